"""Compiled checks of any serial arm: the Newton IK that screens targets before motion; the
singularity measure and its certificate are `chain_kinematics`'s (re-exported here)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from rcmplan._validate import FloatArray
from rcmplan.compiled.kernels import dls_solve, gauss_solve
from rcmplan.robot.chain_kinematics import (
    ROWS,
    E,
    F,
    IntArray,
    Z,
    angle_rows,
    frames,
    needle_axis,
    needle_point,
    point_jacobian,
)
from rcmplan.robot.needle import axis_angles, x_ext_tip


@njit(cache=True)
def needle_pose(A: FloatArray, ix: IntArray, W: FloatArray, tip: FloatArray, phi: float,
                psi: float, q: FloatArray, max_it: int, tol: float) -> int:  # fmt: skip
    """`SerialArm.needle_pose` from the seed q (updated in place): Newton's method with
    minimum-norm steps on (tip [m], phi, psi [rad]) over the active joints, angle errors
    wrapped to [-pi, pi). Returns the steps taken when every error is within tol, -1 when
    max_it checks fail (the reference's cap: its exception)."""
    n, m = ix[0], ix[1]
    o = 4 * (n + 1)
    J, S, v = W[o:], W[o + ROWS :], o + 2 * ROWS
    err, f, dq = W[v + E], W[v + F], W[v + Z]
    for it in range(max_it):
        frames(A, ix, q, W)
        px, py, pz = needle_point(A, n, W, 1.0)
        ax, ay, az = needle_axis(A, n, W)
        err[0], err[1], err[2] = tip[0] - px, tip[1] - py, tip[2] - pz
        phi_now, psi_now = axis_angles(ax, ay, az)
        err[3], err[4] = phi - phi_now, psi - psi_now
        within = True  # every |error| <= tol (False for NaN)
        for i in range(5):
            if i >= 3:
                err[i] = (err[i] + math.pi) % (2.0 * math.pi) - math.pi
            within &= abs(err[i]) <= tol
        if within:
            return it
        point_jacobian(A, ix, W, 1.0, J, 0)
        angle_rows(A, ix, W, False, J, 3)
        if m == 5:
            for i in range(5):
                for j in range(5):
                    S[i, j] = J[i, j]
            gauss_solve(S, err, 5, dq)
        else:
            dls_solve(J, err, 0.0, 5, m, S, f, dq)
        for j in range(m):
            q[ix[2 + n + j]] += dq[j]
    return -1


@njit(cache=True)
def screen_targets(
    A: FloatArray, ix: IntArray, W: FloatArray, lower: FloatArray, upper: FloatArray,
    home: FloatArray, max_it: int, clear_it: int, tol: float, targets: FloatArray,
    flags: NDArray[np.bool_],
) -> None:  # fmt: skip
    """flags[k] = True where X_ext target k may fail `solve_pose` along the path (each Newton
    solve seeded with the previous target's joints, the first with home, as
    `Controller.check_targets`). Cleared: a finite target whose tip x fixes the tip, whose
    Newton solve takes at most clear_it of the max_it steps, and whose lambda and joints lie
    inside [0, 1] and the travel by a margin (1e-12, 1e-9)."""
    n = ix[0]
    length = A[5 * n + 12, 0]
    slack = 1e-8 / length  # `solve_pose`: within 1e-8 m of a needle end counts as at it
    q, a, tip = home.copy(), np.empty(3), np.empty(3)
    for k in range(targets.shape[0]):
        x = targets[k]
        flags[k] = True
        finite = True
        for i in range(6):
            finite &= math.isfinite(x[i])
        if not finite or not x_ext_tip(x, a, tip) or abs(a[0]) < 2e-12:
            continue
        it = needle_pose(A, ix, W, tip, x[1], x[2], q, max_it, tol)
        if it < 0 or it > clear_it:
            continue
        depth = (tip[0] - x[3]) * a[0] + (tip[1] - x[4]) * a[1] + (tip[2] - x[5]) * a[2]
        lam = 1.0 - depth / length
        if not -slack + 1e-12 <= lam <= 1.0 + slack - 1e-12:
            continue
        inside = True
        for i in range(n):
            inside &= lower[i] + 1e-9 <= q[i] <= upper[i] - 1e-9
        flags[k] = not inside
