"""Compiled steps of any serial arm: LU and Gram solves, the pinv step (square, or minimum norm
with the null-space posture) and the DLS step, as `PinvSolver` and `DlsSolver` take them; the
layout is in `chain_kinematics`."""

from __future__ import annotations

import math

from numba import njit

from rcmplan._validate import FloatArray
from rcmplan.control.lu import lu_solve
from rcmplan.control.solvers import PIVOT_DISTANCE
from rcmplan.robot.chain_kinematics import (
    AXIS,
    ROWS,
    TIP,
    E,
    F,
    IntArray,
    X,
    Z,
    evaluate,
    frames,
    needle_point,
    point_jacobian,
)
from rcmplan.robot.needle import x_ext_tip


@njit(cache=True)
def gram_solve(W: FloatArray, j: int, rows: int, cols: int, damping: float, e: FloatArray,
               d: FloatArray) -> None:  # fmt: skip
    """d[:cols] = J^T f with (J J^T + D^2 I) f = e[:rows] for J at rows j.. of W (eqs. 2.19,
    2.20; D = 0: the minimum-norm step), solved on W's 6 x 6 scratch (rows j + ROWS..) and its
    F row (`lu_solve`). J at W's J rows; e may be d (read before d is written)."""
    S = j + ROWS
    f = S + ROWS + F
    for i in range(rows):
        for k in range(i + 1):
            acc = 0.0
            for c in range(cols):
                acc += W[j + i, c] * W[j + k, c]
            W[S + i, k], W[S + k, i] = acc, acc
        W[S + i, i] += damping * damping
        W[f, i] = e[i]
    lu_solve(W, S, rows, f)
    for c in range(cols):
        acc = 0.0
        for i in range(rows):
            acc += W[j + i, c] * W[f, i]
        d[c] = acc


@njit(cache=True)
def square_solve(W: FloatArray, j: int, b: int, d: FloatArray) -> None:
    """d = J^-1 W[b] for the square J at rows j.. of W (J_a of a non-redundant arm), by
    `lu_solve` on W's 6 x 6 scratch (rows j + ROWS..); W[b] is overwritten."""
    S = j + ROWS
    for r in range(ROWS):
        for c in range(ROWS):
            W[S + r, c] = W[j + r, c]
    lu_solve(W, S, ROWS, b)
    for r in range(ROWS):
        d[r] = W[b, r]


@njit(cache=True)
def pinv_solve(A: FloatArray, ix: IntArray, W: FloatArray, q: FloatArray, K: FloatArray,
               gain: float, err: FloatArray, d: FloatArray) -> None:  # fmt: skip
    """The `PinvSolver` step into d (m + 1,) from J_a in W's J rows and the X_ext error err
    (6,) at joints q: J_a d = K e when J_a is square (`square_solve`), else
    d = J_a^+ (K e - J_a z) + z, the minimum-norm step through J_a J_a^T plus the null-space
    posture step z = gain (home - q) over the active joints."""
    n, m = ix[0], ix[1]
    o = 4 * (n + 1)
    e, z = o + 2 * ROWS + E, o + 2 * ROWS + Z
    if m + 1 == ROWS:
        for i in range(ROWS):
            W[e, i] = K[i] * err[i]
        square_solve(W, o, e, d)
        return
    for j in range(m):
        k = ix[2 + n + j]
        W[z, j] = gain * (A[4 * (n + 3) + k, 3] - q[k])
    W[z, m] = 0.0
    for i in range(ROWS):  # K e - J_a z into d (gram_solve reads it before writing d)
        acc = K[i] * err[i]
        for j in range(m + 1):
            acc -= W[o + i, j] * W[z, j]
        d[i] = acc
    gram_solve(W, o, ROWS, m + 1, 0.0, d, d)
    for j in range(m + 1):
        d[j] += W[z, j]


@njit(cache=True)
def pinv_step(A: FloatArray, ix: IntArray, W: FloatArray, q: FloatArray, lam: float,
              target: FloatArray, K: FloatArray, gain: float, thesis: bool,
              d: FloatArray) -> None:  # fmt: skip
    """One `PinvSolver` step into d (m + 1,) (eq. 3.17) at (q, lambda): `pinv_solve` on the
    X_ext error, which is left in W's row X."""
    n = ix[0]
    o = 4 * (n + 1)
    v = o + 2 * ROWS
    x = W[v + X]
    evaluate(A, ix, W, q, lam, thesis, x, W[o:])
    for i in range(ROWS):
        x[i] = target[i] - x[i]
    pinv_solve(A, ix, W, q, K, gain, x, d)


@njit(cache=True)
def dls_solve_at(A: FloatArray, ix: IntArray, W: FloatArray, lam: float, pivot: bool,
                 e: FloatArray, damping: float, d: FloatArray,
                 tip_ready: bool = False) -> None:  # fmt: skip
    """The `DlsSolver` step into d (m + 1,) at the frames in W for its error e (6,): the tip
    and p(lambda) (the needle base for a pivot) over (q[active], lambda),
    d = J^T (J J^T + D^2 I)^-1 e (eqs. 2.19, 2.20); `tip_ready`: W's J rows 0..2 already hold
    d p(1) / d theta_ext (`singular_gram` leaves them there)."""
    n, m = ix[0], ix[1]
    o = 4 * (n + 1)
    if not tip_ready:
        point_jacobian(A, ix, W, 1.0, W, o)
    point_jacobian(A, ix, W, 0.0 if pivot else lam, W, o + 3)
    for i in range(3):  # lambda moves no tip (and no needle base)
        W[o + i, m] = 0.0
        if pivot:
            W[o + 3 + i, m] = 0.0
    gram_solve(W, o, ROWS, m + 1, damping, e, d)


@njit(cache=True)
def dls_step(A: FloatArray, ix: IntArray, W: FloatArray, q: FloatArray, lam: float,
             target: FloatArray, damping: float, d: FloatArray) -> bool:  # fmt: skip
    """One `DlsSolver` step into d (m + 1,): the tip to the tip of the X_ext target and
    p(lambda) to the trocar, or for a pivot (tip on the trocar) the needle base to its place on
    the target axis (`dls_solve_at`); the error e (6,) is left in W's row E. False (d
    untouched) if the target fixes no tip."""
    n = ix[0]
    v = 4 * (n + 1) + 2 * ROWS
    e, tip, a = W[v + E], W[v + TIP], W[v + AXIS]
    if not x_ext_tip(target, a, tip):
        return False
    pivot = math.sqrt((tip[0] - target[3]) ** 2 + (tip[1] - target[4]) ** 2
                      + (tip[2] - target[5]) ** 2) < PIVOT_DISTANCE  # fmt: skip
    lam_rcm, length = 0.0 if pivot else lam, A[5 * n + 12, 0]
    frames(A, ix, q, W)
    p_tip, p_rcm = needle_point(A, n, W, 1.0), needle_point(A, n, W, lam_rcm)
    for i in range(3):
        e[i] = tip[i] - p_tip[i]
        e[3 + i] = (tip[i] - length * a[i] if pivot else target[3 + i]) - p_rcm[i]
    dls_solve_at(A, ix, W, lam, pivot, e, damping, d)
    return True
