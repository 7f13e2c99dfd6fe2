"""summary.json of a session: the figures other checks rely on, SI units in every key.

Fields: status, message, max_rcm_deviation_m, tip_tremor_rms_m, input_tremor_rms_m,
tracking_rms_m, added_lag_s, limit_violations (per kind), retina_min_distance_m, and beside
them the session's settings, fixture activity, clutch events, timing (`teleop.metrics` defines
each figure).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rcmplan._version import __version__
from rcmplan.robot.registry import summary_fields
from rcmplan.scene.record import eye_record
from rcmplan.teleop import metrics
from rcmplan.teleop.run import TeleopResult
from rcmplan.teleop.violations import fixture_active, retina_distance


def summary(result: TeleopResult) -> dict[str, Any]:
    """The summary.json contract (module docstring)."""
    cfg, log, trace, session = result.settings, result.log, result.trace, result.session
    eye, box, rate = session.eye, session.box, cfg.rate_hz
    engaged = trace.engaged
    dev = np.linalg.norm(log.rcm - log.trocar, axis=1)
    active = fixture_active(trace.desired, eye, box, cfg.fixtures.retina_margin)
    to_tip = session.pipeline.scaling.rotation / cfg.scale
    known = result.intended is not None
    intended = metrics.estimate_intended(trace.master, rate)
    if result.intended is not None:
        intended = result.intended
    ref = metrics.reference(log.tip, trace.segment, intended, to_tip)
    free = engaged & metrics.free_mask(
        retina_distance(eye, trace.desired), box.depth(trace.desired), cfg.fixtures.retina_margin
    )
    tip_band = metrics.band_rms(log.tip, engaged, rate)
    input_band = metrics.band_rms(trace.master / cfg.scale, engaged, rate)
    out: dict[str, Any] = {
        "command": "teleop",
        "status": result.status,
        "message": result.message,
        **summary_fields(cfg.robot),
        "plant": cfg.plant,
        "input": result.source,
        "filter": cfg.filter,
        "filter_delay_s": result.filter_delay_s,
        "scale": cfg.scale,
        "max_rcm_deviation_m": float(dev.max()) if dev.size else None,
        "rms_rcm_deviation_m": float(np.sqrt(np.mean(dev**2))) if dev.size else None,
        "tip_tremor_rms_m": tip_band,
        "input_tremor_rms_m": input_band,
        **metrics.summary_band({"tip_tremor_rms_m": tip_band, "input_tremor_rms_m": input_band}),
        "tracking_rms_m": metrics.tracking_rms(log.tip, ref, free),
        "tracked_fraction": float(free.sum() / engaged.sum()) if engaged.any() else None,
        "intended_source": "input" if known else "zero-phase 2 Hz low-pass of the input",
        "added_lag_s": metrics.added_lag(log.tip, ref, free, rate),
        "limit_violations": dict(result.violations),
        "retina_min_distance_m": float(retina_distance(eye, log.tip).min()) if len(log) else None,
        "retina_margin_m": cfg.fixtures.retina_margin,
        "rcm_limit_m": cfg.fixtures.rcm_limit,
        "fixture_active_s": {k: float(m.sum()) * cfg.dt for k, m in active.items()},
        "clutch_events": result.events,
        "released_past_fixture": released_past_fixture(result, active),
        "simulated_time_s": float(log.time[-1]) if len(log) else 0.0,
        "periods": len(log),
        "engaged_s": float(engaged.sum()) * cfg.dt,
        "pipeline_time_us": _timing(trace.pipeline_s),
        "control_time_us": _timing(trace.control_s),
        "pacing": dict(result.pacing),
        "wall_time_s": result.wall_time_s,
        "rcmplan_version": __version__,
        "scene": eye_record(eye),  # the eye and trocar, for readers such as `rcmplan view`
    }
    return out


def released_past_fixture(
    result: TeleopResult, active: dict[str, np.ndarray]
) -> list[dict[str, Any]]:
    """Each clutch release while the desired tip lay past a fixture: the target was out of
    reach, and the needle held where the fixture had stopped it."""
    out = []
    times = result.trace.time
    for ev in result.events:
        if ev["kind"] != "released":
            continue
        k = int(np.searchsorted(times, float(ev["t_s"]))) - 1  # type: ignore[arg-type]
        past = [name for name, m in active.items() if 0 <= k < m.shape[0] and m[k]]
        if past:
            note = f"released while the desired tip lay past {' and '.join(past)}: the needle "
            note += "held at the fixture"
            out.append({"t_s": ev["t_s"], "fixtures": past, "held_tip_m": ev["tip_m"],
                        "note": note})  # fmt: skip
    return out


def _timing(seconds: np.ndarray) -> dict[str, float | None]:
    """Median and 99th percentile of per-period wall times, in [us]."""
    if seconds.size == 0:
        return {"median": None, "p99": None}
    return {"median": float(np.median(seconds)) * 1e6,
            "p99": float(np.percentile(seconds, 99)) * 1e6}  # fmt: skip
