"""`rcmplan teleop`: a teleoperated session from a replay file or the synthetic surgeon."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

from rcmplan._validate import integer, scalar
from rcmplan.cli import interrupts
from rcmplan.cli.common import (
    SEED_MAX,
    add_json,
    add_no_plots,
    add_out,
    add_plant,
    add_robot,
    add_scenario,
    announce_robot,
)
from rcmplan.cli.output import finish, interrupted_message, one_line, table
from rcmplan.exceptions import RcmplanError

FILTERS = ("none", "lowpass", "wflc")  # rcmplan.teleop.FILTERS (a test checks they agree)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `teleop` subcommand."""
    text = "a teleoperated session: clutch, motion scaling, tremor filter, virtual fixtures"
    p = sub.add_parser(
        "teleop", help=text,
        description="Drive the needle from a master input through the clutch, motion scaling "
        "and a tremor filter, with the RCM, a retina no-go margin, a workspace box and actuator "
        "speed held by the QP at every 1 kHz period. The default input is a 20 s synthetic "
        "surgeon (100 um RMS tremor) who pushes the tip past the retina margin once.",
    )  # fmt: skip
    add_scenario(
        p,
        None,
        "scenario lending its robot and plant (a straight needle, the robot's default eye)",
        unset="none: iramis on the kinematic plant",
    )
    add_robot(p, unset="the scenario's, else iramis")
    add_plant(p, unset="the scenario's, else kinematic")
    p.add_argument("--input", default="synthetic", metavar="synthetic|FILE",
                   help="'synthetic' or a replay file (.csv or .npz; docs/teleop.md)")  # fmt: skip
    p.add_argument("--scale", type=float, default=20.0, help="motion scaling, 1-50 (20)")
    p.add_argument("--filter", choices=FILTERS, default="wflc", help="tremor filter (wflc)")
    p.add_argument("--seed", type=int, default=0, help="seed of the synthetic surgeon (0)")
    p.add_argument("--tremor-um", type=float, default=100.0,
                   help="synthetic tremor, RMS of its 3-D magnitude, 0-5000 um "
                   "(100)")  # fmt: skip
    add_out(p, "teleop")
    add_json(p)
    add_no_plots(p)
    p.set_defaults(run=run)


def settings_of(args: argparse.Namespace) -> Any:
    """TeleopSettings from the options, each checked under its own name and unit; a scenario
    lends its robot and plant where --robot and --plant do not name them."""
    from rcmplan.teleop import TeleopSettings
    from rcmplan.teleop.scaling import SCALE_RANGE
    from rcmplan.teleop.settings import session_scenario

    robot, plant = args.robot or "iramis", args.plant or "kinematic"
    if args.scenario:
        sc = session_scenario(args.scenario, args.robot)[0]
        robot, plant = sc.robot, args.plant or sc.plant
    announce_robot(robot, "teleop")
    scale = scalar("--scale", args.scale, *SCALE_RANGE)
    return TeleopSettings(robot=robot, plant=plant, scale=scale, filter=args.filter)


def track_of(args: argparse.Namespace, settings: Any) -> Any:
    """The input track: the synthetic surgeon, or the file (checked row by row)."""
    from rcmplan.teleop import SyntheticSurgeon, read_track
    from rcmplan.teleop.synthetic import TREMOR_RMS_MAX_M

    if args.input == "synthetic":
        seed = integer("--seed", args.seed, 0, SEED_MAX)
        tremor_um = scalar("--tremor-um", args.tremor_um, 0.0, 1e6 * TREMOR_RMS_MAX_M)
        return SyntheticSurgeon(seed=seed, tremor_rms=tremor_um * 1e-6).track()
    return read_track(args.input, settings.max_input_speed)


def run(args: argparse.Namespace) -> int:
    """Run the session, write the outputs, print the summary; exit 1 if it stopped early or
    broke a fixture. Interrupted, it writes what it has with status "interrupted" and
    re-raises (exit 130 or 143)."""
    from rcmplan.analysis.report import prepare_folder
    from rcmplan.teleop import run_replay
    from rcmplan.teleop.outputs import write_outputs

    out = prepare_folder(args.out)
    result, doc = None, None
    try:
        with interrupts.surfaced():
            settings = settings_of(args)
            track = track_of(args, settings)
            result = run_replay(settings, track)
            doc, _ = write_outputs(result, out, figures=not args.no_plots)
            interrupts.finished()  # inside the handling below: no instant falls between
    except RcmplanError as exc:
        if result is None:
            write_failed(out, exc.status, f"{type(exc).__name__}: {exc}")
            raise
        print(f"rcmplan teleop: could not write all outputs: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        write_interrupted(out, exc, result)
        raise
    failure = None if doc["status"] == "ok" else f"{doc['status']}: {doc['message']}"
    return finish(args, out, doc, lambda: print_table(doc), failure)


def write_failed(out: Path, status: str, message: str) -> None:
    """summary.json of a session refused before motion (no log of an earlier run kept)."""
    with interrupts.shielded():
        interrupts.write_stop_file(out, "teleop", {"status": status, "message": one_line(message)})


def write_interrupted(out: Path, exc: KeyboardInterrupt, result: Any) -> None:
    """The partial log and summary.json with status "interrupted" (figures skipped)."""
    from rcmplan.teleop.outputs import write_summary

    if result is None:
        result = getattr(exc, "result", None)
        where = "during the session" if result is not None else "before the session"
    else:
        where = f"while writing the outputs (the session ended with status {result.status!r})"
    message = interrupted_message(exc, where)
    if result is None:
        write_failed(out, "interrupted", message)
        return
    with interrupts.shielded():
        write_summary(replace(result, status="interrupted", message=message), out, csv=False)


def print_table(doc: dict[str, Any]) -> None:
    """The session's figures, one per line, each through `analysis.units.fmt`."""
    from rcmplan.analysis.units import fmt, fmt_setting

    def f(key: str, unit: str = "um") -> str:
        return fmt(doc.get(key), unit, with_unit=doc.get(key) is not None)

    print(f"teleop  robot {doc['robot']}  plant {doc['plant']}  input {doc['input']}  "
          f"filter {doc['filter']}  scale {fmt_setting(doc['scale'])}  "
          f"status {doc['status']}")  # fmt: skip
    rows = [
        ["max RCM deviation", f("max_rcm_deviation_m")],
        ["tip tremor RMS, 6-16 Hz", f("tip_tremor_rms_m")],
        ["input tremor RMS, 6-16 Hz (scaled)", f("input_tremor_rms_m")],
        ["tracking RMS (free space)", f("tracking_rms_m")],
        ["added lag", f("added_lag_s", "ms")],
        ["closest approach to the retina", f("retina_min_distance_m", "mm")],
        ["retina margin", f("retina_margin_m", "mm")],
        ["limit violations", ", ".join(f"{k} {v:,}" for k, v in doc["limit_violations"].items())],
    ]
    print(table(["figure", "value"], rows))
    for note in doc.get("released_past_fixture", []):
        print(f"t = {fmt(note['t_s'], 's')} s: {note['note']}")
