"""The singularity measure of a serial arm holding a straight needle, and its exact gradient, as
numba kernels on the chain kernels' arrays and work array (`chain_kinematics`, which states the
layout). The one definition: `SerialArm.singularity_measure` and `SerialArm.singular_terms`
call these kernels from Python, the compiled loops and the compiled QP step from compiled code.

The measure is kappa = s_min / s_max of M = [J_tip / l; N J_omega] (5, m) over the active
joints: J_tip the tip's point Jacobian, l the needle length, J_omega the needle's angular
Jacobian and N the two unit normals to the needle axis (n1 = a x e_k / |a x e_k|, e_k the first
axis of smallest |a_k|, and n2 = a x n1). Its singular values are the square roots of the
eigenvalues of the Gram matrix G = M M^T (5, 5), found by cyclic Jacobi rotations. Every kernel
reads the frames already in W (`chain_kinematics.frames`).
"""

from __future__ import annotations

import math

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.linalg import gram
from rcmplan.robot.chain_kinematics import (
    ROWS,
    SING,
    IntArray,
    frames,
    joint_axis,
    needle_axis,
    point_jacobian,
    singular_row,
)

CERTIFY = 1e-6  # relative margin of the singularity certificate (rounding is ~1e-15)
SWEEPS = 50  # cap on the Jacobi sweeps (a 5 x 5 matrix converges in fewer than 10)


@njit(cache=True, borrows=True)
def needle_normals(ax: float, ay: float, az: float) -> tuple:
    """The normals N of M for the unit needle axis a: (n1 (3,), n2 (3,), the helper axis
    e_k (3,), |a x e_k|), each as a tuple of floats."""
    ux, uy, uz = 1.0, 0.0, 0.0  # the helper axis: the first smallest |a_i| (np.argmin)
    if abs(ay) < abs(ax):
        ux, uy = 0.0, 1.0
    if abs(az) < min(abs(ax), abs(ay)):
        ux, uy, uz = 0.0, 0.0, 1.0
    n1x, n1y, n1z = ay * uz - az * uy, az * ux - ax * uz, ax * uy - ay * ux
    norm = math.sqrt(n1x * n1x + n1y * n1y + n1z * n1z)
    n1x, n1y, n1z = n1x / norm, n1y / norm, n1z / norm
    n2 = (ay * n1z - az * n1y, az * n1x - ax * n1z, ax * n1y - ay * n1x)
    return (n1x, n1y, n1z), n2, (ux, uy, uz), norm


@njit(cache=True, borrows=True)
def singular_gram(A: FloatArray, ix: IntArray, W: FloatArray) -> int:
    """M (5, m) over the active joints at the frames in W and its Gram matrix G = M M^T (5, 5),
    into W; returns G's first row (M's is `singular_row`). J_tip = d p(1) / d theta_ext is left
    in W's J rows 0..2 for the step."""
    n, m = ix[0], ix[1]
    o = 4 * (n + 1)
    r = singular_row(n)
    g = r + SING
    point_jacobian(A, ix, W, 1.0, W, o)
    n1, n2, _, _ = needle_normals(*needle_axis(A, n, W))
    length = A[5 * n + 12, 0]
    for j in range(m):
        k = ix[2 + n + j]
        wx, wy, wz = 0.0, 0.0, 0.0
        if ix[2 + k] == 0:
            wx, wy, wz = joint_axis(A, n, W, k)
        for i in range(3):
            W[r + i, j] = W[o + i, j] / length
        W[r + 3, j] = n1[0] * wx + n1[1] * wy + n1[2] * wz
        W[r + 4, j] = n2[0] * wx + n2[1] * wy + n2[2] * wz
    gram(W, r, SING, m, 0.0, g)
    return g


@njit(cache=True, borrows=True)
def jacobi(W: FloatArray, g: int, v: int) -> tuple[int, int]:
    """Diagonalise the symmetric (5, 5) matrix at rows g of W in place by cyclic Jacobi
    rotations; with v >= 0 its eigenvectors go to the columns of the (5, 5) block at rows v.
    Returns the indices of the smallest and the largest eigenvalue (on G's diagonal)."""
    fro2 = 0.0
    for i in range(SING):
        for j in range(SING):
            fro2 += W[g + i, j] ** 2
    if v >= 0:
        for i in range(SING):
            for j in range(SING):
                W[v + i, j] = 1.0 if i == j else 0.0
    for _ in range(SWEEPS):
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
                if v >= 0:  # V = V R
                    for k in range(SING):
                        a, b = W[v + k, p], W[v + k, r]
                        W[v + k, p], W[v + k, r] = c * a - s * b, s * a + c * b
    lo, hi = 0, 0
    for i in range(1, SING):
        if W[g + i, i] < W[g + lo, lo]:
            lo = i
        if W[g + i, i] > W[g + hi, hi]:
            hi = i
    return lo, hi


@njit(cache=True, borrows=True)
def gram_extremes(W: FloatArray, g: int) -> tuple[float, float]:
    """(smallest, largest) eigenvalue of the symmetric (5, 5) matrix at rows g of W (`jacobi`;
    the matrix is overwritten)."""
    lo, hi = jacobi(W, g, -1)
    return W[g + lo, lo], W[g + hi, hi]


@njit(cache=True, borrows=True)
def singularity_measure(A: FloatArray, ix: IntArray, W: FloatArray) -> float:
    """`SerialArm.singularity_measure` at the frames in W: sigma_min / sigma_max of M, the
    square roots of G's extreme eigenvalues (to about 1e-12 relative where it is 0.01)."""
    lo, hi = gram_extremes(W, singular_gram(A, ix, W))
    return math.sqrt(max(lo, 0.0) / hi) if hi > 0.0 else 0.0


@njit(cache=True, borrows=True)
def measures(A: FloatArray, ix: IntArray, Q: FloatArray, W: FloatArray, out: FloatArray) -> None:
    """`singularity_measure` at each row of Q (N, n) into out (N,); W the work array."""
    for i in range(Q.shape[0]):
        frames(A, ix, Q[i], W)
        out[i] = singularity_measure(A, ix, W)


@njit(cache=True, borrows=True)
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


@njit(cache=True, borrows=True)
def singular_terms(A: FloatArray, ix: IntArray, W: FloatArray, grad: FloatArray) -> float:
    """kappa = s_min / s_max of M at the frames in W (`singularity_measure`, the same value)
    and its exact gradient over the active joints into grad (m,).

    d s / d q_j = u' (dM / dq_j) v for a simple singular value s with singular vectors u (5,),
    v = M' u / s (m,): u an eigenvector of G. dM / dq_j from the chain's second derivatives
    (columns c < j of the tip's Jacobian move with the point, z_c x J_j for a revolute c;
    columns c > j turn with a revolute joint j, z_j x J_c, as do their axes, z_j x z_c) and the
    motion of the normals with the needle axis (d a / d q_j = omega_j x a). Where s_min or
    s_max is 0 (kappa 0 or M zero) kappa is not differentiable and grad is 0."""
    n, m = ix[0], ix[1]
    g = singular_gram(A, ix, W)
    r, v = g - SING, g + SING
    lo, hi = jacobi(W, g, v)
    s_lo, s_hi = math.sqrt(max(W[g + lo, lo], 0.0)), math.sqrt(max(W[g + hi, hi], 0.0))
    for j in range(m):
        grad[j] = 0.0
    if s_lo <= 0.0 or s_hi <= 0.0:
        return 0.0
    y = v + SING  # rows y, y + 1: v_min, v_max = M' u / s
    for k in range(m):
        u_lo, u_hi = 0.0, 0.0
        for i in range(SING):
            u_lo += W[r + i, k] * W[v + i, lo]
            u_hi += W[r + i, k] * W[v + i, hi]
        W[y, k], W[y + 1, k] = u_lo / s_lo, u_hi / s_hi
    length = A[5 * n + 12, 0]
    o = 4 * (n + 1)  # J_tip's rows (`singular_gram`)
    a = needle_axis(A, n, W)
    n1, n2, e_k, norm = needle_normals(*a)
    zero = (0.0, 0.0, 0.0)
    for j in range(m):
        cj = ix[2 + n + j]
        zj = joint_axis(A, n, W, cj)
        rev_j = ix[2 + cj] == 0
        da = cross(zj, a) if rev_j else zero  # omega_j x a
        dc = cross(da, e_k)
        dot = dc[0] * n1[0] + dc[1] * n1[1] + dc[2] * n1[2]
        dn1 = ((dc[0] - dot * n1[0]) / norm, (dc[1] - dot * n1[1]) / norm,
               (dc[2] - dot * n1[2]) / norm)  # fmt: skip
        dn2 = plus(cross(da, n1), cross(a, dn1))
        ds_lo, ds_hi = 0.0, 0.0
        for k in range(m):
            ck = ix[2 + n + k]
            zk = joint_axis(A, n, W, ck)
            omega = zk if ix[2 + ck] == 0 else zero  # J_omega's column k
            dv, dw = zero, zero  # d J_tip[:, k], d J_omega[:, k]
            if ck > cj and rev_j:
                dv = cross(zj, (W[o, k], W[o + 1, k], W[o + 2, k]))
                dw = cross(zj, omega)
            elif ck <= cj and ix[2 + ck] == 0:
                dv = cross(zk, (W[o, j], W[o + 1, j], W[o + 2, j]))
            d3 = dot3(dn1, omega) + dot3(n1, dw)
            d4 = dot3(dn2, omega) + dot3(n2, dw)
            ds_lo += column_term(W, v, lo, dv, length, d3, d4) * W[y, k]
            ds_hi += column_term(W, v, hi, dv, length, d3, d4) * W[y + 1, k]
        grad[j] = (ds_lo * s_hi - s_lo * ds_hi) / (s_hi * s_hi)
    return math.sqrt(max(W[g + lo, lo], 0.0) / W[g + hi, hi])  # as `singularity_measure`


@njit(cache=True, borrows=True)
def column_term(W: FloatArray, v: int, col: int, dv: tuple, length: float, d3: float,
                d4: float) -> float:  # fmt: skip
    """u' dM[:, k] for the eigenvector u in column col of the block at rows v of W and the
    column dM[:, k] = (dv / l, d3, d4)."""
    acc = (W[v, col] * dv[0] + W[v + 1, col] * dv[1] + W[v + 2, col] * dv[2]) / length
    return acc + W[v + 3, col] * d3 + W[v + 4, col] * d4


@njit(cache=True, borrows=True)
def cross(a: tuple, b: tuple) -> tuple:
    """a x b for 3-tuples."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(cache=True, borrows=True)
def plus(a: tuple, b: tuple) -> tuple:
    """a + b for 3-tuples."""
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@njit(cache=True, borrows=True)
def dot3(a: tuple, b: tuple) -> float:
    """a . b for 3-tuples."""
    return float(a[0] * b[0] + a[1] * b[1] + a[2] * b[2])
