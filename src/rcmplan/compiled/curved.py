"""Which curved-needle robots the compiled loops run, and the compiled screen of a curved
needle's targets before motion (`check_curved_targets`).

A `CurvedTipRobot` with a curved needle (alpha > 0) computes its tip, roll and J_c with the
kernels the loops run (`rcmplan.robot.curved_iramis` on iRAM!S, `curved_arm` on a `SerialArm`),
so the loops take its own arrays (`CurvedTipRobot.arrays`). A subclass, which may answer
otherwise, runs on the reference path. A straight needle (alpha = 0) is the base robot's own and
takes the straight kernels' path.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray
from rcmplan.robot.curved import CurvedArrays, CurvedTipRobot
from rcmplan.robot.model import RobotModel

# Newton steps within which the screen clears a target: the `curved` scenario's targets take at
# most 3 of the 60 (measured); a slower solve might end otherwise in the reference
CLEAR_ITERATIONS = 15


def curved_arrays(robot: RobotModel) -> CurvedArrays | None:
    """The kernels' arrays of a `CurvedTipRobot` itself holding a curved needle, else None."""
    if type(robot) is not CurvedTipRobot:
        return None
    return robot.arrays


def check_curved_targets(
    robot: RobotModel, targets: FloatArray, seed: FloatArray | None
) -> FloatArray | None:
    """`solve_curved_pose` along a path of X_c targets (N, 7) from `seed` (None: home), each
    solve seeded with the previous target's joints, screened in compiled code
    (`curved_checks`); returns the last target's joints, or None (nothing done: not enabled,
    or a model the loops do not run, `curved_arrays`).

    Where the screen flags targets, the reference check runs from the first target through the
    last flagged one with the reference's seeds, so a flagged target that fails raises the
    reference's exception, message and all.
    """
    from rcmplan.control.curved_targets import solve_curved_pose

    targets = np.ascontiguousarray(targets, dtype=np.float64)
    if targets.ndim != 2 or targets.shape[1] != 7:
        return None
    arrays = curved_arrays(robot)
    if arrays is None:
        return None
    start = np.ascontiguousarray(robot.home if seed is None else seed, dtype=np.float64)
    try:
        flags, q = screen(robot, arrays, targets, start)
    except ZeroDivisionError:  # a diverging solve: every target goes to the reference check
        flags, q = np.ones(targets.shape[0], dtype=np.bool_), None
    flagged = np.flatnonzero(flags)
    reference = seed
    for target in targets[: flagged[-1] + 1 if flagged.size else 0]:
        reference = solve_curved_pose(robot, target, reference).q
    return reference if q is None else q


def screen(
    robot: RobotModel, arrays: CurvedArrays, targets: FloatArray, start: FloatArray
) -> tuple[NDArray[np.bool_], FloatArray]:
    """The compiled screen (`curved_checks`) of X_c targets (N, 7) from joints `start`: (flags
    of the targets to check on the reference path, the last target's joints)."""
    from rcmplan.compiled import curved_checks
    from rcmplan.control.curved_targets import POSE_ITERATIONS, POSE_TOLERANCE

    flags, q = np.zeros(targets.shape[0], dtype=np.bool_), np.empty(arrays.n)
    it, clear, tol = POSE_ITERATIONS, CLEAR_ITERATIONS, POSE_TOLERANCE
    if arrays.P is not None:
        curved_checks.screen_iramis(arrays.P, start, it, clear, tol, targets, flags, q)
        return flags, q
    A, ix = arrays.arm()
    W = np.empty(arrays.work_shape())
    lower = np.ascontiguousarray(robot.lower, dtype=np.float64)
    upper = np.ascontiguousarray(robot.upper, dtype=np.float64)
    curved_checks.screen_arm(A, ix, W, lower, upper, start, it, clear, tol, targets, flags, q)
    return flags, q
