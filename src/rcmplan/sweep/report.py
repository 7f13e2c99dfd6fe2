"""What a sweep reports: a JSON-ready summary, a per-target CSV and the rows of a text table."""

from __future__ import annotations

import csv
import math
from collections import Counter
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from rcmplan._atomic import atomic_path
from rcmplan.robot.registry import summary_fields
from rcmplan.sweep.fundus import CAUSE_KEYS, CAUSES, causes
from rcmplan.sweep.gains import Evaluation, GainSearchResult
from rcmplan.sweep.runner import SweepResult
from rcmplan.sweep.sampling import STATUS_NAMES
from rcmplan.sweep.task import STATUSES, TargetResult

UM = 1e6
# Units of the settings block, whose keys are hashed into checkpoints and so keep their names
SETTINGS_UNITS = {
    **{f"settings.region.{k}": u for k, u in (("max_angle", "rad"), ("standoff", "m"))},
    **{f"settings.motion.{k}": u for k, u in (
        ("damping", "m"), ("tolerance_position", "m"), ("tolerance_angle", "rad"),
        ("step_position", "m"), ("step_angle", "rad"), ("dt", "s"), ("eye_radius", "m"),
        ("eye_wall", "m"), ("trocar_radius", "m"), ("trocar_offset", "m"),
        ("insertion_angles", "rad"), ("start_depth", "m"), ("K", "dimensionless"),
        ("rcm_bound", "m"), ("rcm_tolerance", "m"),
        ("method_options", "the unit each key names (a scenario's [qp] keys)"))},
    "iterations": "control iterations per target",
}  # fmt: skip


def _stats(values: list[float]) -> dict[str, float | None]:
    if not values:
        return {"mean": None, "median": None, "p95": None, "max": None}
    a = np.asarray(values, dtype=float)
    return {
        "mean": float(a.mean()),
        "median": float(np.median(a)),
        "p95": float(np.percentile(a, 95)),
        "max": float(a.max()),
    }


def summary(result: SweepResult) -> dict[str, Any]:
    """Counts and figures of a sweep; lengths in [m], times in [s]."""
    rs = result.ordered()
    ok = [r for r in rs if r.converged]
    fresh = len(rs) - result.resumed
    return {
        **summary_fields(result.settings.motion.robot),
        "settings": result.settings.as_dict(),
        "settings_hash": result.settings.digest(),
        "executor": result.executor,
        "targets": {
            "sampled": len(result.sample),
            **result.sample.counts(),
            "run": len(rs),
            "resumed_from_checkpoint": result.resumed,
            "by_status": status_counts(rs),
            "by_cause": cause_counts(result),
        },
        "iterations": {
            **_stats([float(r.iterations) for r in ok]),
            "total": sum(r.iterations for r in rs),
        },
        "max_rcm_deviation_m": _stats(
            [r.max_rcm_deviation_m for r in rs if r.max_rcm_deviation_m is not None]
        ),
        "tip_error_m": _stats([r.tip_error_m for r in ok if r.tip_error_m is not None]),
        "wall_time_s": result.wall_time_s,
        "compute_time_s": sum(r.wall_time_s for r in rs),
        "units": SETTINGS_UNITS,
        "targets_run_now": fresh,
        "targets_per_s": fresh / result.wall_time_s if fresh and result.wall_time_s > 0 else None,
    }


def status_counts(results: list[TargetResult]) -> dict[str, int]:
    """Targets per status: every one of `task.STATUSES` (0 when none), then any other status a
    motion reported (another error's `RcmplanError.status`)."""
    counts = Counter(r.status for r in results)
    return {s: counts[s] for s in (*STATUSES, *sorted(set(counts) - set(STATUSES)))}


def cause_counts(result: SweepResult) -> dict[str, int]:
    """Number of sampled targets per cause (converged, failed, and why the rest are refused)."""
    found = causes(result.sample, result.column("converged"))
    return {key: int(np.sum(found == i)) for i, key in enumerate(CAUSE_KEYS)}


def summary_rows(s: dict[str, Any]) -> list[list[str]]:
    """(figure, value, unit) rows of the summary for a text table."""
    t, it = s["targets"], s["iterations"]
    dev, tip = s["max_rcm_deviation_m"], s["tip_error_m"]
    return [
        ["targets sampled", str(t["sampled"]), ""],
        ["reachable / out of reach / miss retina",
         f"{t['reachable']} / {t['unreachable']} / {t['misses_retina']}", ""],
        ["converged", f"{t['by_status']['ok']} of {t['run']}", ""],
        ["out of reach, by cause", ", ".join(
            f"{CAUSES[CAUSE_KEYS.index(k)]} {v}" for k, v in t["by_cause"].items()
            if v and k not in ("converged", "motion_failed")) or "none", ""],
        ["iterations per target (median / max)", f"{_g(it['median'])} / {_g(it['max'])}", ""],
        ["max RCM deviation (median / p95 / max)",
         f"{_g(dev['median'], UM)} / {_g(dev['p95'], UM)} / {_g(dev['max'], UM)}", "um"],
        ["final tip error (max)", _g(tip["max"], UM), "um"],
        ["wall time", _g(s["wall_time_s"]), "s"],
        ["targets per second (this run)", _g(s["targets_per_s"]) if s["targets_per_s"]
         else "- (every target came from the checkpoint)", "1/s"],
        ["executor", s["executor"], ""],
    ]  # fmt: skip


def gain_rows(search: GainSearchResult) -> list[list[str]]:
    """One row per evaluated candidate, best first, then by cost: the candidate's settings as
    given (`fmt_setting`), its figures to three significant digits (`fmt`)."""
    from rcmplan.analysis.units import fmt_setting

    evs = sorted(search.evaluations, key=lambda e: (not e.feasible, e.cost))
    return [
        [fmt_setting(e.candidate.k_task), fmt_setting(e.candidate.k_rcm),
         fmt_setting(1e3 * e.candidate.step_position), _g(e.mean_iterations),
         _g(e.max_rcm_deviation_m, UM), _g(e.converged_fraction),
         "yes" if e.feasible else "no", "*" if e == search.best else ""]
        for e in evs
    ]  # fmt: skip


GAIN_HEADER = ["k_task", "k_rcm", "step [mm]", "mean iterations", "max RCM dev [um]",
               "converged", "feasible", "best"]  # fmt: skip


def gain_summary(search: GainSearchResult) -> dict[str, Any]:
    """The gain search as JSON-ready data: objective, best candidate, every evaluation."""

    def ev(e: Evaluation | None) -> dict[str, Any] | None:
        return None if e is None else {**asdict(e), "candidate": asdict(e.candidate)}

    return {
        "mode": search.mode,
        "objective": "minimise mean iterations per target subject to every target converging "
        "and max RCM deviation <= rcm_bound_m",
        "rcm_bound_m": search.objective.rcm_bound_m,
        "subsample_ids": list(search.subsample_ids),
        "message": search.message,
        "best": ev(search.best),
        "evaluations": [ev(e) for e in search.evaluations],
    }


def write_targets_csv(result: SweepResult, path: Path) -> Path:
    """One row per sampled target: ray, point, reachability and the motion's figures (SI)."""
    sample = result.sample
    head = ["id", "tilt_e1_deg", "tilt_e2_deg", "x_m", "y_m", "z_m", "reachability", "status",
            "iterations", "max_rcm_deviation_m", "tip_error_m", "wall_time_s"]  # fmt: skip
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(head)
        for i in range(len(sample)):
            r = result.results.get(i)
            tilt = [f"{math.degrees(v):.6g}" for v in sample.tilt[i]]
            row = [i, *tilt, *(repr(float(v)) for v in sample.points[i])]
            row.append(STATUS_NAMES[sample.status[i]])
            if r is None:
                row += ["", "", "", "", ""]
            else:
                row += [r.status, r.iterations, _repr(r.max_rcm_deviation_m),
                        _repr(r.tip_error_m), repr(r.wall_time_s)]  # fmt: skip
            w.writerow(row)
    return path


def _g(v: float | None, scale: float = 1.0) -> str:
    """The one formatter of rcmplan's tables (3 significant digits)."""
    from rcmplan.analysis.units import fmt

    return fmt(None if v is None else v * scale)


def _repr(v: float | None) -> str:
    return "" if v is None else repr(v)
