"""Targets of a curved needle, checked before motion: poses, lateral targets, entry.

A curved needle's target is X_c = (p_tip, rho, p_rcm) (`rcmplan.control.curved`). With the
shaft line through the trocar C and the tip at P, the needle has one freedom left, the roll: the
tip tangent d lies on a cone about v = P - C. Put the shaft's end a distance s beyond C and the
arc's chord (R sin alpha, R (1 - cos alpha)) in the needle's plane (along the shaft a, along the
bevel b): |v|^2 = (s + R sin alpha)^2 + (R (1 - cos alpha))^2 fixes s, the shaft leans
gamma = atan2(R (1 - cos alpha), s + R sin alpha) from v, and the tip tangent beta = alpha - gamma
from v, on the side of the bevel. A lateral target (P, requested direction) keeps the requested
direction's azimuth about v and takes that cone angle (`lateral_target`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from rcmplan._validate import FloatArray, vector
from rcmplan.control.curved import CURVED_TASKS, curved, task_error, task_jacobian
from rcmplan.control.targets import Pose
from rcmplan.exceptions import PcjmAngleError, SliderLimitError, UnreachableTargetError
from rcmplan.robot.curved_needle import CurvedNeedle
from rcmplan.robot.model import RobotModel
from rcmplan.robot.needle import angle_between, closest_lambda, roll_from_axes

POSE_ITERATIONS = 60
POSE_TOLERANCE = 1e-12  # [m] and [rad]


class LateralTarget(NamedTuple):
    """A planned lateral target: X_c (7,), the tip direction it gives and the angle in [rad]
    between that and the requested direction."""

    x: FloatArray
    direction: FloatArray
    deviation: float


def _unit(v: FloatArray) -> FloatArray:
    n = float(np.linalg.norm(v))
    if n < 1e-12:
        raise UnreachableTargetError("a zero-length direction", v)
    return np.asarray(v / n, dtype=float)


def needle_plane(needle: CurvedNeedle, tip: FloatArray, trocar: FloatArray) -> tuple[float, float]:
    """(s, gamma): the shaft's end s [m] beyond the trocar and the shaft's lean gamma [rad] from
    the trocar-to-tip line (module docstring); raises if the tip is too near the trocar."""
    R, al = needle.radius, needle.arc_angle
    c_a, c_b = R * math.sin(al), R * (1.0 - math.cos(al))
    L = float(np.linalg.norm(tip - trocar))
    s = math.sqrt(max(L * L - c_b * c_b, 0.0)) - c_a
    if c_b > L or s < 0.0 or s > needle.shaft_length:
        raise UnreachableTargetError(
            f"the tip {1e3 * L:.3f} mm from the trocar puts the shaft's end {1e3 * s:.3f} mm "
            f"beyond it; valid: [0, {1e3 * needle.shaft_length:.1f}] mm (the RCM on the shaft)",
            tip,
        )
    return s, math.atan2(c_b, s + c_a)


def lateral_target(
    robot: RobotModel, tip: FloatArray, direction: FloatArray, trocar: FloatArray,
    tolerance: float,
) -> LateralTarget:  # fmt: skip
    """X_c for the tip at `tip` approaching along `direction` as near as the needle can (same
    azimuth about the trocar-to-tip line); raises if that is more than `tolerance` [rad] off."""
    needle = curved(robot).needle
    tip, trocar = vector("tip", tip, 3), vector("trocar", trocar, 3)
    v, d_req = _unit(tip - trocar), _unit(vector("direction", direction, 3))
    _, gamma = needle_plane(needle, tip, trocar)
    beta = needle.arc_angle - gamma
    w = d_req - float(d_req @ v) * v
    if np.linalg.norm(w) < 1e-9:  # along the line: any azimuth, take one normal to it
        w = np.cross(v, [0.0, 0.0, 1.0]) if abs(v[2]) < 0.9 else np.cross(v, [1.0, 0.0, 0.0])
    w = _unit(w)
    a = math.cos(gamma) * v - math.sin(gamma) * w
    b = math.sin(gamma) * v + math.cos(gamma) * w
    d = math.cos(beta) * v + math.sin(beta) * w
    deviation = angle_between(d, d_req)
    if deviation > tolerance:
        wanted = angle_between(d_req, v)
        raise UnreachableTargetError(
            f"approach direction {np.round(d_req, 4).tolist()} is {wanted:.4f} rad from the "
            f"trocar-to-tip line; the needle takes {beta:.4f} rad there (valid: within "
            f"{tolerance:.4g} rad of it)",
            tip,
        )
    return LateralTarget(np.array([*tip, roll_from_axes(a, b), *trocar]), d, deviation)


def solve_curved_pose(
    robot: RobotModel, target: FloatArray, seed: FloatArray | None = None
) -> Pose:
    """(q, lambda) realising X_c exactly (Newton's method from `seed`, default home), with lambda
    in [0, 1] and every actuator within travel; else UnreachableTargetError."""
    robot_c = curved(robot)
    target = vector("target", target, 7)
    q = (robot_c.home if seed is None else vector("seed", seed, len(robot_c.home))).copy()
    act = list(robot_c.active)
    lam = _lambda(robot_c, q, target[4:])
    for _ in range(POSE_ITERATIONS):
        e = task_error(CURVED_TASKS, robot_c, q, lam, target)
        if np.abs(e).max() <= POSE_TOLERANCE:
            return _checked(robot_c, q, lam, target)
        d = np.linalg.lstsq(task_jacobian(CURVED_TASKS, robot_c, q, lam), e, rcond=None)[0]
        q[act] += d[:-1]
        lam += float(d[-1])
    raise UnreachableTargetError(
        f"no joints of {robot_c.name} realise the curved-needle target (Newton residual "
        f"{np.abs(e).max():.3g} after {POSE_ITERATIONS} steps)",
        target,
    )


def _lambda(robot: RobotModel, q: FloatArray, trocar: FloatArray) -> float:
    return closest_lambda(robot.needle_point(q, 0.0), robot.needle_point(q, 1.0), trocar)


def _checked(robot: RobotModel, q: FloatArray, lam: float, target: FloatArray) -> Pose:
    if not -1e-9 <= lam <= 1.0 + 1e-9:
        raise UnreachableTargetError(f"lambda = {lam:.6g} is outside [0, 1]", target)
    try:
        robot.check_actuators(robot.actuators_from_joints(q))
    except (SliderLimitError, PcjmAngleError) as exc:
        raise UnreachableTargetError(str(exc), target) from exc
    return Pose(q, min(1.0, max(0.0, lam)))


def tip_direction_error(robot: RobotModel, q: FloatArray, direction: FloatArray) -> float:
    """Angle in [rad] between the tip tangent at joints q and `direction`."""
    d = curved(robot).tip_direction(q)
    return angle_between(d, _unit(direction))
