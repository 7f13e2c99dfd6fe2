"""Compiled steps of any serial arm: the pinv step (square, or minimum norm with the null-space
posture) and the DLS step, as `PinvSolver` and `DlsSolver` take them, on `rcmplan.linalg`'s
solves; the layout is in `chain_kinematics`."""

from __future__ import annotations

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.control.dls_task import dls_error, is_pivot
from rcmplan.linalg import damped, pinv
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


@njit(cache=True, borrows=True)
def gram_solve(W: FloatArray, j: int, rows: int, cols: int, damping: float, e: FloatArray,
               d: FloatArray) -> None:  # fmt: skip
    """d[:cols] = J^T f with (J J^T + D^2 I) f = e[:rows] for J at rows j.. of W (eqs. 2.19,
    2.20; D = 0: the minimum-norm step, `linalg.damped`) on W's scratch (rows j + ROWS..) and
    its F row; e is left as it is (it may be d: read before d is written)."""
    f = j + 2 * ROWS + F
    for i in range(rows):
        W[f, i] = e[i]
    damped(W, j, rows, cols, damping, j + ROWS, f, d)


@njit(cache=True, borrows=True)
def pinv_solve(A: FloatArray, ix: IntArray, W: FloatArray, q: FloatArray, K: FloatArray,
               gain: float, err: FloatArray, d: FloatArray) -> None:  # fmt: skip
    """The `PinvSolver` step into d (m + 1,) from J_a in W's J rows and the X_ext error err
    (6,) at joints q: J_a d = K e when J_a is square, else d = J_a^+ (K e - J_a z) + z, the
    minimum-norm step plus the null-space posture step z = gain (home - q) over the active
    joints (`linalg.pinv`)."""
    n, m = ix[0], ix[1]
    o = 4 * (n + 1)
    e, z = o + 2 * ROWS + E, o + 2 * ROWS + Z
    for i in range(ROWS):
        W[e, i] = K[i] * err[i]
    if m + 1 > ROWS:
        for j in range(m):
            k = ix[2 + n + j]
            W[z, j] = gain * (A[4 * (n + 3) + k, 3] - q[k])
        W[z, m] = 0.0
    pinv(W, o, ROWS, m + 1, o + ROWS, e, z, d)


@njit(cache=True, borrows=True)
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


@njit(cache=True, borrows=True)
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


@njit(cache=True, borrows=True)
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
    pivot = is_pivot(tip, target)
    frames(A, ix, q, W)
    p_tip, p_rcm = needle_point(A, n, W, 1.0), needle_point(A, n, W, 0.0 if pivot else lam)
    dls_error(tip, a, pivot, A[5 * n + 12, 0], target, p_tip, p_rcm, e)
    dls_solve_at(A, ix, W, lam, pivot, e, damping, d)
    return True
