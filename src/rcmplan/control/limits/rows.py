"""Row kernels the limits share: the velocity damper and the sphere a point stays inside.

Each kernel writes rows G x <= h of one control step into caller-owned buffers from row r and
returns the next free row: the Python limits (`Constraint`s for `qp_problem.build_step`) and
the compiled QP step (`compiled/qp_kernels.py`, DAQP's arrays) call the same code. x is in the
QP's units (`base.SCALE`); a gradient is d value / d (x SCALE), a row's G is minus it.
"""

from __future__ import annotations

import math

from rcmplan._jit import njit
from rcmplan._validate import FloatArray

SCALE = 1e-6  # [m] or [rad] per unit of the decision variables
RECOVERY = 1e-6  # [m] largest push back per step when a damped quantity is past its floor


@njit(cache=True, borrows=True)
def damper_bound(value: float, floor: float, gain: float, recovery: float) -> float:
    """h of the row -grad x <= h that keeps value + grad x SCALE >= floor, approached at `gain`.

    value_next - floor >= (1 - gain)(value - floor) to first order; past the floor, the value
    returns to it in one step, by up to `recovery`. (Returning at `gain` would let a second-order
    loss each step, such as a point sliding along a sphere, settle at loss / gain past the
    floor; returning at once it stays within one step's loss.)
    """
    gap = value - floor
    need = -gain * gap if gap >= 0.0 else min(-gap, recovery)
    return -need / SCALE


@njit(cache=True, borrows=True)
def damper_rows(grads: FloatArray, values: FloatArray, floor: float, gain: float,
                G: FloatArray, h: FloatArray, r: int) -> int:  # fmt: skip
    """One damper row per value (k,) with its gradient row grads (k, w), each kept above
    `floor` at `gain` (recovery `RECOVERY`); returns the next row."""
    for a in range(values.shape[0]):
        for j in range(grads.shape[1]):
            G[r + a, j] = -grads[a, j]
        h[r + a] = damper_bound(values[a], floor, gain, RECOVERY)
    return r + values.shape[0]


@njit(cache=True, borrows=True)
def sphere_row(J_point: FloatArray, point: FloatArray, center: FloatArray, value: float,
               floor: float, gain: float, recovery: float, G: FloatArray, h: FloatArray,
               r: int) -> int:  # fmt: skip
    """One damper row keeping a point's radial gap `value` (a radius less |point - center|,
    [m]) above `floor`: its gradient is -(u @ J_point), u the outward unit normal at the point
    and J_point (3, w) d point / d (x SCALE). Returns r + 1."""
    d0, d1, d2 = point[0] - center[0], point[1] - center[1], point[2] - center[2]
    norm = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    u0, u1, u2 = d0 / norm, d1 / norm, d2 / norm
    for j in range(J_point.shape[1]):
        G[r, j] = u0 * J_point[0, j] + u1 * J_point[1, j] + u2 * J_point[2, j]
    h[r] = damper_bound(value, floor, gain, recovery)
    return r + 1


@njit(cache=True, borrows=True)
def radial_gap(center: FloatArray, radius: float, point: FloatArray) -> float:
    """radius - |point - center| [m]: positive inside the sphere."""
    d0, d1, d2 = point[0] - center[0], point[1] - center[1], point[2] - center[2]
    return radius - math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)


@njit(cache=True, borrows=True)
def near_any(point: FloatArray, points: FloatArray, tol: float) -> bool:
    """True if `point` (3,) lies within `tol` of a row of `points` (k, 3)."""
    for c in range(points.shape[0]):
        d0 = point[0] - points[c, 0]
        d1 = point[1] - points[c, 1]
        d2 = point[2] - points[c, 2]
        if math.sqrt(d0 * d0 + d1 * d1 + d2 * d2) <= tol:
            return True
    return False


@njit(cache=True, borrows=True)
def times(A: FloatArray, B: FloatArray, out: FloatArray) -> None:
    """out = A @ B for small matrices (compiled callers; numpy's @ from Python)."""
    for i in range(A.shape[0]):
        for j in range(B.shape[1]):
            acc = 0.0
            for k in range(A.shape[1]):
                acc += A[i, k] * B[k, j]
            out[i, j] = acc
