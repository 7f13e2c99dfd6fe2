"""Compiled curved-needle kinematics of any serial arm: the needle base frame from the chain
kernels' frames, the tip on the arc, X_c and J_c (the implementation of
`rcmplan.robot.curved.CurvedTipRobot` on a `SerialArm`; its steps are
`rcmplan.control.curved_step`'s).

The arm travels as the chain kernels' arrays (`chain_kinematics`) with a tail (`pack` builds
them): A gains row 5 n + 13 = (x, z, 0, 0),
the arc's end in the needle base frame (the mount) [m]; ix gains (m_c, the m_c active joints of
the curved needle: the arm's active joints and its roll joint). The head of both is the arm's
own, so the chain kernels (frames, the singularity check over the arm's active joints) read them
unchanged. The work array W has the curved work block (`curved_block`) after its joint axes
rows (`block_row`). The base frame's geometric Jacobian over the curved needle's active joints:
J_v = z_k x (o - o_k), J_w = z_k for a revolute joint k; J_v = z_k, J_w = 0 for a prismatic one.
The small kernels the loop calls each iteration are inlined into it (`inline="always"`).
Imports numba.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.robot import curved_block as ck
from rcmplan.robot.chain_kinematics import (
    IntArray,
    axes_row,
    frames,
    joint_axis,
    needle_axis,
    needle_point,
    rotate,
)
from rcmplan.robot.needle import roll_of


def pack(A: FloatArray, ix: NDArray[np.int64], tip_local: FloatArray,
         active: tuple[int, ...]) -> tuple[FloatArray, NDArray[np.int64]]:  # fmt: skip
    """The arm's chain arrays (A, ix) with the curved needle's tail: the arc's end (x, z) in the
    mount frame [m] and the curved needle's m_c active joints."""
    A = np.vstack([A, [[tip_local[0], tip_local[2], 0.0, 0.0]]])
    ix = np.concatenate([ix, [len(active)], np.asarray(active, dtype=np.int64)])
    return np.ascontiguousarray(A), ix


def work_shape(n: int, m: int, m_c: int) -> tuple[int, int]:
    """Shape of W for n joints, m active for the straight shaft, m_c for the curved needle."""
    return axes_row(n) + n + ck.BLOCK_ROWS, max(ck.WIDTH, m + 1, m_c + 1)


@njit(cache=True, borrows=True)
def block_row(n: int) -> int:
    """First row of the curved work block in W."""
    return axes_row(n) + n


@njit(cache=True, inline="always")
def active_span(ix: IntArray) -> tuple[int, int]:
    """(first entry of the curved needle's active joints in ix, their count m_c)."""
    tail = 2 + ix[0] + ix[1]
    return tail + 1, ix[tail]


@njit(cache=True, inline="always")
def frame(A: FloatArray, n: int, W: FloatArray) -> tuple[tuple, tuple, tuple, tuple]:
    """(o, a, b, tip) at the frames in W: the needle base, the shaft axis, the bend direction
    (the mount's x in the world) and the tip o + x b + z a."""
    ml = 4 * (n + 2)
    o = needle_point(A, n, W, 0.0)
    a = needle_axis(A, n, W)
    b = rotate(W, 4 * n, A[ml, 0], A[ml + 1, 0], A[ml + 2, 0])
    x, z = A[5 * n + 13, 0], A[5 * n + 13, 1]
    tip = (x * b[0] + z * a[0] + o[0], x * b[1] + z * a[1] + o[1], x * b[2] + z * a[2] + o[2])
    return o, a, b, tip


@njit(cache=True, borrows=True)
def jacobian(A: FloatArray, ix: IntArray, W: FloatArray, lam: float, pose: bool) -> None:
    """J_c (7, m_c + 1) at the frames in W into the curved work block."""
    n = ix[0]
    c = block_row(n)
    first, mc = active_span(ix)
    o, a, _, tip = frame(A, n, W)
    for j in range(mc):
        k = ix[first + j]
        zx, zy, zz = joint_axis(A, n, W, k)
        if ix[2 + k] != 0:
            W[c, j], W[c + 1, j], W[c + 2, j] = zx, zy, zz
            W[c + 3, j], W[c + 4, j], W[c + 5, j] = 0.0, 0.0, 0.0
            continue
        dx, dy, dz = o[0] - W[4 * k, 3], o[1] - W[4 * k + 1, 3], o[2] - W[4 * k + 2, 3]
        W[c, j], W[c + 1, j], W[c + 2, j] = zy * dz - zz * dy, zz * dx - zx * dz, zx * dy - zy * dx
        W[c + 3, j], W[c + 4, j], W[c + 5, j] = zx, zy, zz
    p = o if pose else needle_point(A, n, W, lam)
    ck.assemble(W, c, mc, o, tip, p, a, A[5 * n + 12, 0], pose)


@njit(cache=True, inline="always")
def task(A: FloatArray, n: int, W: FloatArray, lam: float, pose: bool, x: FloatArray) -> None:
    """X_c = (p_tip, rho, p(lambda)) at the frames in W into x (7,), or with `pose`
    (p_tip, rho, p(0))."""
    o, a, b, t = frame(A, n, W)
    x[0], x[1], x[2] = t
    x[3] = roll_of(a[0], a[1], a[2], b[0], b[1], b[2])
    x[4], x[5], x[6] = o if pose else needle_point(A, n, W, lam)


@njit(cache=True, inline="always")
def tip(A: FloatArray, n: int, W: FloatArray) -> tuple[float, float, float]:
    """The tip on the arc at the frames in W."""
    return frame(A, n, W)[3]


@njit(cache=True, borrows=True)
def task_jacobian(A: FloatArray, ix: IntArray, W: FloatArray, q: FloatArray, lam: float,
                  pose: bool, x: FloatArray) -> None:  # fmt: skip
    """Frames of q into W, X_c (or the whole pose) into x (7,) and J_c into the curved work
    block's J rows (`block_row` + `curved_block.J`)."""
    frames(A, ix, q, W)
    task(A, ix[0], W, lam, pose, x)
    jacobian(A, ix, W, lam, pose)


@njit(cache=True, borrows=True)
def needle_frames(A: FloatArray, ix: IntArray, W: FloatArray, Q: FloatArray,
                  out: FloatArray) -> None:  # fmt: skip
    """For each joints row of Q (R, n): the needle base p(0), the shaft's end p(1), the shaft
    axis a and the bend direction b into out[r] (4, 3); W is the work array."""
    n = ix[0]
    for r in range(Q.shape[0]):
        frames(A, ix, Q[r], W)
        o, a, b, _ = frame(A, n, W)
        end = needle_point(A, n, W, 1.0)
        for i in range(3):
            out[r, 0, i], out[r, 1, i], out[r, 2, i], out[r, 3, i] = o[i], end[i], a[i], b[i]
