"""One iteration of Algorithm 1 for a serial arm, compiled: what `Controller.converge` does
between reading the plant and commanding it, in the same order.

From the joints q = s (an arm's actuators are its joints): frames, drift correction (lambda of
the needle point closest to the trocar), the solver's task error, the record (from the second
iteration on), the per-component tolerance check, the iteration cap, the singularity check
(`SerialArm.singularity_measure`) and the solver's step (`chain_kernels`). The plant, the
actuator map and their checks stay in Python (`rcmplan.compiled.arm_phase`). Imports numba.

Record row (`record_width(n)` columns): time [s], sliders (n,), joints (n,), lambda, tip, rcm,
trocar, base, target tip (3 each) [m], error (6,) NaN-padded; see `arm_phase.arm_columns`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from rcmplan._validate import FloatArray
from rcmplan.compiled.chain_kernels import (
    ROWS,
    IntArray,
    dls_step,
    frames,
    joint_axis,
    needle_axis,
    needle_point,
    pinv_step,
    point_jacobian,
)
from rcmplan.compiled.kernels import axis_from_angles, dls_solve
from rcmplan.compiled.loop import converged
from rcmplan.compiled.records import DLS, DONE, NO_CONVERGENCE, PINV_THESIS, SINGULAR, STEPPED, TIP


def record_width(n: int) -> int:
    """Columns of a record row for n joints."""
    return 2 * n + 23


@njit(cache=True)
def singularity_measure(A: FloatArray, ix: IntArray, W: FloatArray) -> float:
    """Inverse condition number of [J_tip / l; N J_omega] over the active joints (frames in W),
    as `SerialArm.singularity_measure` (N: the two unit normals to the needle axis)."""
    n, m = ix[0], ix[1]
    J = W[4 * (n + 1) :]
    point_jacobian(A, ix, W, 1.0, J, 0)
    a = needle_axis(A, n, W)
    h = 0
    for i in range(1, 3):
        if abs(a[i]) < abs(a[h]):
            h = i
    u = np.zeros(3)
    u[h] = 1.0
    n1 = np.array([a[1] * u[2] - a[2] * u[1], a[2] * u[0] - a[0] * u[2], a[0] * u[1] - a[1] * u[0]])
    n1 /= math.sqrt(n1[0] ** 2 + n1[1] ** 2 + n1[2] ** 2)
    n2 = np.array([a[1] * n1[2] - a[2] * n1[1], a[2] * n1[0] - a[0] * n1[2],
                   a[0] * n1[1] - a[1] * n1[0]])  # fmt: skip
    M = np.empty((5, m))
    length = A[5 * n + 12, 0]
    for j in range(m):
        k = ix[2 + n + j]
        w = (0.0, 0.0, 0.0) if ix[2 + k] != 0 else joint_axis(A, n, W, k)
        for i in range(3):
            M[i, j] = J[i, j] / length
        M[3, j] = n1[0] * w[0] + n1[1] * w[1] + n1[2] * w[2]
        M[4, j] = n2[0] * w[0] + n2[1] * w[1] + n2[2] * w[2]
    sv = np.linalg.svd(M)[1]
    return sv[-1] / sv[0] if sv[0] > 0 else 0.0


@njit(cache=True)
def task_error(A: FloatArray, ix: IntArray, W: FloatArray, method: int, lam: float,
               target: FloatArray, tip_t: FloatArray, pivot: bool,
               e: FloatArray) -> int:  # fmt: skip
    """The solver's error at the frames in W into e; returns its length (6, or 3 for TIP)."""
    n = ix[0]
    p_tip = needle_point(A, n, W, 1.0)
    if method == TIP:
        for i in range(3):
            e[i] = target[i] - p_tip[i]
        return 3
    if method == DLS:
        a = W[4 * (n + 1) + 2 * ROWS]  # a vector row of W as scratch
        axis_from_angles(target[1], target[2], a)
        p = needle_point(A, n, W, 0.0 if pivot else lam)
        for i in range(3):
            e[i] = tip_t[i] - p_tip[i]
            e[3 + i] = (tip_t[i] - A[5 * n + 12, 0] * a[i] if pivot else target[3 + i]) - p[i]
        return 6
    ax, ay, az = needle_axis(A, n, W)
    p = needle_point(A, n, W, lam)
    x = (p_tip[0], math.atan2(az, -ax), math.atan2(-ay, math.hypot(ax, az)), p[0], p[1], p[2])
    for i in range(6):
        e[i] = target[i] - x[i]
    return 6


@njit(cache=True)
def record(A: FloatArray, n: int, W: FloatArray, row: FloatArray, t: float, s: FloatArray,
           lam: float, trocar: FloatArray, tip_t: FloatArray, e: FloatArray,
           ne: int) -> None:  # fmt: skip
    """One record into row (record_width(n),); see the module docstring."""
    base, tip = needle_point(A, n, W, 0.0), needle_point(A, n, W, 1.0)
    row[0] = t
    for i in range(n):
        row[1 + i], row[1 + n + i] = s[i], s[i]
    o = 2 * n + 1
    row[o] = lam
    for i in range(3):
        row[o + 1 + i] = tip[i]
        row[o + 4 + i] = base[i] + lam * (tip[i] - base[i])
        row[o + 7 + i], row[o + 10 + i], row[o + 13 + i] = trocar[i], base[i], tip_t[i]
    for i in range(6):
        row[o + 16 + i] = e[i] if i < ne else np.nan


@njit(cache=True)
def step(A: FloatArray, ix: IntArray, W: FloatArray, method: int, K: FloatArray, gain: float,
         damping: float, s: FloatArray, lam: float, target: FloatArray, e: FloatArray,
         d: FloatArray) -> None:  # fmt: skip
    """The solver's step d = (dq[active], dlambda) at joints s (frames in W for TIP)."""
    n, m = ix[0], ix[1]
    if method == TIP:
        o = 4 * (n + 1)
        J = W[o:]
        point_jacobian(A, ix, W, 1.0, J, 0)
        dls_solve(J, e, damping, 3, m, W[o + ROWS :], W[o + 2 * ROWS], d)
        d[m] = 0.0
    elif method == DLS:
        dls_step(A, ix, W, s, lam, target, damping, d)
    else:
        pinv_step(A, ix, W, s, lam, target, K, gain, method == PINV_THESIS, d)


@njit(cache=True)
def arm_iterate(
    A: FloatArray, ix: IntArray, method: int, K: FloatArray, gain: float, damping: float,
    tol: FloatArray, max_it: int, drift: bool, thr: float, target: FloatArray, pivot: bool,
    tip_t: FloatArray, trocar: FloatArray, s: FloatArray, state: FloatArray, it: int,
    row: FloatArray, fail: FloatArray, W: FloatArray, d: FloatArray,
) -> int:  # fmt: skip
    """One iteration from joints s (n,). Returns DONE, STEPPED (the next joints in fail[n:2n]),
    NO_CONVERGENCE or SINGULAR. state = (lambda, time [s]); lambda is updated. fail holds
    (q (n,), q_new (n,), error (6,))."""
    n, m = ix[0], ix[1]
    e = fail[2 * n : 2 * n + 6]
    for i in range(n):
        fail[i] = s[i]
    frames(A, ix, s, W)
    if method != TIP and drift:
        base, tip = needle_point(A, n, W, 0.0), needle_point(A, n, W, 1.0)
        num, den = 0.0, 0.0
        for i in range(3):
            axis = tip[i] - base[i]
            num += (trocar[i] - base[i]) * axis
            den += axis * axis
        state[0] = min(1.0, max(0.0, num / den))  # the needle point closest to the trocar
    ne = task_error(A, ix, W, method, state[0], target, tip_t, pivot, e)
    if it > 0:
        record(A, n, W, row, state[1], s, state[0], trocar, tip_t, e, ne)
    if converged(e, tol, ne):
        return DONE
    if it == max_it:
        return NO_CONVERGENCE
    if singularity_measure(A, ix, W) < thr:
        return SINGULAR
    step(A, ix, W, method, K, gain, damping, s, state[0], target, e, d)
    for i in range(n):
        fail[n + i] = s[i]
    for j in range(m):
        fail[n + ix[2 + n + j]] += d[j]
    state[0] += d[m]
    return STEPPED
