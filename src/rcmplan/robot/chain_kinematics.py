"""The kinematics of any serial arm holding a straight needle, as numba kernels: frames, needle
points, the point and angle Jacobians, X_ext and J_a (the memory layout every chain kernel
shares). The one definition: `SerialArm` (`robot/model.py`) calls these kernels from Python,
the compiled loops from compiled code.

An arm travels as two arrays (`pack` builds them):
- A (float64, (5 n + 13, 4)): (4, 4) blocks at rows 4 b (b < n: joint b's origin; b = n: the
  chain base, n + 1: its end frame `tip`, n + 2: the needle mount), then row 4 (n + 3) + k =
  (joint k's unit axis, joint k's home), then row 5 n + 12 = (needle length l [m], 0, 0, 0).
- ix (int64): n, m, prismatic flags (n,), active joint indices (m,).
One work array W (float64, `work_shape(n, m)`) holds the frames (rows 4 k..4 k + 3 for frame
k), J, a 6 x 6 scratch, vector rows, the singularity measure's (5, m) matrix, (5, 5) Gram
matrix, (5, 5) eigenvectors and two (m,) right singular vectors (`chain_singular`), and the
joint axes in the world, each beside the joint value the frames were computed at (`frames` is
the only kernel that writes the frames, so a loop reads them again without recomputing when
the joints have not changed: `holds_frames`). The kernels allocate nothing and index A and W
by row offsets: numba views (slices, reshapes) cost tens of ns each, as much as a joint's
kinematics.
Joints q (n,) in [rad] or [m]; steps d = (dq[active], dlambda), (m + 1,).

A kernel that needs the frames of q either computes them (`frames`) or says "at the frames in
W": a compiled loop computes them once per iteration and every later quantity reads them.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.robot.needle import axis_angles

IntArray = NDArray[np.int64]
ROWS = 6  # X_ext = (x_tip, phi, psi, p_rcm)
X, E, F, Z, TIP, AXIS = range(6)  # vector rows of W after J and the scratch S
SING = 5  # rows of the singularity measure's matrix [J_tip / l; N J_omega]


def work_shape(n: int, m: int) -> tuple[int, int]:
    """Shape of the work array W for n joints, m of them active."""
    return axes_row(n) + n, max(ROWS, m + 1)


@njit(cache=True, borrows=True)
def axes_row(n: int) -> int:
    """First row of W's joint axes in the world (row axes_row(n) + k: joint k's, 3 columns,
    and in column 3 q[k] of the frames in W)."""
    return singular_row(n) + 3 * SING + 2


@njit(cache=True, borrows=True)
def singular_row(n: int) -> int:
    """First row of the singularity measure's matrix M in W; its Gram matrix, eigenvectors
    and right singular vectors follow (`chain_singular`)."""
    return 4 * (n + 1) + 2 * ROWS + 6


# compose, move and rotate are inlined into their callers (`frames`, the needle's points and
# axis): a call passes each array as its fields, and inlined the arms' loops take 0.82 (Panda)
# and 0.89 (UR5) of the time per record, the first UR5 run compiling as long (benchmarks.md).
@njit(cache=True, borrows=True, inline="always")
def compose(P: FloatArray, p: int, Q: FloatArray, r: int, out: FloatArray, o: int) -> None:
    """Rows o..o+2 of out = (P @ Q)[:3] for rigid transforms at rows p of P and r of Q."""
    for i in range(3):
        a0, a1, a2, a3 = P[p + i, 0], P[p + i, 1], P[p + i, 2], P[p + i, 3]
        for j in range(4):
            out[o + i, j] = a0 * Q[r, j] + a1 * Q[r + 1, j] + a2 * Q[r + 2, j]
        out[o + i, 3] += a3
    out[o + 3, 0], out[o + 3, 1], out[o + 3, 2], out[o + 3, 3] = 0.0, 0.0, 0.0, 1.0


@njit(cache=True, borrows=True, inline="always")
def move(T: FloatArray, o: int, A: FloatArray, a: int, prismatic: bool, q: float) -> None:
    """T = T @ motion for the transform at rows o of T: a slide by q [m] along, or a turn by
    q [rad] about, the unit axis A[a, :3] of that frame (Rodrigues' formula; about z or y, only
    the two columns it turns)."""
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


@njit(cache=True, borrows=True, inline="always")
def rotate(T: FloatArray, o: int, x: float, y: float, z: float) -> tuple[float, float, float]:
    """The rotation at rows o of T applied to (x, y, z)."""
    return (T[o, 0] * x + T[o, 1] * y + T[o, 2] * z,
            T[o + 1, 0] * x + T[o + 1, 1] * y + T[o + 1, 2] * z,
            T[o + 2, 0] * x + T[o + 2, 1] * y + T[o + 2, 2] * z)  # fmt: skip


@njit(cache=True, borrows=True)
def frames(A: FloatArray, ix: IntArray, q: FloatArray, W: FloatArray) -> None:
    """Frames 0..n (joints after motion, then the end frame), the joint axes in the world and
    the joints q themselves into W's rows."""
    n = ix[0]
    r = axes_row(n)
    for k in range(n):
        W[r + k, 3] = q[k]
        if k == 0:
            compose(A, 4 * n, A, 0, W, 0)
        else:
            compose(W, 4 * (k - 1), A, 4 * k, W, 4 * k)
        a = 4 * (n + 3) + k
        move(W, 4 * k, A, a, ix[2 + k] != 0, q[k])
        W[r + k, 0], W[r + k, 1], W[r + k, 2] = rotate(W, 4 * k, A[a, 0], A[a, 1], A[a, 2])
    compose(W, 4 * (n - 1), A, 4 * (n + 1), W, 4 * n)


@njit(cache=True, borrows=True)
def holds_frames(ix: IntArray, q: FloatArray, W: FloatArray) -> bool:
    """True if W holds the frames of exactly the joints q (n,) (`frames` left them; a W never
    framed holds NaN there: `blank_work`)."""
    r = axes_row(ix[0])
    for k in range(ix[0]):  # noqa: SIM110 (a plain loop compiles best)
        if W[r + k, 3] != q[k]:
            return False
    return True


def blank_work(shape: tuple[int, int], n: int) -> FloatArray:
    """A work array of `shape` for n joints (`work_shape`, or a curved needle's) that holds no
    frames: zeros, and NaN where `frames` keeps its joints (`holds_frames` is False for any)."""
    W = np.zeros(shape)
    W[axes_row(n) : axes_row(n) + n, 3] = np.nan
    return W


@njit(cache=True, borrows=True)
def needle_point(A: FloatArray, n: int, W: FloatArray, lam: float) -> tuple[float, float, float]:
    """p(lambda) in [m] (eq. 3.7): the end frame applied to mount origin + lambda l mount z."""
    ml, e = 4 * (n + 2), 4 * n
    s = lam * A[5 * n + 12, 0]
    x, y, z = rotate(W, e, A[ml, 3] + s * A[ml, 2], A[ml + 1, 3] + s * A[ml + 1, 2],
                     A[ml + 2, 3] + s * A[ml + 2, 2])  # fmt: skip
    return x + W[e, 3], y + W[e + 1, 3], z + W[e + 2, 3]


@njit(cache=True, borrows=True)
def needle_axis(A: FloatArray, n: int, W: FloatArray) -> tuple[float, float, float]:
    """The unit needle axis (base to tip) in the world: the end frame applied to mount z."""
    ml = 4 * (n + 2)
    return rotate(W, 4 * n, A[ml, 2], A[ml + 1, 2], A[ml + 2, 2])


@njit(cache=True, borrows=True)
def joint_axis(A: FloatArray, n: int, W: FloatArray, k: int) -> tuple[float, float, float]:
    """Joint k's unit axis in the world (stored by `frames`)."""
    r = axes_row(n) + k
    return W[r, 0], W[r, 1], W[r, 2]


@njit(cache=True, borrows=True)
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


@njit(cache=True, borrows=True)
def angle_rows(A: FloatArray, ix: IntArray, W: FloatArray, thesis: bool, J: FloatArray,
               r: int) -> None:  # fmt: skip
    """d(phi, psi) / d(q[active], lambda) into rows r, r+1 of J: exact (the axis turns
    with the needle, da_j = omega_j x a, then the chain rule), or eq. 6.1's (omega_y, omega_z)
    if `thesis`."""
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


@njit(cache=True, borrows=True)
def task_at(A: FloatArray, n: int, W: FloatArray, lam: float, x: FloatArray) -> None:
    """X_ext = (x_tip [m], phi, psi [rad], p_rcm [m]) (eq. 3.14) at the frames in W into x."""
    x[0] = needle_point(A, n, W, 1.0)[0]
    x[1], x[2] = axis_angles(*needle_axis(A, n, W))
    x[3], x[4], x[5] = needle_point(A, n, W, lam)


@njit(cache=True, borrows=True)
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


@njit(cache=True, borrows=True)
def evaluate(A: FloatArray, ix: IntArray, W: FloatArray, q: FloatArray, lam: float,
             thesis: bool, x: FloatArray, J: FloatArray) -> None:  # fmt: skip
    """Frames into W, X_ext into x (6,) and J_a into J[:6, :m + 1] at (q, lambda)."""
    frames(A, ix, q, W)
    task_at(A, ix[0], W, lam, x)
    jacobian_at(A, ix, W, lam, thesis, J, 0)


@njit(cache=True, borrows=True)
def task_jacobian(A: FloatArray, ix: IntArray, W: FloatArray, q: FloatArray, lam: float,
                  thesis: bool, x: FloatArray, J: FloatArray) -> None:  # fmt: skip
    """X_ext (6,) and J_a (6, m + 1) at (q, lambda) into x and J."""
    evaluate(A, ix, W, q, lam, thesis, x, J)


def pack(
    chain: Any, mount: Any, length: float, home: Any, active: Any
) -> tuple[FloatArray, IntArray]:
    """The kernels' arrays (A, ix) of a JointChain holding a straight needle of `length` [m]
    on the (4, 4) `mount` in its end frame (layout above); `home` (n,), `active` indices."""
    n = chain.n
    active = np.asarray(active, dtype=np.int64)
    blocks = np.concatenate([chain.origins, [chain.base, chain.tip, mount]])
    rows = np.column_stack([chain.axes, np.asarray(home, dtype=np.float64)])
    A = np.concatenate([blocks.reshape(4 * (n + 3), 4), rows, [[length, 0.0, 0.0, 0.0]]])
    head = np.array([n, active.size], dtype=np.int64)
    ix = np.concatenate([head, chain.prismatic.astype(np.int64), active])
    return np.ascontiguousarray(A, dtype=np.float64), ix


@njit(cache=True, borrows=True)
def angular_jacobian(A: FloatArray, ix: IntArray, W: FloatArray, J: FloatArray, r: int) -> None:
    """The needle's angular velocity per (q[active], lambda) into rows r..r+2 of J: the world
    axis of each active revolute joint (eq. 2.11), zero for prismatic joints and lambda."""
    n, m = ix[0], ix[1]
    for j in range(m + 1):
        J[r, j], J[r + 1, j], J[r + 2, j] = 0.0, 0.0, 0.0
    for j in range(m):
        k = ix[2 + n + j]
        if ix[2 + k] == 0:
            J[r, j], J[r + 1, j], J[r + 2, j] = joint_axis(A, n, W, k)
