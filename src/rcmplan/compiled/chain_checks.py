"""Compiled checks of any serial arm: the singularity measure (with a cheap certificate that it
lies above a threshold) and the Newton IK that screens targets before motion; the layout is in
`chain_kinematics`."""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from rcmplan._validate import FloatArray
from rcmplan.compiled.kernels import dls_solve, gauss_solve, tip_of_target
from rcmplan.robot.chain_kinematics import (
    CERTIFY,
    ROWS,
    SING,
    E,
    F,
    IntArray,
    Z,
    angle_rows,
    frames,
    joint_axis,
    needle_axis,
    needle_point,
    point_jacobian,
)


@njit(cache=True)
def singular_gram(A: FloatArray, ix: IntArray, W: FloatArray) -> int:
    """M = [J_tip / l; N J_omega] (5, m) over the active joints at the frames in W, as
    `SerialArm.singularity_measure` builds it (N: the two unit normals to the needle axis), and
    its Gram matrix G = M M^T (5, 5), into W; returns G's first row. J_tip = d p(1) / d theta_ext
    is left in W's J rows 0..2 for the step."""
    n, m = ix[0], ix[1]
    o = 4 * (n + 1)
    r = o + 2 * ROWS + 6
    g = r + SING
    point_jacobian(A, ix, W, 1.0, W, o)
    ax, ay, az = needle_axis(A, n, W)
    ux, uy, uz = 1.0, 0.0, 0.0  # the helper axis: the first smallest |a_i| (np.argmin)
    if abs(ay) < abs(ax):
        ux, uy = 0.0, 1.0
    if abs(az) < min(abs(ax), abs(ay)):
        ux, uy, uz = 0.0, 0.0, 1.0
    n1x, n1y, n1z = ay * uz - az * uy, az * ux - ax * uz, ax * uy - ay * ux
    norm = math.sqrt(n1x * n1x + n1y * n1y + n1z * n1z)
    n1x, n1y, n1z = n1x / norm, n1y / norm, n1z / norm
    n2x, n2y, n2z = ay * n1z - az * n1y, az * n1x - ax * n1z, ax * n1y - ay * n1x
    length = A[5 * n + 12, 0]
    for j in range(m):
        k = ix[2 + n + j]
        wx, wy, wz = 0.0, 0.0, 0.0
        if ix[2 + k] == 0:
            wx, wy, wz = joint_axis(A, n, W, k)
        for i in range(3):
            W[r + i, j] = W[o + i, j] / length
        W[r + 3, j] = n1x * wx + n1y * wy + n1z * wz
        W[r + 4, j] = n2x * wx + n2y * wy + n2z * wz
    for i in range(SING):
        for j in range(i + 1):
            acc = 0.0
            for k in range(m):
                acc += W[r + i, k] * W[r + j, k]
            W[g + i, j], W[g + j, i] = acc, acc
    return g


@njit(cache=True)
def gram_extremes(W: FloatArray, g: int) -> tuple[float, float]:
    """(smallest, largest) eigenvalue of the symmetric (5, 5) matrix at rows g of W, by cyclic
    Jacobi rotations (the matrix is overwritten)."""
    fro2 = 0.0
    for i in range(SING):
        for j in range(SING):
            fro2 += W[g + i, j] ** 2
    for _ in range(50):
        off = 0.0
        for i in range(SING):
            for j in range(i + 1, SING):
                off += W[g + i, j] ** 2
        if off <= 1e-32 * fro2:
            break
        for p in range(SING - 1):
            for r in range(p + 1, SING):
                apq = W[g + p, r]
                if apq == 0.0:
                    continue
                theta = (W[g + r, r] - W[g + p, p]) / (2.0 * apq)
                t = 1.0 / (abs(theta) + math.sqrt(theta * theta + 1.0))
                if theta < 0.0:
                    t = -t
                c = 1.0 / math.sqrt(t * t + 1.0)
                s = t * c
                for k in range(SING):  # G = R^T G R with R the rotation in the (p, r) plane
                    a, b = W[g + k, p], W[g + k, r]
                    W[g + k, p], W[g + k, r] = c * a - s * b, s * a + c * b
                for k in range(SING):
                    a, b = W[g + p, k], W[g + r, k]
                    W[g + p, k], W[g + r, k] = c * a - s * b, s * a + c * b
    lo, hi = W[g, 0], W[g, 0]
    for i in range(1, SING):
        lo, hi = min(lo, W[g + i, i]), max(hi, W[g + i, i])
    return lo, hi


@njit(cache=True)
def singularity_measure(A: FloatArray, ix: IntArray, W: FloatArray) -> float:
    """`SerialArm.singularity_measure` at the frames in W: sigma_min / sigma_max of M, the
    square roots of G's extreme eigenvalues (to about 1e-12 relative where it is 0.01)."""
    lo, hi = gram_extremes(W, singular_gram(A, ix, W))
    return math.sqrt(max(lo, 0.0) / hi) if hi > 0.0 else 0.0


@njit(cache=True)
def is_singular(A: FloatArray, ix: IntArray, W: FloatArray, thr: float) -> bool:
    """True if `SerialArm.singularity_measure` at the frames in W is below thr.

    Usually decided by a certificate: lambda_max(G) <= ||G||_F = U, so a Cholesky factorisation
    of G - thr^2 U (1 + CERTIFY) I that succeeds proves sigma_min^2 > thr^2 sigma_max^2; only
    when it fails is the measure computed (`gram_extremes`). No allocation either way."""
    n = ix[0]
    g = singular_gram(A, ix, W)
    S = 4 * (n + 1) + ROWS  # the 6 x 6 scratch rows
    fro2 = 0.0
    for i in range(SING):
        for j in range(SING):
            fro2 += W[g + i, j] ** 2
    shift = thr * thr * math.sqrt(fro2) * (1.0 + CERTIFY)
    for i in range(SING):  # Cholesky of G - shift I into the scratch (1 / L_ii on its diagonal)
        for j in range(i + 1):
            acc = W[g + i, j] - (shift if i == j else 0.0)
            for k in range(j):
                acc -= W[S + i, k] * W[S + j, k]
            if i != j:
                W[S + i, j] = acc * W[S + j, j]
            elif acc > 0.0:
                W[S + i, i] = 1.0 / math.sqrt(acc)
            else:
                lo, hi = gram_extremes(W, g)
                return (math.sqrt(max(lo, 0.0) / hi) if hi > 0.0 else 0.0) < thr
    return False


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
        err[3] = phi - math.atan2(az, -ax)
        err[4] = psi - math.atan2(-ay, math.hypot(ax, az))
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
        if not finite or not tip_of_target(x, a, tip) or abs(a[0]) < 2e-12:
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
