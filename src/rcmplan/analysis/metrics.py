"""Metrics of a run, read only from the run log.

RCM deviation is p_rcm(lambda) - trocar per record (the thesis's measure, figs. 4.1-4.5): its
components and norm. With drift correction on, lambda puts p_rcm at the needle point closest to
the trocar, so the norm equals the distance from the trocar to the needle line.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from rcmplan.control.log import RunLog
from rcmplan.robot.model import RobotModel


@dataclass(frozen=True)
class PhaseMetrics:
    """Figures of one phase; lengths in [m], time in [s]. RCM figures are None in free space."""

    name: str
    inside_eye: bool
    iterations: int
    steps: int
    max_rcm_deviation_m: float | None
    rms_rcm_deviation_m: float | None
    max_rcm_deviation_xyz_m: tuple[float, float, float] | None
    rms_rcm_deviation_xyz_m: tuple[float, float, float] | None
    final_tip_error_m: float
    max_tracking_error_m: float
    wall_time_s: float

    def as_dict(self) -> dict[str, object]:
        """Plain JSON-ready dictionary."""
        return asdict(self)


def phase_metrics(log: RunLog, wall_times: dict[str, float] | None = None) -> list[PhaseMetrics]:
    """Metrics for every phase of the log, in the order the phases ran."""
    out = []
    wall_times = wall_times or {}
    for pid, name in enumerate(log.phase_names):
        m = log.phase == pid
        if not np.any(m):
            continue
        sub = log.select(m)
        inside = bool(np.all(np.isfinite(sub.trocar)))
        dev = sub.rcm_deviation()
        norm = np.linalg.norm(dev, axis=1)
        tip_err = np.linalg.norm(sub.tip - sub.target_tip, axis=1)
        out.append(
            PhaseMetrics(
                name=name,
                inside_eye=inside,
                iterations=len(sub),
                steps=int(sub.step.max()) + 1,
                max_rcm_deviation_m=float(norm.max()) if inside else None,
                rms_rcm_deviation_m=float(np.sqrt(np.mean(norm**2))) if inside else None,
                max_rcm_deviation_xyz_m=_triple(np.abs(dev).max(axis=0)) if inside else None,
                rms_rcm_deviation_xyz_m=_triple(np.sqrt(np.mean(dev**2, axis=0)))
                if inside
                else None,
                final_tip_error_m=float(tip_err[-1]),
                max_tracking_error_m=float(tip_err.max()),
                wall_time_s=float(wall_times.get(name, 0.0)),
            )
        )
    return out


def _triple(v: np.ndarray) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


@dataclass(frozen=True)
class SliderUse:
    """Range of each slider used in a run and the smallest margin to its travel limits."""

    lower_used: tuple[float, ...]
    upper_used: tuple[float, ...]
    min_margin: tuple[float, ...]

    def as_dict(self) -> dict[str, object]:
        """Plain JSON-ready dictionary."""
        return asdict(self)


def slider_use(log: RunLog, robot: RobotModel) -> SliderUse:
    """Slider ranges used and margin to travel, per slider ([m], q5 in [rad])."""
    if len(log) == 0:
        nan = (float("nan"),) * len(robot.lower)
        return SliderUse(nan, nan, nan)
    lo, hi = log.sliders.min(axis=0), log.sliders.max(axis=0)
    margin = np.minimum(lo - robot.lower, robot.upper - hi)
    return SliderUse(tuple(map(float, lo)), tuple(map(float, hi)), tuple(map(float, margin)))


def overall(phases: list[PhaseMetrics]) -> dict[str, float | None]:
    """The run's headline figures, in [m]: `max_rcm_deviation_m`, the largest RCM deviation
    over the phases inside the eye (None when no record held an RCM: a run stopped before it
    entered the eye), and `max_tip_error_m`, the worst tip error at the end of a phase inside
    the eye, or at the end of each phase the run has when it stopped before entering (None only
    for a run without records)."""
    inside = [p for p in phases if p.inside_eye]
    measured = inside or phases
    return {
        "max_rcm_deviation_m": max((p.max_rcm_deviation_m or 0.0 for p in inside), default=None),
        "max_tip_error_m": max((p.final_tip_error_m for p in measured), default=None),
    }
