"""The error of the DLS task, the task pair of the thesis's V-REP IK group, written once for
`DlsSolver` and the compiled loops: the tip to the target's tip and p(lambda) to the trocar,
or, when the target puts the tip on the trocar (a pivot about the tip), the needle base to its
place on the target axis, l behind the tip (the two points then coincide and fix no
direction)."""

from __future__ import annotations

import math

from rcmplan._jit import njit
from rcmplan._validate import FloatArray

Point = FloatArray | tuple[float, float, float]  # the kernels' points are arrays or tuples

# [m] A target tip this close to its trocar point is on it: a pivot about the tip (lambda = 1).
# The loop's default position tolerance, so that a tip the loop left within tolerance of the
# trocar (after the approach) counts as there. The compiled kernels read it as a compile-time
# constant, which numba's cache does not track: after changing it, delete the cached kernels.
PIVOT_DISTANCE = 1e-8


@njit(cache=True, borrows=True)
def is_pivot(tip: FloatArray, target: FloatArray) -> bool:
    """True when the tip point (3,) lies on the X_ext target's trocar point (within
    PIVOT_DISTANCE)."""
    acc = 0.0
    for i in range(3):
        acc += (tip[i] - target[3 + i]) ** 2
    return math.sqrt(acc) < PIVOT_DISTANCE


@njit(cache=True, borrows=True)
def dls_error(tip: FloatArray, a: FloatArray, pivot: bool, length: float, target: FloatArray,
              p_tip: Point, p: Point, e: FloatArray) -> None:  # fmt: skip
    """e (6,) = (tip - p_tip, trocar - p) in [m], p = p(lambda); for a pivot, (tip - l a) - p
    with p = p(0), the needle base, and a (3,) the target's unit axis. tip: the target's tip
    point (`needle.x_ext_tip`), length: the needle's l."""
    for i in range(3):
        e[i] = tip[i] - p_tip[i]
        e[3 + i] = ((tip[i] - length * a[i]) if pivot else target[3 + i]) - p[i]
