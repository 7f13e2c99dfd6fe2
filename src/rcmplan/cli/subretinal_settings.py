"""What one subretinal episode and a batch of them share on the command line: the settings
read from the options, and the summary of a refused run."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from rcmplan.cli.output import one_line
from rcmplan.exceptions import InvalidInputError

SINGLE_DEFAULTS = {"compensation": "kalman", "ioct_rate_hz": 9.0, "latency_ms": 150.0,
                   "motion_um": 50.0, "eye_drift_um": 0.0, "target_fraction": 0.5}  # fmt: skip


def option(args: argparse.Namespace, name: str) -> Any:
    """An option's value, or its one-episode default when not given."""
    value = getattr(args, name)
    return SINGLE_DEFAULTS[name] if value is None else value


def settings_of(args: argparse.Namespace) -> Any:
    """EpisodeSettings from the options, each checked under its own name and unit."""
    from rcmplan._validate import scalar
    from rcmplan.subretinal.episode_settings import EYE_DRIFT_MAX_M, EpisodeSettings
    from rcmplan.subretinal.layers import RetinaLayers

    compensation = option(args, "compensation")
    if compensation == "all" and args.episodes is None:
        raise InvalidInputError("--compensation", "all", "one method for one episode; all "
                                "with --episodes N")  # fmt: skip
    bpm = args.heart_rate_sd_bpm
    heart_rate_sd_hz = None if bpm is None else scalar("--heart-rate-sd-bpm", bpm, 0.0, 60.0) / 60
    # the depth limit of the default retina (its thickness less the RPE margin) in um
    floor_um = 1e6 * (RetinaLayers.thickness_m - EpisodeSettings.rpe_margin_m)
    puncture_um = scalar("--puncture-depth-um", args.puncture_depth_um, 0.0, floor_um,
                         high_open=True)  # fmt: skip
    fraction = option(args, "target_fraction")
    fraction = scalar("--target-fraction", fraction, 0.0, 1.0, low_open=True, high_open=True)
    drift_um = scalar("--eye-drift-um", option(args, "eye_drift_um"), 0.0, EYE_DRIFT_MAX_M * 1e6)
    return EpisodeSettings(
        robot=args.robot,
        plant=args.plant,
        compensation="kalman" if compensation == "all" else compensation,
        ioct_estimates=args.ioct_estimates,
        ioct_rate_hz=scalar("--ioct-rate-hz", option(args, "ioct_rate_hz"), 0.5, 200.0),
        latency_s=1e-3 * scalar("--latency-ms", option(args, "latency_ms"), 0.0, 1000.0),
        breathing_m=1e-6 * scalar("--motion-um", option(args, "motion_um"), 0.0, 200.0),
        heart_rate_sd_hz=heart_rate_sd_hz,
        seed=args.seed,
        hold_s=scalar("--hold-s", args.hold_s, 0.0, 60.0, low_open=True),
        eye_drift_m=1e-6 * drift_um,
        hover_s=scalar("--hover-s", args.hover_s, 0.0, 60.0),
        target_fraction=fraction,
        puncture_depth_m=1e-6 * puncture_um,
    )


def write_failed(out: Path, status: str, message: str) -> None:
    """summary.json of an episode refused before motion (no log of an earlier run kept)."""
    from rcmplan._atomic import write_text

    for name in ("log.npz", "episode.npz", "bscans.npz"):
        (out / name).unlink(missing_ok=True)
    doc = {"command": "subretinal", "status": status, "message": one_line(message)}
    write_text(out / "summary.json", json.dumps(doc, indent=2))
