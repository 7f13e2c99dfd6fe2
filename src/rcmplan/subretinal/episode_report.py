"""The figures of a batch of subretinal episodes, per method, from its per-episode records.

Per method: episodes run, successes and the success rate (`EpisodeRecord.success`), RPE
breaches, the median and 95th percentile of the hover tracking RMS, the median of the mean depth
error and of the depth RMS error during the hold, the mean in-band fraction, the largest RCM
deviation and the largest trocar displacement (whole-eye motion), the median of the episodes'
iOCT estimate error RMS and the iOCT volumes dropped (no ILM segmented). Curves: the same
success rate and median tracking RMS in bins of the drawn iOCT volume rate (log-spaced) and
latency. SI units throughout.
"""

from __future__ import annotations

import csv
import json
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

from rcmplan._atomic import atomic_path, write_text
from rcmplan.robot.registry import summary_fields
from rcmplan.subretinal.episode_batch import COLUMNS, BatchSettings, EpisodeRecord

CURVE_BINS = 6
CURVE_AXES = {"ioct_rate_hz": True, "latency_s": False}  # name: log-spaced bins
TOP_FIELDS = ("episodes", "successes", "success_rate", "rpe_breaches", "tracking_rms_m_median",
              "depth_error_m_median")  # fmt: skip
CHOICE_ONE = "the only method run"
CHOICE_BEST = "the highest success rate, then the lowest median tracking RMS"


def _values(records: list[EpisodeRecord], name: str) -> list[float]:
    return [float(v) for r in records if (v := getattr(r, name)) is not None]


def _median(values: list[float]) -> float | None:
    return float(np.median(values)) if values else None


def method_summary(records: list[EpisodeRecord]) -> dict[str, Any]:
    """The figures of one method's records (module docstring)."""
    n = len(records)
    successes = sum(r.success for r in records)
    tracking = _values(records, "tracking_rms_m")
    rcm = _values(records, "max_rcm_deviation_m")
    trocar = _values(records, "max_trocar_displacement_m")
    in_band = _values(records, "in_band_fraction")
    return {
        "episodes": n,
        "successes": successes,
        "success_rate": successes / n if n else None,
        "rpe_breaches": sum(r.rpe_breach is True for r in records),
        "tracking_rms_m_median": _median(tracking),
        "tracking_rms_m_p95": float(np.percentile(tracking, 95)) if tracking else None,
        "depth_error_m_median": _median(_values(records, "depth_error_m")),
        "depth_rms_error_m_median": _median(_values(records, "depth_rms_error_m")),
        "in_band_fraction_mean": float(np.mean(in_band)) if in_band else None,
        "max_rcm_deviation_m": max(rcm) if rcm else None,
        "max_trocar_displacement_m": max(trocar) if trocar else None,
        "segmentation_rms_m_median": _median(_values(records, "segmentation_rms_m")),
        "acquisitions_dropped": int(sum(_values(records, "acquisitions_dropped"))),
        "statuses": dict(Counter(r.status for r in records)),
        "wall_time_s_median": _median([r.wall_time_s for r in records]),
    }


def curve_edges(bounds: tuple[float, float], log: bool, bins: int = CURVE_BINS) -> list[float]:
    """Bin edges over a drawn range; one bin when the range is one value."""
    lo, hi = bounds
    if hi <= lo:
        return [lo, hi]
    return [float(x) for x in (np.geomspace if log and lo > 0 else np.linspace)(lo, hi, bins + 1)]


def curve(records: list[EpisodeRecord], name: str, edges: list[float]) -> dict[str, Any]:
    """Per bin of the drawn condition `name`: episodes, success rate, median tracking RMS."""
    x = np.array([getattr(r.draw, name) for r in records], dtype=float)
    nb = len(edges) - 1
    idx = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, nb - 1)
    out: dict[str, list[Any]] = {"episodes": [], "success_rate": [], "tracking_rms_m_median": []}
    for b in range(nb):
        inside = [r for r, i in zip(records, idx, strict=True) if i == b]
        out["episodes"].append(len(inside))
        out["success_rate"].append(sum(r.success for r in inside) / len(inside) if inside else None)
        out["tracking_rms_m_median"].append(_median(_values(inside, "tracking_rms_m")))
    return out


def best_method(methods: dict[str, dict[str, Any]]) -> str:
    """The method with the highest success rate, then the lowest median tracking RMS."""

    def key(name: str) -> tuple[float, float]:
        m = methods[name]
        rate, tracking = m["success_rate"], m["tracking_rms_m_median"]
        return (-(rate if rate is not None else -1.0),
                tracking if tracking is not None else float("inf"))  # fmt: skip

    return min(methods, key=key)


def batch_summary(batch: BatchSettings, records: list[EpisodeRecord]) -> dict[str, Any]:
    """summary.json's figures: per method under "methods", the chosen one at the top level
    ("method" and why, "method_choice"), the curves, and the batch's settings."""
    by_method = {m: [r for r in records if r.compensation == m] for m in batch.methods}
    methods = {m: method_summary(rs) for m, rs in by_method.items()}
    chosen = best_method(methods)
    top = methods[chosen]
    curves = {}
    for name, log in CURVE_AXES.items():
        edges = curve_edges(getattr(batch.ranges, name), log)
        per_method = {m: curve(rs, name, edges) for m, rs in by_method.items()}
        curves[name] = {"edges": edges, "methods": per_method}
    return {
        "command": "subretinal",
        "mode": "episodes",
        **summary_fields(batch.base.robot),
        "episodes_planned": batch.episodes,
        "jobs_planned": batch.n_items,
        "jobs_run": len(records),
        "method": chosen,
        "method_choice": CHOICE_ONE if len(methods) == 1 else CHOICE_BEST,
        "ioct_estimates": batch.base.ioct_estimates,
        **{k: top[k] for k in TOP_FIELDS},
        "success": "status ok (no RPE breach, RCM within its bound, ILM punctured) and in the "
        "target band for the whole hold",
        "methods": methods,
        "curves": curves,
        "settings": batch.as_dict(),
    }


def write_records(records: list[EpisodeRecord], out: Path) -> dict[str, Path]:
    """episodes.csv and episodes.json (one row per job, sorted by id) in `out`."""
    rows = [r.as_dict() for r in sorted(records, key=lambda r: r.id)]
    csv_path = out / "episodes.csv"
    with atomic_path(csv_path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=COLUMNS)
        writer.writeheader()
        writer.writerows([{k: ("" if v is None else v) for k, v in row.items()} for row in rows])
    json_path = write_text(out / "episodes.json", json.dumps(rows, indent=1))
    return {"csv": csv_path, "json": json_path}
