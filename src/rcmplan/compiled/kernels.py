"""iRAM!S's X_ext, J_a in closed form and the step solves, compiled, on the kinematics of
`rcmplan.robot.iramis_kernels` (the one definition the `Iramis` model calls too). The
augmented Jacobian's closed form and the solves repeat the arithmetic of the generic tasks
(`control/tasks.py`, `augmented.py`, `solvers.py`), which any robot model uses, so results
agree to rounding.

Parameters travel as one float64 array P (`iramis_kernels.PARAMS`).
"""

from __future__ import annotations

import numpy as np

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.robot.iramis_kernels import point, point_jacobian, trig
from rcmplan.robot.needle import axis_angles


@njit(cache=True, borrows=True)
def task(P: FloatArray, q: FloatArray, tr: tuple, lam: float, x: FloatArray) -> None:
    """X_ext = (x_tip [m], phi, psi [rad], p_rcm [m]) into x (6,)."""
    c1, s1, c3, s3 = tr
    ax, ay, az = -c1 * c3, -s3, s1 * c3
    point(P, q, tr, lam, x[3:])
    x[0] = P[1] * s1 - c1 * c3 * (q[4] + 1.0 * P[5]) - P[4] * c1 * s3  # x of p(1)
    x[1], x[2] = axis_angles(ax, ay, az)


@njit(cache=True, borrows=True)
def extended_task(P: FloatArray, q: FloatArray, lam: float, x: FloatArray) -> None:
    """X_ext at (q, lambda) into x (6,)."""
    task(P, q, trig(q), lam, x)


@njit(cache=True, borrows=True)
def jacobian_a(
    P: FloatArray, q: FloatArray, tr: tuple, lam: float, thesis: bool, J: FloatArray
) -> None:
    """J_a (6, 6) into J: eq. 3.15 with exact angle rows, or eq. 6.1's rows if `thesis`."""
    point_jacobian(P, q, tr, 1.0, J, 0)  # row 0 kept; rows 1, 2 overwritten with the angles
    J[0, 5] = 0.0
    for j in range(6):
        J[1, j] = 0.0
        J[2, j] = 0.0
    J[1, 1] = 1.0
    J[2, 3] = tr[0] if thesis else 1.0
    point_jacobian(P, q, tr, lam, J, 3)


@njit(cache=True, borrows=True)
def augmented_jacobian(
    P: FloatArray, q: FloatArray, lam: float, thesis: bool, J: FloatArray
) -> None:
    """J_a (6, 6) at (q, lambda) into J."""
    jacobian_a(P, q, trig(q), lam, thesis, J)


@njit(cache=True, borrows=True)
def solve_augmented(J: FloatArray, b: FloatArray, d: FloatArray) -> None:
    """Solve J_a d = b by substitution: J_a is a permuted triangular matrix.

    Structural zeros of J_a (both variants): row 1 = e_q1, row 2 = c e_q3, row 0 touches only
    q1, q3, q4; row 3 adds lambda; row 4 adds q2 (coefficient 1); row 5 adds q0 (coefficient 1).
    Needs J[0, 4] = -cos q1 cos q3 and J[3, 5] = -l6 cos q1 cos q3 nonzero (not singular).
    """
    d[1] = b[1] / J[1, 1]
    d[3] = b[2] / J[2, 3]
    d[4] = (b[0] - J[0, 1] * d[1] - J[0, 3] * d[3]) / J[0, 4]
    d[5] = (b[3] - J[3, 1] * d[1] - J[3, 3] * d[3] - J[3, 4] * d[4]) / J[3, 5]
    d[2] = (b[4] - J[4, 3] * d[3] - J[4, 4] * d[4] - J[4, 5] * d[5]) / J[4, 2]
    d[0] = (b[5] - J[5, 1] * d[1] - J[5, 3] * d[3] - J[5, 4] * d[4] - J[5, 5] * d[5]) / J[5, 0]


@njit(cache=True, borrows=True)
def batch_task_jacobians(
    P: FloatArray, Q: FloatArray, lam: FloatArray, thesis: bool, X: FloatArray, J: FloatArray
) -> None:
    """X_ext (N, 6) and J_a (N, 6, 6) for N configurations, one core."""
    for i in range(Q.shape[0]):
        tr = trig(Q[i])
        task(P, Q[i], tr, lam[i], X[i])
        jacobian_a(P, Q[i], tr, lam[i], thesis, J[i])


@njit(cache=True)
def pinv_step(
    P: FloatArray, q: FloatArray, lam: float, target: FloatArray, K: FloatArray, thesis: bool,
    d: FloatArray,
) -> None:  # fmt: skip
    """One control step: X_ext, J_a and J_a d = K (target - X_ext), d = (dq0..dq4, dlambda)."""
    x = np.empty(6)
    J = np.empty((6, 6))
    tr = trig(q)
    task(P, q, tr, lam, x)
    for i in range(6):
        x[i] = K[i] * (target[i] - x[i])
    jacobian_a(P, q, tr, lam, thesis, J)
    solve_augmented(J, x, d)
