"""Compiled closed-form kinematics of iRAM!S: needle points, X_ext, J_a and the step solves.

The one module that imports numba (the `fast` extra); `rcmplan.compiled.runner` imports it only
when numba is installed. Every kernel repeats the arithmetic of the reference code in the same
order (`Iramis.needle_point`, `augmented.py`, `solvers.py`), so results agree to rounding.

Parameters travel as one float64 array P (see `PARAMS`): link lengths l1..l6 [m], PCJM slider
spacing d [m], slider travel lower (6,) and upper (6,) [m, rad for q5]. Joint vectors q are
(q0..q5) [m, rad]; slider vectors s are (L1, L2, L3, L4, L5, q5).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from rcmplan._validate import FloatArray

PARAMS = ("l1", "l2", "l3", "l4", "l5", "l6", "d", "lower[6]", "upper[6]")
LOWER, UPPER = 7, 13
HALF_PI = 0.5 * math.pi


@njit(cache=True)
def joints_from_actuators(P: FloatArray, s: FloatArray, q: FloatArray) -> None:
    """q from s through both PCJMs (eqs. 2.1, 2.2), written into q (6,)."""
    q[0] = 0.5 * (s[0] + s[1])
    q[1] = math.atan((s[1] - s[0]) / P[6])
    q[2] = 0.5 * (s[2] + s[3])
    q[3] = math.atan((s[3] - s[2]) / P[6])
    q[4] = s[4]
    q[5] = s[5]


@njit(cache=True)
def actuators_from_joints(P: FloatArray, q: FloatArray, s: FloatArray) -> bool:
    """s from q (inverse PCJM maps) into s (6,); False if q is not finite or |q1|, |q3| >= pi/2."""
    for i in range(6):
        if not math.isfinite(q[i]):
            return False
    if abs(q[1]) >= HALF_PI or abs(q[3]) >= HALF_PI:
        return False
    half = 0.5 * P[6] * math.tan(q[1])
    s[0] = q[0] - half
    s[1] = q[0] + half
    half = 0.5 * P[6] * math.tan(q[3])
    s[2] = q[2] - half
    s[3] = q[2] + half
    s[4] = q[4]
    s[5] = q[5]
    return True


@njit(cache=True)
def first_beyond_travel(P: FloatArray, s: FloatArray) -> int:
    """Index of the first slider outside its travel, or -1."""
    for i in range(6):
        if s[i] < P[LOWER + i] or s[i] > P[UPPER + i]:
            return i
    return -1


@njit(cache=True)
def trig(q: FloatArray) -> tuple[float, float, float, float]:
    """(cos q1, sin q1, cos q3, sin q3): computed once per configuration, passed as `tr`."""
    return math.cos(q[1]), math.sin(q[1]), math.cos(q[3]), math.sin(q[3])


@njit(cache=True)
def point(P: FloatArray, q: FloatArray, tr: tuple, lam: float, out: FloatArray) -> None:
    """p(lambda) in [m], base frame (eqs. 2.7, 3.7), written into out (3,); tr = trig(q)."""
    c1, s1, c3, s3 = tr
    w = q[4] + lam * P[5]
    out[0] = P[1] * s1 - c1 * c3 * w - P[4] * c1 * s3
    out[1] = P[2] + P[3] + q[2] - s3 * w + P[4] * c3
    out[2] = P[0] + q[0] + P[1] * c1 + s1 * c3 * w + P[4] * s1 * s3


@njit(cache=True)
def needle_point(P: FloatArray, q: FloatArray, lam: float, out: FloatArray) -> None:
    """p(lambda) in [m] into out (3,)."""
    point(P, q, trig(q), lam, out)


@njit(cache=True)
def point_jacobian(
    P: FloatArray, q: FloatArray, tr: tuple, lam: float, J: FloatArray, r: int
) -> None:
    """d p(lambda) / d(q0..q4, lambda) (eq. 3.10) into rows r..r+2 of J (n, 6)."""
    c1, s1, c3, s3 = tr
    l2, l5, l6 = P[1], P[4], P[5]
    w = q[4] + lam * l6
    k = s3 * w - l5 * c3
    J[r, 0] = 0.0
    J[r, 1] = l2 * c1 + s1 * c3 * w + l5 * s1 * s3
    J[r, 2] = 0.0
    J[r, 3] = c1 * k
    J[r, 4] = -c1 * c3
    J[r, 5] = -l6 * c1 * c3
    J[r + 1, 0] = 0.0
    J[r + 1, 1] = 0.0
    J[r + 1, 2] = 1.0
    J[r + 1, 3] = -c3 * w - l5 * s3
    J[r + 1, 4] = -s3
    J[r + 1, 5] = -l6 * s3
    J[r + 2, 0] = 1.0
    J[r + 2, 1] = c1 * c3 * w - l2 * s1 + l5 * c1 * s3
    J[r + 2, 2] = 0.0
    J[r + 2, 3] = -s1 * k
    J[r + 2, 4] = s1 * c3
    J[r + 2, 5] = l6 * s1 * c3


@njit(cache=True)
def tip_jacobian(P: FloatArray, q: FloatArray, tr: tuple, J: FloatArray, r: int) -> None:
    """d p_tip / d theta_ext with a zero lambda column into rows r..r+2 of J."""
    point_jacobian(P, q, tr, 1.0, J, r)
    J[r, 5] = 0.0
    J[r + 1, 5] = 0.0
    J[r + 2, 5] = 0.0


@njit(cache=True)
def task(P: FloatArray, q: FloatArray, tr: tuple, lam: float, x: FloatArray) -> None:
    """X_ext = (x_tip [m], phi, psi [rad], p_rcm [m]) into x (6,)."""
    c1, s1, c3, s3 = tr
    ax, ay, az = -c1 * c3, -s3, s1 * c3
    point(P, q, tr, lam, x[3:])
    x[0] = P[1] * s1 - c1 * c3 * (q[4] + 1.0 * P[5]) - P[4] * c1 * s3  # x of p(1)
    x[1] = math.atan2(az, -ax)
    x[2] = math.atan2(-ay, math.hypot(ax, az))


@njit(cache=True)
def extended_task(P: FloatArray, q: FloatArray, lam: float, x: FloatArray) -> None:
    """X_ext at (q, lambda) into x (6,)."""
    task(P, q, trig(q), lam, x)


@njit(cache=True)
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


@njit(cache=True)
def augmented_jacobian(
    P: FloatArray, q: FloatArray, lam: float, thesis: bool, J: FloatArray
) -> None:
    """J_a (6, 6) at (q, lambda) into J."""
    jacobian_a(P, q, trig(q), lam, thesis, J)


@njit(cache=True)
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


@njit(cache=True)
def gauss_solve(A: FloatArray, b: FloatArray, n: int, x: FloatArray) -> None:
    """Solve A[:n, :n] x = b[:n]: Gaussian elimination, partial pivoting (A, b overwritten)."""
    for c in range(n):
        p = c
        for r in range(c + 1, n):
            if abs(A[r, c]) > abs(A[p, c]):
                p = r
        if p != c:
            for j in range(n):
                A[c, j], A[p, j] = A[p, j], A[c, j]
            b[c], b[p] = b[p], b[c]
        for r in range(c + 1, n):
            f = A[r, c] / A[c, c]
            for j in range(c + 1, n):
                A[r, j] -= f * A[c, j]
            b[r] -= f * b[c]
    for r in range(n - 1, -1, -1):
        acc = b[r]
        for j in range(r + 1, n):
            acc -= A[r, j] * x[j]
        x[r] = acc / A[r, r]


@njit(cache=True)
def dls_solve(
    J: FloatArray, e: FloatArray, D: float, m: int, n: int, A: FloatArray, f: FloatArray,
    d: FloatArray,
) -> None:  # fmt: skip
    """d = J^T f with (J J^T + D^2 I) f = e for J[:m, :n] (eqs. 2.19, 2.20); A, f scratch."""
    for i in range(m):
        for j in range(m):
            acc = 0.0
            for k in range(n):
                acc += J[i, k] * J[j, k]
            A[i, j] = acc
        A[i, i] += D * D
        f[i] = e[i]
    gauss_solve(A, f, m, d)  # d[:m] holds the solution f
    for i in range(m):
        f[i] = d[i]
    for k in range(n):
        acc = 0.0
        for i in range(m):
            acc += J[i, k] * f[i]
        d[k] = acc


@njit(cache=True)
def axis_from_angles(phi: float, psi: float, a: FloatArray) -> None:
    """The unit needle axis with needle angles (phi, psi) into a (3,)."""
    a[0] = -math.cos(phi) * math.cos(psi)
    a[1] = -math.sin(psi)
    a[2] = math.sin(phi) * math.cos(psi)


@njit(cache=True)
def tip_of_target(x: FloatArray, a: FloatArray, tip: FloatArray) -> bool:
    """The tip point X_ext implies into tip (3,); False if the axis is perpendicular to x."""
    axis_from_angles(x[1], x[2], a)
    if abs(a[0]) < 1e-12:
        return False
    t = (x[0] - x[3]) / a[0]
    for i in range(3):
        tip[i] = x[3 + i] + t * a[i]
    return True


@njit(cache=True)
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
