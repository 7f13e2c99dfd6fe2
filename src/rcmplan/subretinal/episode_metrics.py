"""The figures of one subretinal episode, from its per-period series (SI units)."""

from __future__ import annotations

from typing import Any

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.robot.registry import summary_fields
from rcmplan.subretinal.episode import PHASES, EpisodeResult
from rcmplan.subretinal.episode_settings import (
    SEGMENTATION_BIAS_M,
    SEGMENTATION_STD_M,
    EpisodeSettings,
)
from rcmplan.subretinal.layers import in_target_band
from rcmplan.subretinal.segment_error import rms_m
from rcmplan.subretinal.tissue import TissueState


def ioct_source(cfg: EpisodeSettings) -> str:
    """What the controller's iOCT estimates were, in words."""
    if cfg.ioct_estimates == "image":
        return ("segmented from the B-scan rendered from the true state at each acquisition "
                "(speckle, the needle and its shadow, the ILM tented under the tip)")  # fmt: skip
    measured = ", the measured sd" if cfg.noise_std_m == SEGMENTATION_STD_M else ""
    bias, sd = SEGMENTATION_BIAS_M * 1e6, cfg.noise_std_m * 1e6
    stand_in = "measured-noise stand-in for the segmented B-scans, no image"
    return f"{stand_in} (bias {bias:.2f} um, sd {sd:.2f} um{measured})"


def segmentation_figures(result: EpisodeResult) -> dict[str, Any]:
    """The iOCT volumes delivered to the controller and the error of what it received [m]:
    the ILM displacement delivered less the truth (RMS and mean, over the volumes that
    delivered one) and, for "image" estimates, the segmentation against the rendered scene
    (per A-line ILM and RPE depth, the needle tip where one was segmented; RMS over volumes)."""
    trace, received = result.trace, result.received
    error = trace.estimate_m - trace.truth_m
    errors = trace.errors
    image = result.settings.ioct_estimates == "image"
    tips = [e.tip_m for e in errors]
    return {
        "acquisitions_delivered": len(received),
        "acquisitions_dropped": trace.dropped,
        "segmentation_rms_m": _rms(error),
        "segmentation_bias_m": _mean(error),
        "segmentation_ilm_rms_m": rms_m([e.ilm_rms_m for e in errors]) if image else None,
        "segmentation_rpe_rms_m": rms_m([e.rpe_rms_m for e in errors]) if image else None,
        "segmentation_tip_rms_m": rms_m(tips) if image else None,
        "tip_segmented": sum(t is not None for t in tips) if image else None,
        "tip_in_window": int(sum(r.tip_in_window for r in received)),
        "segmentation_by_phase": segmentation_by_phase(result),
    }


def segmentation_by_phase(result: EpisodeResult) -> dict[str, dict[str, Any]]:
    """Per phase of its acquisition ("warmup" before the approach): the volumes delivered and
    dropped, the ILM displacement delivered less the truth (RMS, mean, largest) [m], and with
    "image" estimates the volumes whose true tip lay in the window, those with a segmented tip
    and its error (RMS, median) [m]."""
    starts = [("warmup", -np.inf), *result.phase_starts_s.items()]
    out: dict[str, dict[str, Any]] = {}
    for (name, t0), (_, t1) in zip(starts, [*starts[1:], ("", np.inf)], strict=True):
        mine = [r for r in result.received if t0 <= r.t_acq_s < t1]
        if not mine:
            continue
        got = np.array([r.estimate_m - r.scene.ilm_offset_m for r in mine
                        if r.estimate_m is not None])  # fmt: skip
        tips = np.array([r.error.tip_m for r in mine if r.error and r.error.tip_m is not None])
        image = result.settings.ioct_estimates == "image"
        out[name] = {
            "volumes": len(mine),
            "dropped": len(mine) - got.size,
            "rms_m": _rms(got),
            "mean_m": _mean(got),
            "max_abs_m": float(np.abs(got).max()) if got.size else None,
            "tip_in_window": int(sum(r.tip_in_window for r in mine)),
            "tip_segmented": int(tips.size) if image else None,
            "tip_rms_m": _rms(tips) if image else None,
            "tip_median_m": float(np.median(tips)) if image and tips.size else None,
        }
    return out


def _rms(x: FloatArray) -> float | None:
    return float(np.sqrt(np.mean(np.square(x)))) if x.size else None


def _mean(x: FloatArray) -> float | None:
    return float(np.mean(x)) if x.size else None


def trocar_motion(result: EpisodeResult) -> tuple[float, float]:
    """The trocar's largest distance [m] from where it was in the first period, and its
    largest move in one period [m] (whole-eye motion; both 0 when the eye stays put)."""
    trocar = result.log.trocar
    if trocar.shape[0] < 2:
        return 0.0, 0.0
    away = np.linalg.norm(trocar - trocar[0], axis=1).max()
    return float(away), float(np.linalg.norm(np.diff(trocar, axis=0), axis=1).max())


def episode_status(result: EpisodeResult, breach: bool, punctured: bool) -> tuple[str, str]:
    """(status, message): the run's own status if it stopped, else "rpe_breach" if the tip
    passed the RPE, "not_punctured" if it never entered the retina, else "ok"."""
    if result.status != "ok":
        return result.status, result.message
    if breach:
        return "rpe_breach", "the tip passed the RPE surface"
    if not punctured:
        return "not_punctured", "the tip never passed the ILM"
    return "ok", ""


def summarise(result: EpisodeResult) -> dict[str, Any]:
    """summary.json of an episode: settings, status and the measured figures (SI units)."""
    cfg, layers, s = result.settings, result.layers, result.series
    phase = s["phase"].astype(int)
    hover, hold = phase == PHASES.index("hover"), phase == PHASES.index("hold")
    depth = s["depth_m"]
    past = depth - layers.thickness_m
    breach = bool(np.any(past > 0.0))
    punctured = bool(np.any(s["tissue_state"] == int(TissueState.PUNCTURED)))
    status, message = episode_status(result, breach, punctured)
    height_error = -depth[hover] - cfg.standoff_m
    band = np.asarray(in_target_band(layers, depth[hold]), dtype=bool)
    trocar = trocar_motion(result)
    return {
        "command": "subretinal",
        "status": status,
        "message": message,
        **summary_fields(cfg.robot),
        "plant": cfg.plant,
        "compensation": cfg.compensation,
        "ioct_rate_hz": cfg.ioct_rate_hz,
        "latency_s": cfg.latency_s,
        "ioct_estimates": cfg.ioct_estimates,
        "ioct_source": ioct_source(cfg),
        "noise_std_m": cfg.noise_std_m if cfg.ioct_estimates == "noise" else None,
        "heart_rate_sd_hz": cfg.heart_rate_sd_hz,
        "breathing_amplitude_m": cfg.breathing_m,
        "cardiac_amplitude_m": cfg.cardiac_m,
        "breathing_rate_hz": cfg.breathing_rate_hz,
        "cardiac_rate_hz": cfg.cardiac_rate_hz,
        "target_fraction": cfg.target_fraction,
        "seed": cfg.seed,
        "hold_s": cfg.hold_s,
        "standoff_m": cfg.standoff_m,
        "target_depth_m": layers.target_depth_m,
        "target_band_m": list(layers.band_m),
        "thickness_m": layers.thickness_m,
        "rpe_margin_m": cfg.rpe_margin_m,
        "puncture_depth_m": cfg.puncture_depth_m,
        "depth_limit": cfg.depth_limit,
        "duration_s": float(s["t_s"].size * cfg.dt),
        "max_rcm_deviation_m": float(s["rcm_deviation_m"].max()) if s["t_s"].size else 0.0,
        "eye_drift_m": cfg.eye_drift_m,
        "eye_drift_time_s": cfg.eye_drift_time_s,
        "max_trocar_displacement_m": trocar[0],
        "max_trocar_step_m": trocar[1],
        "tracking_rms_m": _rms(height_error),
        "depth_error_m": _mean(depth[hold] - layers.target_depth_m),
        "depth_rms_error_m": _rms(depth[hold] - layers.target_depth_m),
        "in_band_fraction": float(np.mean(band)) if band.size else 0.0,
        "punctured": punctured,
        "rpe_breach": breach,
        "max_depth_past_rpe_m": float(past.max()) if past.size else None,
        **segmentation_figures(result),
        "prediction_rms_m": _rms(s["predicted_m"] - s["wall_m"]),
        "phase_starts_s": result.phase_starts_s,
    }
