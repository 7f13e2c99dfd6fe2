"""Compiled kinematics and control steps of any serial arm holding a straight needle.

The same maths as `SerialArm` (`robot/model.py`), `angles_jacobian` (`robot/needle.py`), the
X_ext stacking (`control/augmented.py`) and `PinvSolver` / `DlsSolver` (`control/solvers.py`),
so results agree with the reference to rounding. Imports numba (the `fast` extra); loaded only
through `rcmplan.compiled.cache.chain_kernels`.

An arm travels as two arrays (`rcmplan.compiled.arm.pack_arm` builds them):
- A (float64, (5 n + 13, 4)): (4, 4) blocks at rows 4 b (b < n: joint b's origin; b = n: the
  chain base, n + 1: its end frame `tip`, n + 2: the needle mount), then row 4 (n + 3) + k =
  (joint k's unit axis, joint k's home), then row 5 n + 12 = (needle length l [m], 0, 0, 0).
- ix (int64): n, m, prismatic flags (n,), active joint indices (m,).
One work array W (float64, `work_shape(n, m)`) holds the frames (rows 4 k..4 k + 3 for frame
k), J, a 6 x 6 scratch, vector rows, and the singularity measure's (5, m) matrix and (5, 5)
Gram matrix. The kernels allocate nothing and index A and W by row offsets: numba views
(slices, reshapes) cost tens of ns each, as much as a joint's kinematics.
Joints q (n,) in [rad] or [m]; steps d = (dq[active], dlambda), (m + 1,).

A kernel that needs the frames of q either computes them (`frames`) or says "at the frames in
W": a compiled loop computes them once per iteration and every later quantity reads them.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from rcmplan._validate import FloatArray
from rcmplan.compiled.kernels import dls_solve, gauss_solve, tip_of_target
from rcmplan.control.solvers import PIVOT_DISTANCE

IntArray = NDArray[np.int64]
ROWS = 6  # X_ext = (x_tip, phi, psi, p_rcm)
X, E, F, Z, TIP, AXIS = range(6)  # vector rows of W after J and the scratch S
SING = 5  # rows of the singularity measure's matrix [J_tip / l; N J_omega]
CERTIFY = 1e-6  # relative margin of the singularity certificate (rounding is ~1e-15)


def work_shape(n: int, m: int) -> tuple[int, int]:
    """Shape of the work array W for n joints, m of them active."""
    return axes_row(n) + n, max(ROWS, m + 1)


@njit(cache=True)
def axes_row(n: int) -> int:
    """First row of W's joint axes in the world (row axes_row(n) + k: joint k's, 3 columns)."""
    return 4 * (n + 1) + 2 * ROWS + 6 + 2 * SING


@njit(cache=True)
def compose(P: FloatArray, p: int, Q: FloatArray, r: int, out: FloatArray, o: int) -> None:
    """Rows o..o+2 of out = (P @ Q)[:3] for rigid transforms at rows p of P and r of Q."""
    for i in range(3):
        a0, a1, a2, a3 = P[p + i, 0], P[p + i, 1], P[p + i, 2], P[p + i, 3]
        for j in range(4):
            out[o + i, j] = a0 * Q[r, j] + a1 * Q[r + 1, j] + a2 * Q[r + 2, j]
        out[o + i, 3] += a3
    out[o + 3, 0], out[o + 3, 1], out[o + 3, 2], out[o + 3, 3] = 0.0, 0.0, 0.0, 1.0


@njit(cache=True)
def move(T: FloatArray, o: int, A: FloatArray, a: int, prismatic: bool, q: float) -> None:
    """T = T @ motion for the transform at rows o of T: a slide by q [m] along, or a turn by
    q [rad] about, the unit axis A[a, :3] of that frame (Rodrigues' formula,
    `robot/chain.py::_motion`; about z or y, only the two columns it turns)."""
    x, y, z = A[a, 0], A[a, 1], A[a, 2]
    if prismatic:
        for i in range(o, o + 3):
            T[i, 3] += T[i, 0] * (q * x) + T[i, 1] * (q * y) + T[i, 2] * (q * z)
        return
    c, s = math.cos(q), math.sin(q)
    if x == 0.0 and y == 0.0 and z == 1.0:  # about z (URDF's usual axis): columns 0, 1 turn
        for i in range(o, o + 3):
            a0, a1 = T[i, 0], T[i, 1]
            T[i, 0], T[i, 1] = a0 * c + a1 * s, a1 * c - a0 * s
        return
    if x == 0.0 and y == 1.0 and z == 0.0:  # about y: columns 2, 0 turn
        for i in range(o, o + 3):
            a0, a2 = T[i, 0], T[i, 2]
            T[i, 0], T[i, 2] = a0 * c - a2 * s, a2 * c + a0 * s
        return
    C = 1.0 - c
    r00, r01, r02 = c + x * x * C, x * y * C - z * s, x * z * C + y * s
    r10, r11, r12 = y * x * C + z * s, c + y * y * C, y * z * C - x * s
    r20, r21, r22 = z * x * C - y * s, z * y * C + x * s, c + z * z * C
    for i in range(o, o + 3):
        a0, a1, a2 = T[i, 0], T[i, 1], T[i, 2]
        T[i, 0] = a0 * r00 + a1 * r10 + a2 * r20
        T[i, 1] = a0 * r01 + a1 * r11 + a2 * r21
        T[i, 2] = a0 * r02 + a1 * r12 + a2 * r22


@njit(cache=True)
def rotate(T: FloatArray, o: int, x: float, y: float, z: float) -> tuple[float, float, float]:
    """The rotation at rows o of T applied to (x, y, z)."""
    return (T[o, 0] * x + T[o, 1] * y + T[o, 2] * z,
            T[o + 1, 0] * x + T[o + 1, 1] * y + T[o + 1, 2] * z,
            T[o + 2, 0] * x + T[o + 2, 1] * y + T[o + 2, 2] * z)  # fmt: skip


@njit(cache=True)
def frames(A: FloatArray, ix: IntArray, q: FloatArray, W: FloatArray) -> None:
    """Frames 0..n (joints after motion, then the end frame) and the joint axes in the world
    into W's rows."""
    n = ix[0]
    r = axes_row(n)
    for k in range(n):
        if k == 0:
            compose(A, 4 * n, A, 0, W, 0)
        else:
            compose(W, 4 * (k - 1), A, 4 * k, W, 4 * k)
        a = 4 * (n + 3) + k
        move(W, 4 * k, A, a, ix[2 + k] != 0, q[k])
        W[r + k, 0], W[r + k, 1], W[r + k, 2] = rotate(W, 4 * k, A[a, 0], A[a, 1], A[a, 2])
    compose(W, 4 * (n - 1), A, 4 * (n + 1), W, 4 * n)


@njit(cache=True)
def needle_point(A: FloatArray, n: int, W: FloatArray, lam: float) -> tuple[float, float, float]:
    """p(lambda) in [m] (eq. 3.7): the end frame applied to mount origin + lambda l mount z."""
    ml, e = 4 * (n + 2), 4 * n
    s = lam * A[5 * n + 12, 0]
    x, y, z = rotate(W, e, A[ml, 3] + s * A[ml, 2], A[ml + 1, 3] + s * A[ml + 1, 2],
                     A[ml + 2, 3] + s * A[ml + 2, 2])  # fmt: skip
    return x + W[e, 3], y + W[e + 1, 3], z + W[e + 2, 3]


@njit(cache=True)
def needle_axis(A: FloatArray, n: int, W: FloatArray) -> tuple[float, float, float]:
    """The unit needle axis (base to tip) in the world: the end frame applied to mount z."""
    ml = 4 * (n + 2)
    return rotate(W, 4 * n, A[ml, 2], A[ml + 1, 2], A[ml + 2, 2])


@njit(cache=True)
def joint_axis(A: FloatArray, n: int, W: FloatArray, k: int) -> tuple[float, float, float]:
    """Joint k's unit axis in the world (stored by `frames`)."""
    r = axes_row(n) + k
    return W[r, 0], W[r, 1], W[r, 2]


@njit(cache=True)
def point_jacobian(A: FloatArray, ix: IntArray, W: FloatArray, lam: float, J: FloatArray,
                   r: int) -> None:  # fmt: skip
    """d p(lambda) / d(q[active], lambda) (eqs. 2.10, 2.11, 3.10) into rows r..r+2 of J."""
    n, m = ix[0], ix[1]
    px, py, pz = needle_point(A, n, W, lam)
    for j in range(m):
        k = ix[2 + n + j]
        zx, zy, zz = joint_axis(A, n, W, k)
        if ix[2 + k] != 0:
            J[r, j], J[r + 1, j], J[r + 2, j] = zx, zy, zz  # eq. 2.11
            continue
        dx, dy, dz = px - W[4 * k, 3], py - W[4 * k + 1, 3], pz - W[4 * k + 2, 3]
        J[r, j] = zy * dz - zz * dy  # eq. 2.10: z x (p - o_k)
        J[r + 1, j] = zz * dx - zx * dz
        J[r + 2, j] = zx * dy - zy * dx
    ax, ay, az = needle_axis(A, n, W)
    length = A[5 * n + 12, 0]
    J[r, m], J[r + 1, m], J[r + 2, m] = length * ax, length * ay, length * az  # dp/dlambda


@njit(cache=True)
def angle_rows(A: FloatArray, ix: IntArray, W: FloatArray, thesis: bool, J: FloatArray,
               r: int) -> None:  # fmt: skip
    """d(phi, psi) / d(q[active], lambda) into rows r, r+1 of J: exact (`angles_jacobian`:
    da_j = omega_j x a, then the chain rule), or eq. 6.1's (omega_y, omega_z) if `thesis`."""
    n, m = ix[0], ix[1]
    ax, ay, az = needle_axis(A, n, W)
    h2 = ax * ax + az * az
    h = math.sqrt(h2)
    for j in range(m):
        k = ix[2 + n + j]
        wx, wy, wz = 0.0, 0.0, 0.0
        if ix[2 + k] == 0:
            wx, wy, wz = joint_axis(A, n, W, k)
        if thesis:
            J[r, j], J[r + 1, j] = wy, wz
            continue
        dx, dy, dz = wy * az - wz * ay, wz * ax - wx * az, wx * ay - wy * ax
        J[r, j] = (az * dx - ax * dz) / h2
        J[r + 1, j] = -h * dy + ay * (ax * dx + az * dz) / h
    J[r, m], J[r + 1, m] = 0.0, 0.0


@njit(cache=True)
def task_at(A: FloatArray, n: int, W: FloatArray, lam: float, x: FloatArray) -> None:
    """X_ext = (x_tip [m], phi, psi [rad], p_rcm [m]) (eq. 3.14) at the frames in W into x."""
    x[0] = needle_point(A, n, W, 1.0)[0]
    ax, ay, az = needle_axis(A, n, W)
    x[1] = math.atan2(az, -ax)
    x[2] = math.atan2(-ay, math.hypot(ax, az))
    x[3], x[4], x[5] = needle_point(A, n, W, lam)


@njit(cache=True)
def jacobian_at(A: FloatArray, ix: IntArray, W: FloatArray, lam: float, thesis: bool,
                J: FloatArray, r: int, tip_ready: bool = False) -> None:  # fmt: skip
    """J_a (eq. 3.15; eq. 6.1's angle rows if `thesis`) at the frames in W into
    J[r:r + 6, :m + 1]; `tip_ready`: row r already holds d p(1) / d theta_ext."""
    m = ix[1]
    if not tip_ready:  # row r kept: the tip's x; rows r + 1, 2 overwritten
        point_jacobian(A, ix, W, 1.0, J, r)
    J[r, m] = 0.0  # lambda moves no tip
    angle_rows(A, ix, W, thesis, J, r + 1)
    point_jacobian(A, ix, W, lam, J, r + 3)


@njit(cache=True)
def evaluate(A: FloatArray, ix: IntArray, W: FloatArray, q: FloatArray, lam: float,
             thesis: bool, x: FloatArray, J: FloatArray) -> None:  # fmt: skip
    """Frames into W, X_ext into x (6,) and J_a into J[:6, :m + 1] at (q, lambda)."""
    frames(A, ix, q, W)
    task_at(A, ix[0], W, lam, x)
    jacobian_at(A, ix, W, lam, thesis, J, 0)


@njit(cache=True)
def task_jacobian(A: FloatArray, ix: IntArray, W: FloatArray, q: FloatArray, lam: float,
                  thesis: bool, x: FloatArray, J: FloatArray) -> None:  # fmt: skip
    """X_ext (6,) and J_a (6, m + 1) at (q, lambda) into x and J."""
    evaluate(A, ix, W, q, lam, thesis, x, J)


@njit(cache=True)
def lu_solve(W: FloatArray, S: int, n: int, b: int) -> None:
    """Solve M x = W[b, :n] in place for the n x n matrix M at rows S.. of W (overwritten):
    Gaussian elimination with partial pivoting as LAPACK's getrf/getrs do it (multipliers
    scaled by the pivot's reciprocal, back substitution dividing), the way `np.linalg.solve`
    solves the reference's systems."""
    for c in range(n):
        p = c
        for r in range(c + 1, n):
            if abs(W[S + r, c]) > abs(W[S + p, c]):
                p = r
        if p != c:
            for k in range(c, n):
                W[S + c, k], W[S + p, k] = W[S + p, k], W[S + c, k]
            W[b, c], W[b, p] = W[b, p], W[b, c]
        inv = 1.0 / W[S + c, c]
        for r in range(c + 1, n):
            f = W[S + r, c] * inv
            for k in range(c + 1, n):
                W[S + r, k] -= f * W[S + c, k]
            W[b, r] -= f * W[b, c]
    for r in range(n - 1, -1, -1):
        acc = W[b, r]
        for k in range(r + 1, n):
            acc -= W[S + r, k] * W[b, k]
        W[b, r] = acc / W[S + r, r]


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
    if not tip_of_target(target, a, tip):
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
