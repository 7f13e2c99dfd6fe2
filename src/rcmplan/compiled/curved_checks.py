"""Compiled screen of a curved needle's targets before motion: `solve_curved_pose`'s Newton
method on X_c along a path, on iRAM!S (`curved_iramis`) or an arm (`curved_arm`).

Each target's Newton solve starts from the previous target's joints (the first from the seed),
updates (q[active], lambda) by the least-squares step of J_c (square: its solve; wider: the
minimum-norm step) until every |X_c error| <= tol, then checks lambda and the actuators, as
`rcmplan.control.curved_targets.solve_curved_pose` does. A target is cleared when its solve
takes at most `clear_it` steps and lambda and every actuator lie inside their ranges by a margin
(1e-9); the others are flagged for the reference check. Imports numba.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.control import curved_step
from rcmplan.control.curved_step import CURVED_PINV
from rcmplan.robot import curved_arm
from rcmplan.robot import curved_block as ck
from rcmplan.robot.chain_kinematics import IntArray, frames, needle_point
from rcmplan.robot.iramis_kernels import actuators_from_joints, point, trig
from rcmplan.robot.needle import closest_point

MARGIN = 1e-9  # [m], [rad]: how far inside lambda's [0, 1] and the travel a cleared target lies
LAMBDA_SLACK = 1e-9  # `solve_curved_pose` accepts lambda within this of [0, 1]


@njit(cache=True)
def within(e: FloatArray, tol: float) -> bool:
    """Every |e_i| <= tol (False for NaN)."""
    for i in range(ck.WIDTH):  # noqa: SIM110 (a plain loop compiles best)
        if not abs(e[i]) <= tol:
            return False
    return True


@njit(cache=True)
def lambda_clear(lam: float) -> bool:
    """lambda inside `solve_curved_pose`'s range by the margin."""
    return -LAMBDA_SLACK + MARGIN <= lam <= 1.0 + LAMBDA_SLACK - MARGIN


@njit(cache=True)
def screen_iramis(P: FloatArray, seed: FloatArray, max_it: int, clear_it: int, tol: float,
                  targets: FloatArray, flags: NDArray[np.bool_],
                  q: FloatArray) -> None:  # fmt: skip
    """flags[k] = True where iRAM!S's curved target k may fail `solve_curved_pose` along the
    path from `seed` (module docstring); q ends at the last target's joints."""
    e, d, w, s = np.empty(7), np.empty(7), np.empty(3), np.empty(6)
    C, K = np.empty((ck.BLOCK_ROWS, 7)), np.ones(7)
    for i in range(6):
        q[i] = seed[i]
    for k in range(targets.shape[0]):
        x = targets[k]
        tr = trig(q)
        point(P, q, tr, 0.0, w)
        base = (w[0], w[1], w[2])
        point(P, q, tr, 1.0, w)
        lam = closest_point(base, (w[0], w[1], w[2]), x[4:])[0]
        steps = -1
        for it in range(max_it):
            tr = trig(q)
            curved_step.iramis_task_error(P, CURVED_PINV, q, tr, lam, x, e, w)
            if within(e, tol):
                steps = it
                break
            curved_step.iramis_pinv_step(P, K, q, tr, lam, e, d, w, C)
            for i in range(6):
                q[i] += d[i]
            lam += d[6]
        flags[k] = True
        if steps < 0 or steps > clear_it or not lambda_clear(lam):
            continue
        if not actuators_from_joints(P, q, s):
            continue
        inside = True
        for i in range(6):
            inside &= P[7 + i] + MARGIN <= s[i] <= P[13 + i] - MARGIN
        flags[k] = not inside


@njit(cache=True)
def screen_arm(A: FloatArray, ix: IntArray, W: FloatArray, lower: FloatArray,
               upper: FloatArray, seed: FloatArray, max_it: int, clear_it: int, tol: float,
               targets: FloatArray, flags: NDArray[np.bool_], q: FloatArray) -> None:  # fmt: skip
    """flags[k] = True where an arm's curved target k may fail `solve_curved_pose` along the
    path from `seed` (module docstring); q ends at the last target's joints."""
    n = ix[0]
    c = curved_arm.block_row(n)
    first, mc = curved_arm.active_span(ix)
    e, d, K = np.empty(7), np.empty(mc + 1), np.ones(7)
    for i in range(n):
        q[i] = seed[i]
    for j in range(mc + 1):
        W[c + ck.Z, j] = 0.0  # no posture: the plain least-squares step
    for k in range(targets.shape[0]):
        x = targets[k]
        frames(A, ix, q, W)
        lam = closest_point(needle_point(A, n, W, 0.0), needle_point(A, n, W, 1.0), x[4:])[0]
        steps = -1
        for it in range(max_it):
            if it > 0:
                frames(A, ix, q, W)
            curved_step.arm_task_error(A, ix, W, CURVED_PINV, lam, x, e)
            if within(e, tol):
                steps = it
                break
            curved_arm.jacobian(A, ix, W, lam, False)
            curved_step.step(W, c, CURVED_PINV, mc, K, 0.0, A[5 * n + 12, 0], e, d)
            for j in range(mc):
                q[ix[first + j]] += d[j]
            lam += d[mc]
        flags[k] = True
        if steps < 0 or steps > clear_it or not lambda_clear(lam):
            continue
        inside = True
        for i in range(n):
            inside &= math.isfinite(q[i]) and lower[i] + MARGIN <= q[i] <= upper[i] - MARGIN
        flags[k] = not inside
