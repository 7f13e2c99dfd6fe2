"""`rcmplan subretinal`: one simulated subretinal injection under iOCT with motion compensation,
or with --episodes N many, drawn (`cli/subretinal_episodes.py`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from rcmplan.analysis.units import fmt
from rcmplan.cli import interrupts
from rcmplan.cli.batch_options import add_batch_options
from rcmplan.cli.common import (
    add_json,
    add_no_plots,
    add_out,
    add_plant,
    add_robot,
    announce_robot,
)
from rcmplan.cli.output import finish, interrupted_message, table
from rcmplan.cli.subretinal_settings import settings_of, write_failed
from rcmplan.exceptions import RcmplanError

COMPENSATIONS = ("none", "hold", "fft", "kalman")  # rcmplan.subretinal.predictors.PREDICTORS
IOCT_ESTIMATES = ("image", "noise")  # rcmplan.subretinal.episode_settings.IOCT_ESTIMATES
PLANTS = ("kinematic", "mujoco")  # rcmplan.subretinal.episode_settings.PLANTS_SUPPORTED


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `subretinal` subcommand."""
    p = sub.add_parser(
        "subretinal", help="one simulated subretinal injection under iOCT with motion compensation",
        description="Approach, hover 100 um above the ILM, advance to mid-retina, hold, retract: "
        "the tip target follows the ILM motion predicted from delayed iOCT estimates, one QP "
        "step per 1 kHz period holds the RCM and a depth limit above the estimated RPE "
        "(docs/subretinal.md).",
    )  # fmt: skip
    p.add_argument("--compensation", choices=(*COMPENSATIONS, "all"), default=None,
                   help="predictor of the ILM motion (kalman; with --episodes: all)")  # fmt: skip
    p.add_argument("--ioct-estimates", choices=IOCT_ESTIMATES, default="image",
                   help="where the controller's ILM estimates come from: image (each volume's "
                   "B-scan rendered from the true state and segmented) or noise (a STAND-IN: "
                   "the true displacement plus the segmentation's measured bias and noise, no "
                   "image) (image)")  # fmt: skip
    drawn = "; with --episodes: drawn unless given"
    p.add_argument("--ioct-rate-hz", type=float, default=None,
                   help=f"iOCT volume rate, 0.5-200 (9{drawn})")  # fmt: skip
    p.add_argument("--latency-ms", type=float, default=None,
                   help=f"iOCT latency, 0-1000 (150{drawn})")  # fmt: skip
    p.add_argument("--motion-um", type=float, default=None,
                   help=f"breathing amplitude 0-200 um, cardiac 0.2 of it (50{drawn})")  # fmt: skip
    p.add_argument("--target-fraction", type=float, default=None,
                   help="target depth between ILM (0) and RPE (1), inside the target band's "
                   f"reach (0.5{drawn})")  # fmt: skip
    p.add_argument("--puncture-depth-um", type=float, default=120.0,
                   help="the advance reaches at least this depth below the ILM (past its "
                   "tent, so it gives way) and withdraws to a shallower target, from 0 to "
                   "the depth limit, 225 um (120)")  # fmt: skip
    p.add_argument("--eye-drift-um", type=float, default=None,
                   help="whole-eye translation carrying the trocar: standard deviation per "
                   "axis, 0-5000 um (0: off; with --episodes: fixed, else 0)")  # fmt: skip
    p.add_argument("--heart-rate-sd-bpm", type=float, default=None,
                   help="give kalman the anaesthesia monitor's heart rate, read with this "
                   "error (1 sigma), 0-60 bpm (off)")  # fmt: skip
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the motion and noise; --episodes: of the draws (0)")  # fmt: skip
    add_robot(p, "iramis")
    add_plant(p, PLANTS, "kinematic")
    p.add_argument("--hold-s", type=float, default=5.0, help="injection time, 0-60 s (5)")
    p.add_argument("--hover-s", type=float, default=1.0,
                   help="hover at the stand-off before the advance, 0-60 s (1)")  # fmt: skip
    add_episode_options(p)
    add_out(p, "subretinal")
    add_json(p)
    add_no_plots(p, "the figure")
    p.set_defaults(run=run)


def add_episode_options(p: argparse.ArgumentParser) -> None:
    """The options of many episodes: --episodes and where and how they run."""
    p.add_argument(
        "--episodes",
        type=int,
        default=None,
        help="run N drawn episodes, each with every method (docs/subretinal.md)",
    )
    add_batch_options(p, "run", prefix="--episodes: ")


def run(args: argparse.Namespace) -> int:
    """Run the episode, write log.npz, episode.npz, summary.json and the figure; exit 1 if the
    episode did not end "ok", 2 on a bad option (summary.json then says which). With
    --episodes, run many (`subretinal_episodes.run_episodes`)."""
    from rcmplan.analysis.report import prepare_folder

    if args.episodes is not None:
        from rcmplan.cli.subretinal_episodes import run_episodes

        return run_episodes(args)
    out = prepare_folder(args.out)
    result = None
    try:
        with interrupts.surfaced():
            announce_robot(args.robot, "subretinal")
            settings = settings_of(args)
            result = run_episode(settings)
            doc = write_outputs(settings, out, not args.no_plots, result)
            interrupts.finished()  # inside the handling below: no instant falls between
    except RcmplanError as exc:
        write_failed(out, exc.status, f"{type(exc).__name__}: {exc}")
        raise
    except KeyboardInterrupt as exc:
        if result is None:  # the periods recorded before the interrupt (`Episode.run`), if any
            result = getattr(exc, "result", None)
            message = "" if result is None else result.message
        else:  # the episode ended: its records stay, marked interrupted
            where = "while writing the outputs (the episode had ended)"
            message = interrupted_message(exc, where)
        if result is not None:
            with interrupts.shielded():
                write_records(result, out, "interrupted", message)
        raise
    failure = None if doc["status"] == "ok" else f"{doc['status']}: {doc['message']}"
    return finish(args, out, doc, lambda: print_table(doc), failure)


def run_episode(settings: Any) -> Any:
    """The episode of `settings`, built (its checks pass before any motion), announced on
    stderr, and run (`rcmplan.subretinal.episode.Episode`)."""
    from rcmplan.subretinal.episode import Episode

    episode = Episode(settings)
    print(f"rcmplan subretinal: running the episode: {episode.n_periods} periods of "
          f"{settings.dt * 1e3:g} ms after {settings.warmup_s:g} s of iOCT warm-up",
          file=sys.stderr)  # fmt: skip
    return episode.run()


def write_outputs(settings: Any, out: Path, figures: bool, result: Any = None) -> dict[str, Any]:
    """Run one episode (unless its `result` is given) and write its outputs in `out`; returns
    the summary. The figure is drawn as a run's figures are (`analysis.parallel.run_jobs`)."""
    result = run_episode(settings) if result is None else result
    doc = write_records(result, out)
    if figures:
        from functools import partial

        from rcmplan.analysis import style
        from rcmplan.analysis.parallel import run_jobs
        from rcmplan.subretinal.episode_plot import depth_figure

        style.plt()  # matplotlib imported once, before any fork
        path = out / "figures" / "depth.png"
        run_jobs([(path, partial(depth_figure, result, path))])
        doc["figure"] = str(path)
    return doc


def write_records(result: Any, out: Path, status: str | None = None, message: str = ""
                  ) -> dict[str, Any]:  # fmt: skip
    """log.npz, episode.npz, bscans.npz and summary.json of an episode that ended or was
    stopped (its `status` and `message` replaced when given); returns the summary. An
    interrupted episode's bscans.npz is not written (rendering its B-scans again takes seconds,
    an interrupt is answered at once) and an earlier one is removed; the summary says so."""
    import numpy as np

    from rcmplan._atomic import atomic_path
    from rcmplan.analysis.report import write_json
    from rcmplan.subretinal.episode import PHASES
    from rcmplan.subretinal.episode_metrics import summarise

    result.log.save_npz(out / "log.npz")
    with atomic_path(out / "episode.npz") as tmp, open(tmp, "wb") as fh:
        series: dict[str, Any] = dict(result.series)
        np.savez_compressed(fh, **series, phase_names=np.array(PHASES, dtype=str))
    doc: dict[str, Any] = summarise(result)
    doc.update(replay_fields(result, out, bscans=status != "interrupted"))
    if status is not None:
        doc.update(status=status, message=message)
    write_json(out / "summary.json", doc)
    return doc


BSCANS_SKIPPED = "not written: the episode was interrupted"


def replay_fields(result: Any, out: Path, bscans: bool = True) -> dict[str, Any]:
    """Write bscans.npz (the B-scans of the volumes the controller received; without
    `bscans`, remove an earlier one instead) and return what `rcmplan view` reads from
    summary.json: the periods logged, the eye with the target, the version, the B-scan
    frames."""
    from rcmplan._version import __version__
    from rcmplan.robot.registry import make_robot
    from rcmplan.scene.eye import default_eye
    from rcmplan.scene.record import eye_record
    from rcmplan.subretinal.episode_bscans import episode_bscans
    from rcmplan.subretinal.episode_ioct import bscan_axes

    cfg, layers = result.settings, result.layers
    if bscans:
        frames = episode_bscans(result).save(out / "bscans.npz").name
    else:
        (out / "bscans.npz").unlink(missing_ok=True)
        frames = BSCANS_SKIPPED
    eye = default_eye(make_robot(cfg.robot))
    normal, _ = bscan_axes(eye, cfg.direction)
    target = eye.center + (layers.ilm_radius_m + layers.target_depth_m) * normal
    scene = eye_record(eye, {"target": target}, ["target"])
    return {"periods": len(result.log), "rcmplan_version": __version__, "scene": scene,
            "bscans": frames}  # fmt: skip


def print_table(doc: dict[str, Any]) -> None:
    """The episode's figures, one per line."""

    def um(key: str) -> str:
        return fmt(doc.get(key), "um", with_unit=True)

    rate, latency_ms = doc["ioct_rate_hz"], doc["latency_s"] * 1e3
    source = "segmented B-scans" if doc["ioct_estimates"] == "image" else "noise stand-in"
    print(f"subretinal  robot {doc['robot']}  compensation {doc['compensation']}  "
          f"iOCT {rate:g} Hz, {latency_ms:g} ms  status {doc['status']}")  # fmt: skip
    rows = [
        ["max RCM deviation", um("max_rcm_deviation_m")],
        ["hover tracking RMS (height above the ILM)", um("tracking_rms_m")],
        ["mean depth error during the hold", um("depth_error_m")],
        ["in-band fraction of the hold", fmt(doc["in_band_fraction"])],
        ["deepest point past the RPE (negative: short of it)", um("max_depth_past_rpe_m")],
        ["RPE breach", str(doc["rpe_breach"])],
        ["largest trocar displacement (whole-eye motion)", um("max_trocar_displacement_m")],
        ["prediction RMS", um("prediction_rms_m")],
        [f"ILM estimate error RMS ({source})", um("segmentation_rms_m")],
        ["iOCT volumes delivered, dropped (no ILM segmented)",
         f"{doc['acquisitions_delivered']}, {doc['acquisitions_dropped']}"],
    ]  # fmt: skip
    if doc["ioct_estimates"] == "image":  # the segmentation against the rendered scene
        rows[-1:-1] = [
            ["segmented ILM per A-line: RMS error", um("segmentation_ilm_rms_m")],
            [f"segmented needle tip: RMS error ({doc['tip_segmented']} volumes)",
             um("segmentation_tip_rms_m")],
        ]  # fmt: skip
    print(table(["figure", "value"], rows))
