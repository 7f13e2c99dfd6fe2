"""Compiled checks of any serial arm: the screen of a path's targets before motion, on the
Newton IK of `chain_pose`."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.robot.chain_kinematics import IntArray
from rcmplan.robot.chain_pose import needle_pose
from rcmplan.robot.needle import x_ext_tip


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
        if not finite or not x_ext_tip(x, a, tip) or abs(a[0]) < 2e-12:
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
