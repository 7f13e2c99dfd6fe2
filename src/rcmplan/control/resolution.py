"""Loop tolerances a plant's actuator resolution can meet, derived from that resolution.

A plant that rounds every command to whole actuator steps (`actuator_resolution`, (n,) in [m]
or [rad]; the MuJoCo plants) cannot put the needle closer to a target than the nearest grid
point allows: with every actuator within half a step of the exact solution, an error
component X_j stays within b_j = sum_i |dX_j / ds_i| res_i / 2 (first order). The loop
(Algorithm 1) stops only when every component is within its tolerance, so a tolerance below
b_j may never be met (1 nm slider steps turn an iRAM!S PCJM by 33 nrad: an angle tolerance of
10 nrad stalls). `resolution_tolerance` gives twice the largest b_j of each unit at the home
pose (the lever arms change by up to 20 % over the default injection, measured, and the
servo's settling residual must fit as well); `met_tolerance` raises a requested tolerance to
it. A plant that reaches its commands exactly (no `actuator_resolution`, or None) changes
nothing.

`quantised` is the rounding itself, the one every user of a resolution calls: the MuJoCo
plants' servo references, and the QP's plan from the servo's last command (`QpSolver`, and in
compiled code the iRAM!S and arm servo steps).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.control.solvers import Tolerance
from rcmplan.robot.model import RobotModel

MARGIN = 2.0  # the tolerance over the grid's first-order error bound at the home pose


@njit(cache=True, borrows=True)
def quantised(s: FloatArray, res: FloatArray, out: FloatArray) -> None:
    """The command s (n,) as a plant with resolution res (n,) reaches it: each s[i] rounded to
    a whole number of steps res[i] (to even on a tie; res[i] = 0: s[i] as it is), into out
    (n,). ValueError if res or out is not as long as s."""
    if res.shape[0] != s.shape[0] or out.shape[0] != s.shape[0]:
        raise ValueError("quantised: s, res and out must have the same length")
    for i in range(s.shape[0]):
        out[i] = s[i] if res[i] == 0.0 else np.rint(s[i] / res[i]) * res[i]


def plant_resolution(plant: Any) -> FloatArray | None:
    """The plant's actuator resolution (n,) if it rounds its commands, else None."""
    res = getattr(plant, "actuator_resolution", None)
    return None if res is None else np.asarray(res, dtype=float)


def grid_error_bound(robot: RobotModel, resolution: FloatArray, q: FloatArray) -> Tolerance:
    """(position [m], angle [rad]): the largest first-order error of the nearest grid point
    at q over the tip, the needle's two ends (every needle point lies between) and the needle
    angles."""
    active = list(robot.active)
    half = 0.5 * np.asarray(resolution, dtype=float)[active]
    ds = robot.joint_rates(q)[np.ix_(active, active)]  # d q[active] / d s[active]
    points = [robot.tip_jacobian(q)] + [robot.needle_point_jacobian(q, lam) for lam in (0.0, 1.0)]
    position = max(float(np.max(np.abs(J[:, :-1] @ ds) @ half)) for J in points)
    angles = robot.needle_angles_jacobian(q)[:, :-1] @ ds
    return Tolerance(position, float(np.max(np.abs(angles) @ half)))


def resolution_tolerance(robot: RobotModel, resolution: FloatArray) -> Tolerance:
    """The smallest loop tolerance the resolution supports: MARGIN times the grid's error bound
    at the home pose (see the module docstring)."""
    b = grid_error_bound(robot, resolution, robot.home)
    return Tolerance(MARGIN * b.position, MARGIN * b.angle)


def met_tolerance(tol: Tolerance, robot: RobotModel, plant: Any) -> Tolerance:
    """`tol`, each unit raised to what the plant's resolution supports (unchanged, the same
    object, on a plant without a resolution)."""
    res = plant_resolution(plant)
    if res is None:
        return tol
    floor = resolution_tolerance(robot, res)
    if tol.position >= floor.position and tol.angle >= floor.angle:
        return tol
    return Tolerance(max(tol.position, floor.position), max(tol.angle, floor.angle))
