"""Targets as a user states them, checked before any motion.

"Tip to point P while the RCM stays at trocar point C" fixes the needle line (through C and P),
so it fixes phi, psi and, with the tip's x, the whole extended task X_ext. On iRAM!S the pose
that realises X_ext has a closed form (phi = q1, psi = q3, then q4, q2, q0 from eq. 2.7), which
lets every target be checked for lambda in [0, 1], needle angle and slider travel before motion.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from rcmplan._validate import FloatArray, vector
from rcmplan.control.tasks import angles_from_axis, axis_from_angles
from rcmplan.exceptions import PcjmAngleError, SliderLimitError, UnreachableTargetError
from rcmplan.robot.iramis import Iramis


class Pose(NamedTuple):
    """A robot configuration that realises a target: joints q (6,) and the RCM's lambda."""

    q: FloatArray
    lam: float


def rcm_target(tip: FloatArray, trocar: FloatArray) -> FloatArray:
    """X_ext of "tip at `tip` while the RCM stays at `trocar`" (both (3,) in [m])."""
    x = rcm_targets(vector("tip", tip, 3)[None, :], vector("trocar", trocar, 3))[0]
    if not np.isfinite(x[1]):
        # RCM at the tip (lambda = 1): the needle direction is free; callers pass angles instead.
        raise UnreachableTargetError(
            "the tip coincides with the trocar: the needle axis is undefined"
        )
    return x


def rcm_targets(tips: FloatArray, trocar: FloatArray) -> FloatArray:
    """X_ext (N, 6) for many tip points (N, 3) with the RCM at one trocar; rcm_target per row.

    Rows whose tip lies on the trocar get NaN angles: callers choose the needle direction there.
    """
    tips = np.asarray(tips, dtype=float)
    axis = tips - vector("trocar", trocar, 3)
    with np.errstate(invalid="ignore", divide="ignore"):
        u = axis / np.linalg.norm(axis, axis=1, keepdims=True)
    out = np.empty((tips.shape[0], 6))
    out[:, 0] = tips[:, 0]
    out[:, 1] = np.arctan2(u[:, 2], -u[:, 0])  # angles_from_axis, row by row
    out[:, 2] = np.arctan2(-u[:, 1], np.hypot(u[:, 0], u[:, 2]))
    out[:, 3:] = trocar
    return out


def pivot_target(x_tip: float, phi: float, psi: float, trocar: FloatArray) -> FloatArray:
    """X_ext for explicit needle angles (used while lambda = 1, tip at the trocar)."""
    return np.array([x_tip, phi, psi, *vector("trocar", trocar, 3)])


def tip_of_target(x_ext: FloatArray) -> FloatArray:
    """The tip point that X_ext implies: on the line through p_rcm along the axis, at x = x_tip."""
    axis = axis_from_angles(x_ext[1], x_ext[2])
    if abs(axis[0]) < 1e-12:
        raise UnreachableTargetError("needle axis perpendicular to x: tip x does not fix the tip")
    t = (x_ext[0] - x_ext[3]) / axis[0]
    return x_ext[3:] + t * axis


def solve_pose(robot: Iramis, x_ext: FloatArray) -> Pose:
    """The configuration (q with q5 = 0, lambda) that realises X_ext exactly, or raise.

    Raises UnreachableTargetError when lambda would leave [0, 1], the needle angles leave the
    non-singular range, or a slider leaves its travel.
    """
    x_ext = vector("target", x_ext, 6)
    p = robot.params
    phi, psi = float(x_ext[1]), float(x_ext[2])
    thr = p.singular_threshold
    if min(abs(math.cos(phi)), abs(math.cos(psi))) < thr:
        raise UnreachableTargetError(
            f"needle angles (phi, psi) = ({phi:.4g}, {psi:.4g}) rad leave the reach "
            f"|cos phi|, |cos psi| >= {thr:g}",
            x_ext,
        )
    tip = tip_of_target(x_ext)
    axis = axis_from_angles(phi, psi)
    depth = float(np.dot(tip - x_ext[3:], axis))  # tip ahead of the RCM along the axis
    lam = 1.0 - depth / p.l6
    if -1e-9 <= lam < 0.0 or 1.0 < lam <= 1.0 + 1e-9:  # rounding at the ends of the needle
        lam = min(1.0, max(0.0, lam))
    if not 0.0 <= lam <= 1.0:
        raise UnreachableTargetError(
            f"lambda = {lam:.6g} is outside [0, 1]: the RCM would leave the needle "
            f"(tip {1e3 * depth:.3f} mm ahead of the RCM, needle length {1e3 * p.l6:.1f} mm)",
            x_ext,
        )
    c1, s1, c3, s3 = math.cos(phi), math.sin(phi), math.cos(psi), math.sin(psi)
    w = (p.l2 * s1 - p.l5 * c1 * s3 - tip[0]) / (c1 * c3)  # x row of eq. 2.7
    q2 = tip[1] - (p.l3 + p.l4 - s3 * w + p.l5 * c3)  # y row
    q0 = tip[2] - (p.l1 + p.l2 * c1 + s1 * c3 * w + p.l5 * s1 * s3)  # z row
    q = np.array([q0, phi, q2, psi, w - p.l6, 0.0])
    try:
        robot.check_actuators(robot.actuators_from_joints(q))
    except (SliderLimitError, PcjmAngleError) as exc:
        raise UnreachableTargetError(str(exc), x_ext) from exc
    return Pose(q, lam)


def solve_tip_pose(robot: Iramis, tip: FloatArray, axis: FloatArray) -> FloatArray:
    """Joints q placing the tip at `tip` with the needle along `axis` (unit), checked."""
    phi, psi = angles_from_axis(vector("axis", axis, 3))
    trocar = vector("tip", tip, 3) - 0.5 * robot.params.l6 * axis_from_angles(phi, psi)
    return solve_pose(robot, np.array([tip[0], phi, psi, *trocar])).q
