"""The reachable retina of a straight and a curved needle, from poses alone (no motion).

Retina points are spread evenly over the retinal sphere (a Fibonacci lattice of n points, each
standing for 4 pi r^2 / n of retina); points behind the trocar's tangent plane are left out. A
point is reachable by the straight needle if a pose puts its tip there with the needle through
the trocar, lambda in [0, 1], every actuator within travel and away from the singular set
(`rcmplan.control.targets.solve_pose`). The curved needle reaches it if, for one of `rolls`
needle rolls evenly spaced over a turn, Newton's method (`solve_curved_pose`, seeded by the
straight needle's pose or home) finds such a pose and the model's singularity check passes; a
roll where Newton's method fails counts as unreachable, so the curved area is a lower bound.
For each point the approach angle (tip direction to the retina's outward normal) is kept for
every reachable roll.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.control.curved_targets import solve_curved_pose
from rcmplan.control.targets import rcm_target, solve_pose
from rcmplan.exceptions import RcmplanError
from rcmplan.robot.curved import CurvedTipRobot
from rcmplan.robot.needle import angle_between
from rcmplan.scene.eye import Eye


class ReachMap:
    """Arrays of a reach map; see `reach_map`."""

    def __init__(self, points: FloatArray, cell_m2: float, straight: FloatArray,
                 angles: FloatArray) -> None:  # fmt: skip
        self.points, self.cell_m2 = points, cell_m2
        self.straight_angle = straight  # (N,) approach angle [rad], NaN: unreachable
        self.curved_angles = angles  # (N, rolls) approach angles [rad], NaN: unreachable

    def summary(self) -> dict[str, float]:
        """Areas in [mm^2], their ratio and the approach-angle ranges in [rad]."""
        curved = np.isfinite(self.curved_angles).any(axis=1)
        straight = np.isfinite(self.straight_angle)
        span = np.nanmax(self.curved_angles[curved], axis=1) - np.nanmin(
            self.curved_angles[curved], axis=1
        )
        a_s, a_c = 1e6 * self.cell_m2 * straight.sum(), 1e6 * self.cell_m2 * curved.sum()
        return {
            "straight_area_mm2": float(a_s),
            "curved_area_mm2": float(a_c),
            "area_ratio": float(a_c / a_s) if a_s > 0 else math.inf,
            "both_area_mm2": float(1e6 * self.cell_m2 * (straight & curved).sum()),
            "curved_angle_span_median_rad": float(np.median(span)) if span.size else math.nan,
            "curved_min_angle_median_rad": float(np.median(np.nanmin(
                self.curved_angles[curved], axis=1))) if curved.any() else math.nan,
            "straight_angle_median_rad": float(np.nanmedian(self.straight_angle))
            if straight.any() else math.nan,
        }  # fmt: skip


class _Pose(NamedTuple):
    q: FloatArray | None
    angle: float


def retina_lattice(eye: Eye, n: int) -> tuple[FloatArray, float]:
    """Points on the retina in front of the trocar (k, 3) and the area each stands for [m^2]."""
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    phi = math.pi * (3.0 - math.sqrt(5.0)) * i
    r = np.sqrt(1.0 - z * z)
    unit = np.column_stack([r * np.cos(phi), r * np.sin(phi), z])
    pts = eye.center + eye.retina_radius * unit
    front = (pts - eye.port) @ eye.axis > 1e-4
    return pts[front], 4.0 * math.pi * eye.retina_radius**2 / n


def _straight(robot: CurvedTipRobot, eye: Eye, p: FloatArray) -> _Pose:
    try:
        pose = solve_pose(robot.base, rcm_target(p, eye.port))
        robot.base.check_singularity(pose.q)
    except RcmplanError:
        return _Pose(None, math.nan)
    return _Pose(pose.q, angle_between(robot.base.needle_axis(pose.q), p - eye.center))


def _curved(robot: CurvedTipRobot, eye: Eye, p: FloatArray, roll: float,
            seed: FloatArray | None) -> float:  # fmt: skip
    try:
        pose = solve_curved_pose(robot, np.array([*p, roll, *eye.port]), seed)
        robot.check_singularity(pose.q)
    except RcmplanError:
        return math.nan
    return angle_between(robot.tip_direction(pose.q), p - eye.center)


def reach_map(robot: CurvedTipRobot, eye: Eye, n: int = 2000, rolls: int = 12) -> ReachMap:
    """The reach map of `robot`'s curved needle beside its straight shaft (module docstring)."""
    pts, cell = retina_lattice(eye, n)
    straight = np.full(len(pts), math.nan)
    angles = np.full((len(pts), rolls), math.nan)
    roll_values = -math.pi + 2.0 * math.pi * (np.arange(rolls) + 0.5) / rolls
    for i, p in enumerate(pts):
        base = _straight(robot, eye, p)
        straight[i] = base.angle
        for j, roll in enumerate(roll_values):
            angles[i, j] = _curved(robot, eye, p, float(roll), base.q)
    return ReachMap(pts, cell, straight, angles)
