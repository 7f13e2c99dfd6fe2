"""Which curved-needle robots the compiled kernels reproduce, the arrays they take, and the
compiled screen of a curved needle's targets before motion (`check_curved_targets`).

A `CurvedTipRobot` with a curved needle (alpha > 0) on iRAM!S (`curved_iramis`, closed form) or
on a `SerialArm` itself (`curved_arm`, the chain kernels) is accepted when the kernels give its
own X_c and J_c (`rcmplan.control.curved`; the whole-pose task too) within 1e-12 at three probe
configurations, and its actuator map and singularity measure where the loop computes them, so a
model with other geometry runs on the reference path. A straight needle (alpha = 0) is the
base robot's own and takes the straight kernels' path (or the reference). Needs numba.
"""

from __future__ import annotations

import math
import weakref
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray
from rcmplan.compiled.arm import arm_arrays, pack_arm, probes
from rcmplan.compiled.records import robot_params
from rcmplan.control.curved import CURVED_POSE_TASKS, CURVED_TASKS
from rcmplan.control.tasks import stack_jacobian, stack_value
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot import iramis_kernels
from rcmplan.robot.curved import CurvedTipRobot
from rcmplan.robot.iramis import Iramis
from rcmplan.robot.model import RobotModel, SerialArm

PROBE_TOL = 1e-12
# Newton steps within which the screen clears a target: the `curved` scenario's targets take at
# most 3 of the 60 (measured); a slower solve might end otherwise in the reference
CLEAR_ITERATIONS = 15
_IRAMIS_PROBES = np.array([[4e-3, 0.3, -6e-3, -0.2, 5e-3, 0.4],
                           [-9e-3, -0.5, 2e-3, 0.6, -3e-3, -1.1],
                           [1e-3, 0.05, 1e-2, 0.12, 2e-2, 0.0]])  # fmt: skip


class CurvedArrays(NamedTuple):
    """The kernels' arrays of a curved-needle robot: `P` for iRAM!S (`curved_iramis.params`),
    else (A, ix) of an arm (`pack_curved_arm`); `n` joints, `m` active (with the roll)."""

    P: FloatArray | None
    A: FloatArray | None
    ix: NDArray[np.int64] | None
    n: int
    m: int

    def arm(self) -> tuple[FloatArray, NDArray[np.int64]]:
        """(A, ix) of an arm (InvalidInputError for iRAM!S's arrays)."""
        if self.A is None or self.ix is None:
            raise InvalidInputError("curved-needle arrays", "iRAM!S's P", "an arm's (A, ix)")
        return self.A, self.ix


_checked: weakref.WeakKeyDictionary[object, CurvedArrays | None] = weakref.WeakKeyDictionary()


def pack_curved_arm(robot: CurvedTipRobot) -> tuple[FloatArray, NDArray[np.int64]]:
    """(A, ix) of the arm holding the shaft, with the curved needle's tail (`curved_arm`)."""
    A, ix = pack_arm(robot.base)
    tip = robot.needle.tip_local()
    A = np.vstack([A, [[tip[0], tip[2], 0.0, 0.0]]])
    ix = np.concatenate([ix, [len(robot.active)], np.asarray(robot.active, dtype=np.int64)])
    return np.ascontiguousarray(A), ix


def _pack(robot: CurvedTipRobot) -> CurvedArrays | None:
    base = robot.base
    if type(base) is Iramis:
        from rcmplan.compiled import curved_iramis

        P = curved_iramis.params(robot_params(base), robot.needle.tip_local())
        return CurvedArrays(P, None, None, 6, 6)
    if type(base) is SerialArm and arm_arrays(base) is not None:
        A, ix = pack_curved_arm(robot)
        return CurvedArrays(None, A, ix, int(ix[0]), len(robot.active))
    return None


def arm_work_shape(arrays: CurvedArrays) -> tuple[int, int]:
    """Shape of the arm loop's work array W for a curved needle on an arm (`curved_arm`)."""
    from rcmplan.compiled import curved_arm

    return curved_arm.work_shape(arrays.n, int(arrays.arm()[1][1]), arrays.m)


def _kernel_task(arrays: CurvedArrays, q: FloatArray, lam: float, pose: bool) -> tuple[Any, Any]:
    """X_c (7,) and J_c (7, m + 1) from the kernels."""
    from rcmplan.compiled import curved_arm, curved_iramis
    from rcmplan.compiled import curved_kernels as ck

    x = np.empty(7)
    if arrays.P is not None:
        C = np.empty((ck.BLOCK_ROWS, 7))
        curved_iramis.task_jacobian(arrays.P, q, lam, pose, x, C)
        return x, C[ck.J : ck.J + 7, : arrays.m + 1]
    A, ix = arrays.arm()
    W = np.empty(arm_work_shape(arrays))
    curved_arm.task_jacobian(A, ix, W, q, lam, pose, x)
    c = curved_arm.block_row(arrays.n) + ck.J
    return x, W[c : c + 7, : arrays.m + 1]


def _reproduces(robot: CurvedTipRobot, arrays: CurvedArrays) -> bool:
    """True if the kernels give the model's X_c, J_c (both tasks), actuator map and singularity
    measure at the probes."""
    configs = _IRAMIS_PROBES if arrays.P is not None else probes(robot)
    for q in configs:
        for lam in (0.0, 0.7, 1.0):
            for pose, tasks in ((False, CURVED_TASKS), (True, CURVED_POSE_TASKS)):
                x, J = _kernel_task(arrays, q, lam, pose)
                dx = x - stack_value(tasks, robot, q, lam)
                dx[3] = (dx[3] + math.pi) % (2.0 * math.pi) - math.pi
                if np.abs(dx).max() > PROBE_TOL:
                    return False
                if np.abs(J - stack_jacobian(tasks, robot, q, lam)).max() > PROBE_TOL:
                    return False
        if arrays.P is not None and not _iramis_maps(robot, arrays.P, q):
            return False
    return True


def _iramis_maps(robot: CurvedTipRobot, P: FloatArray, q: FloatArray) -> bool:
    """The kernels' PCJM maps and singularity measure equal the model's at q."""
    k = iramis_kernels
    s, back = np.empty(6), np.empty(6)
    k.actuators_from_joints(P, q, s)
    k.joints_from_actuators(P, s, back)
    measure = k.singular_measure(math.cos(q[1]), math.cos(q[3]))
    return bool(
        np.allclose(s, robot.actuators_from_joints(q), rtol=0.0, atol=PROBE_TOL)
        and np.allclose(back, robot.joints_from_actuators(s), rtol=0.0, atol=PROBE_TOL)
        and robot.singularity_measure(q) == measure
    )


def curved_arrays(robot: RobotModel) -> CurvedArrays | None:
    """The kernels' arrays for a curved-needle robot they reproduce (module docstring), else
    None (also without numba). Checked once per model object."""
    if robot in _checked:
        return _checked[robot]
    arrays: CurvedArrays | None = None
    curved = isinstance(robot, CurvedTipRobot) and robot.needle.curved
    if curved and type(robot) is CurvedTipRobot:
        arrays = _pack(robot)
        with np.errstate(all="ignore"):
            if arrays is not None and not _reproduces(robot, arrays):
                arrays = None
    _checked[robot] = arrays
    return arrays


def check_curved_targets(
    robot: RobotModel, targets: FloatArray, seed: FloatArray | None
) -> FloatArray | None:
    """`solve_curved_pose` along a path of X_c targets (N, 7) from `seed` (None: home), each
    solve seeded with the previous target's joints, screened in compiled code
    (`curved_checks`); returns the last target's joints, or None (nothing done: not enabled,
    or a robot the kernels do not reproduce).

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
    W = np.empty(arm_work_shape(arrays))
    lower = np.ascontiguousarray(robot.lower, dtype=np.float64)
    upper = np.ascontiguousarray(robot.upper, dtype=np.float64)
    curved_checks.screen_arm(A, ix, W, lower, upper, start, it, clear, tol, targets, flags, q)
    return flags, q
