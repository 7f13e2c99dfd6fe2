"""Targets as a user states them, checked before any motion.

"Tip to point P while the RCM stays at trocar point C" fixes the needle line (through C and P),
so it fixes phi, psi and, with the tip's x, the whole extended task X_ext. The robot model
finds joints that put the tip at P with the needle along that line (`needle_pose`: a closed form
on iRAM!S, phi = q1, psi = q3, then q4, q2, q0 from eq. 2.7; Newton's method on an arm), which
lets every target be checked for lambda in [0, 1], reach and actuator travel before motion.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from rcmplan._validate import F64, WORKSPACE_M, FloatArray, matrix, scalar, vector, workspace_point
from rcmplan.exceptions import (
    InvalidInputError,
    PcjmAngleError,
    SingularPoseError,
    SliderLimitError,
    UnreachableTargetError,
)
from rcmplan.robot.checks import robot_model
from rcmplan.robot.model import RobotModel
from rcmplan.robot.needle import axes_angles, axis_from_angles, x_ext_tip, x_ext_tips


def checked_target(
    target: Any, width: int, name: str = "target", finite: bool = True
) -> FloatArray:
    """target as a float64 array (width,) of finite numbers, or InvalidInputError naming it. A
    float64 array of that shape costs a type test and, unless `finite` is False (its NaN then
    shows in a result the caller tests), one sum: solvers check every call."""
    fast = target.__class__ is np.ndarray and target.dtype is F64 and target.shape == (width,)
    if fast and (not finite or math.isfinite(sum(target.tolist()))):
        return target
    return vector(name, target, width)


def finite_step(d: FloatArray, robot: RobotModel, q: Any, error: Any = None) -> FloatArray:
    """d, a solver's step, if finite; else InvalidInputError naming the error (a non-finite
    task error) or q (joints far out of range), or SingularPoseError (the system was singular:
    `linalg`'s solves then give inf or NaN)."""
    if math.isfinite(sum(d.tolist())):
        return d
    if error is not None:
        vector("error", error, len(error))
    q = vector("q", q, len(robot.home))
    measure = robot.singularity_measure(q)
    if measure < robot.singular_threshold:
        raise SingularPoseError(q, measure, robot.singular_threshold, "singularity measure")
    raise InvalidInputError("q", q, "joints at which the step's system is solvable (finite)")


class Pose(NamedTuple):
    """A robot configuration that realises a target: joints q (6,) and the RCM's lambda."""

    q: FloatArray
    lam: float


def rcm_target(tip: FloatArray, trocar: FloatArray) -> FloatArray:
    """X_ext of "tip at `tip` while the RCM stays at `trocar`" (both (3,) in [m], each
    coordinate within WORKSPACE_M of the base, else InvalidInputError)."""
    tip, trocar = workspace_point("tip", tip), workspace_point("trocar", trocar)
    x = rcm_targets(tip[None, :], trocar)[0]
    if not np.isfinite(x[1]):
        # RCM at the tip (lambda = 1): the needle direction is free; callers pass angles instead.
        raise UnreachableTargetError(
            "the tip coincides with the trocar: the needle axis is undefined"
        )
    return x


def rcm_targets(tips: FloatArray, trocar: FloatArray) -> FloatArray:
    """X_ext (N, 6) for many tip points (N, 3) with the RCM at one trocar (3,), or at each
    row's trocar (N, 3) (a trocar that moves); rcm_target per row.

    Rows whose tip lies on the trocar get NaN angles: callers choose the needle direction there.
    """
    tips = np.asarray(tips, dtype=float)
    shape = np.shape(trocar)
    if len(shape) == 2:
        trocar = matrix("trocar", trocar, (tips.shape[0], 3))
    else:
        trocar = vector("trocar", trocar, 3)
    axis = tips - trocar
    with np.errstate(invalid="ignore", divide="ignore"):
        u = axis / np.linalg.norm(axis, axis=1, keepdims=True)
    out, angles = np.empty((tips.shape[0], 6)), np.empty((tips.shape[0], 2))
    axes_angles(u, angles)  # a C-contiguous array for any N: one compiled version
    out[:, 0], out[:, 1:3], out[:, 3:] = tips[:, 0], angles, trocar
    return out


def pivot_target(x_tip: float, phi: float, psi: float, trocar: FloatArray) -> FloatArray:
    """X_ext for explicit needle angles (used while lambda = 1, tip at the trocar).

    Raises InvalidInputError for a non-finite x_tip [m], angles outside [-pi, pi] [rad], or a
    trocar that is not 3 finite numbers."""
    x = scalar("x_tip", x_tip)
    a = scalar("phi", phi, -math.pi, math.pi)
    b = scalar("psi", psi, -math.pi, math.pi)
    if abs(x) > WORKSPACE_M:
        raise InvalidInputError("x_tip", x_tip, f"within +-{WORKSPACE_M:g} m of the base")
    return np.array([x, a, b, *workspace_point("trocar", trocar)])


def tip_of_target(x_ext: FloatArray) -> FloatArray:
    """The tip point that X_ext implies: on the line through p_rcm along the axis, at x = x_tip."""
    tip = np.empty(3)
    if not x_ext_tip(np.ascontiguousarray(x_ext, dtype=np.float64), np.empty(3), tip):
        raise UnreachableTargetError("needle axis perpendicular to x: tip x does not fix the tip")
    return tip


def target_tip(target: FloatArray, kind: str = "rcm") -> FloatArray:
    """The tip point a target asks for: a tip point (3,) itself, the first three entries of a
    curved needle's target (7,) (`rcmplan.control.curved`), the tip X_ext (6,) implies."""
    if kind == "free" or target.shape[0] == 7:
        return np.asarray(target[:3], dtype=float)
    return tip_of_target(target)


def target_tips(targets: FloatArray) -> FloatArray:
    """`target_tip` of each row of an RCM phase's targets (N, 6) or a curved needle's (N, 7),
    in one compiled call: the tip points (N, 3) [m]. Raises UnreachableTargetError as
    tip_of_target does, naming the first such target."""
    targets = np.ascontiguousarray(targets, dtype=np.float64)
    if targets.shape[1] == 7:
        return targets[:, :3].copy()
    tips = np.empty((targets.shape[0], 3))
    k = x_ext_tips(targets, tips)
    if k >= 0:
        raise UnreachableTargetError(
            f"target {k}: needle axis perpendicular to x: tip x does not fix the tip", targets[k]
        )
    return tips


def solve_pose(robot: RobotModel, x_ext: FloatArray, seed: FloatArray | None = None) -> Pose:
    """A configuration (q, lambda) that realises X_ext exactly, or raise.

    Raises UnreachableTargetError when the robot cannot point the needle that way, lambda would
    leave [0, 1], or an actuator leaves its travel.

    Raises InvalidInputError unless robot is a robot model and x_ext 6 finite numbers, its
    positions within WORKSPACE_M of the base and its angles in [-pi, pi].

    Args:
        seed: Joints to start an iterative search from (the previous target's, along a path).
    """
    robot_model("robot", robot)
    x_ext = vector("x_ext", x_ext, 6)
    x, phi, psi, *trocar = x_ext.tolist()
    if max(abs(x), *map(abs, trocar)) > WORKSPACE_M or max(abs(phi), abs(psi)) > math.pi:
        valid = (
            f"(x_tip, phi, psi, trocar): positions within +-{WORKSPACE_M:g} m, angles in [-pi, pi]"
        )
        raise InvalidInputError("x_ext", x_ext, valid)
    tip = tip_of_target(x_ext)
    if max(map(abs, tip.tolist())) > WORKSPACE_M:
        raise UnreachableTargetError(f"the tip lies beyond +-{WORKSPACE_M:g} m of the base", x_ext)
    try:
        q = robot.needle_pose(tip, phi, psi, seed)
    except UnreachableTargetError as exc:
        if exc.target is not None:
            raise
        raise UnreachableTargetError(exc.reason, x_ext) from exc
    axis = axis_from_angles(phi, psi)
    length = robot.needle_length
    depth = float(np.dot(tip - x_ext[3:], axis))  # tip ahead of the RCM along the axis
    lam = 1.0 - depth / length
    # Within the loop's default position tolerance (1e-8 m) of an end of the needle: at it.
    slack = 1e-8 / length
    if -slack <= lam < 0.0 or 1.0 < lam <= 1.0 + slack:
        lam = min(1.0, max(0.0, lam))
    if not 0.0 <= lam <= 1.0:
        raise UnreachableTargetError(
            f"lambda = {lam:.6g} is outside [0, 1]: the RCM would leave the needle "
            f"(tip {1e3 * depth:.3f} mm ahead of the RCM, needle length {1e3 * length:.1f} mm)",
            x_ext,
        )
    try:
        robot.check_actuators(robot.actuators_from_joints(q))
    except (SliderLimitError, PcjmAngleError) as exc:
        raise UnreachableTargetError(str(exc), x_ext) from exc
    return Pose(q, lam)
