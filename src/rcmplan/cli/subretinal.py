"""`rcmplan subretinal`: one simulated subretinal injection under iOCT with motion compensation."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from rcmplan.analysis.units import fmt
from rcmplan.cli.common import (
    add_json,
    add_no_plots,
    add_out,
    add_plant,
    add_robot,
    announce_robot,
)
from rcmplan.cli.output import finish, one_line, table
from rcmplan.exceptions import RcmplanError

COMPENSATIONS = ("none", "hold", "fft", "kalman")  # rcmplan.subretinal.predictors.PREDICTORS


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `subretinal` subcommand."""
    p = sub.add_parser(
        "subretinal", help="one simulated subretinal injection under iOCT with motion compensation",
        description="Approach, hover 100 um above the ILM, advance to mid-retina, hold, retract: "
        "the tip target follows the ILM motion predicted from delayed iOCT estimates, one QP "
        "step per 1 kHz period holds the RCM and a depth limit above the estimated RPE "
        "(docs/subretinal.md).",
    )  # fmt: skip
    p.add_argument("--compensation", choices=COMPENSATIONS, default="kalman",
                   help="predictor of the ILM motion (kalman)")  # fmt: skip
    p.add_argument("--ioct-rate-hz", type=float, default=9.0, help="iOCT volume rate, 0.5-200 (9)")
    p.add_argument("--latency-ms", type=float, default=150.0, help="iOCT latency, 0-1000 (150)")
    p.add_argument("--motion-um", type=float, default=50.0,
                   help="breathing amplitude, 0-200 um; cardiac 0.2 of it (50)")  # fmt: skip
    p.add_argument("--seed", type=int, default=0, help="seed of the motion and iOCT noise (0)")
    add_robot(p, "iramis")
    add_plant(p, ("kinematic",), "kinematic")
    p.add_argument("--hold-s", type=float, default=5.0, help="injection time, 0-60 s (5)")
    add_out(p, "subretinal")
    add_json(p)
    add_no_plots(p, "the figure")
    p.set_defaults(run=run)


def settings_of(args: argparse.Namespace) -> Any:
    """EpisodeSettings from the options, each checked under its own name and unit."""
    from rcmplan._validate import scalar
    from rcmplan.subretinal.episode_settings import EpisodeSettings

    return EpisodeSettings(
        robot=args.robot,
        plant=args.plant,
        compensation=args.compensation,
        ioct_rate_hz=scalar("--ioct-rate-hz", args.ioct_rate_hz, 0.5, 200.0),
        latency_s=1e-3 * scalar("--latency-ms", args.latency_ms, 0.0, 1000.0),
        breathing_m=1e-6 * scalar("--motion-um", args.motion_um, 0.0, 200.0),
        seed=args.seed,
        hold_s=scalar("--hold-s", args.hold_s, 0.0, 60.0, low_open=True),
    )


def run(args: argparse.Namespace) -> int:
    """Run the episode, write log.npz, episode.npz, summary.json and the figure; exit 1 if the
    episode did not end "ok", 2 on a bad option (summary.json then says which)."""
    from rcmplan.analysis.report import prepare_folder

    out = prepare_folder(args.out)
    try:
        announce_robot(args.robot, "subretinal")
        settings = settings_of(args)
        doc = write_outputs(settings, out, figures=not args.no_plots)
    except RcmplanError as exc:
        write_failed(out, exc.status, f"{type(exc).__name__}: {exc}")
        raise
    failure = None if doc["status"] == "ok" else f"{doc['status']}: {doc['message']}"
    return finish(args, out, doc, lambda: print_table(doc), failure)


def write_outputs(settings: Any, out: Path, figures: bool) -> dict[str, Any]:
    """Run one episode and write its outputs in `out`; returns the summary."""
    import numpy as np

    from rcmplan._atomic import atomic_path, write_text
    from rcmplan.analysis.report import jsonable
    from rcmplan.subretinal.episode import PHASES, run_episode
    from rcmplan.subretinal.episode_metrics import summarise

    result = run_episode(settings)
    result.log.save_npz(out / "log.npz")
    with atomic_path(out / "episode.npz") as tmp, open(tmp, "wb") as fh:
        series: dict[str, Any] = dict(result.series)
        np.savez_compressed(fh, **series, phase_names=np.array(PHASES, dtype=str))
    doc: dict[str, Any] = jsonable(summarise(result))
    write_text(out / "summary.json", json.dumps(doc, indent=2))
    if figures:
        from rcmplan.subretinal.episode_plot import depth_figure

        doc["figure"] = str(depth_figure(result, out / "figures" / "depth.png"))
    return doc


def write_failed(out: Path, status: str, message: str) -> None:
    """summary.json of an episode refused before motion (no log of an earlier run kept)."""
    from rcmplan._atomic import write_text

    for name in ("log.npz", "episode.npz"):
        (out / name).unlink(missing_ok=True)
    doc = {"command": "subretinal", "status": status, "message": one_line(message)}
    write_text(out / "summary.json", json.dumps(doc, indent=2))


def print_table(doc: dict[str, Any]) -> None:
    """The episode's figures, one per line."""

    def um(key: str) -> str:
        return fmt(doc.get(key), "um", with_unit=True)

    rate, latency_ms = doc["ioct_rate_hz"], doc["latency_s"] * 1e3
    print(f"subretinal  robot {doc['robot']}  compensation {doc['compensation']}  "
          f"iOCT {rate:g} Hz, {latency_ms:g} ms  status {doc['status']}")  # fmt: skip
    rows = [
        ["max RCM deviation", um("max_rcm_deviation_m")],
        ["hover tracking RMS (height above the ILM)", um("tracking_rms_m")],
        ["mean depth error during the hold", um("depth_error_m")],
        ["in-band fraction of the hold", fmt(doc["in_band_fraction"])],
        ["deepest point past the RPE (negative: short of it)", um("max_depth_past_rpe_m")],
        ["RPE breach", str(doc["rpe_breach"])],
        ["prediction RMS", um("prediction_rms_m")],
        ["segmentation RMS", um("segmentation_rms_m")],
    ]
    print(table(["figure", "value"], rows))
