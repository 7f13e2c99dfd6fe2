"""Compiled kinematics and control steps of any serial arm holding a straight needle.

`arm_arrays` says whether the chain kernels (`rcmplan.compiled.chain_kernels`) reproduce a
robot model: it must look like a `SerialArm` (a `JointChain` `chain`, a `StraightNeedle`
`needle`, at least five active joints) and the kernels must give its own X_ext and J_a (both
angle-row variants) within 1e-12 at three probe configurations near home, so a subclass with
other geometry is refused. `FastArm` wraps the kernels with argument checks outside the hot
`step`. `check_arm_targets` screens a path of X_ext targets in compiled code before motion, as
`Controller.check_targets` does with `solve_pose`. Needs numba (the `fast` extra).
"""

from __future__ import annotations

import functools
import weakref
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray, scalar, vector
from rcmplan.compiled import cache as fast_cache
from rcmplan.control.augmented import augmented_jacobian, extended_task
from rcmplan.control.targets import solve_pose
from rcmplan.control.tasks import VARIANTS, JacobianVariant
from rcmplan.exceptions import InvalidInputError, UnreachableTargetError
from rcmplan.robot.chain import JointChain
from rcmplan.robot.chain_kinematics import pack
from rcmplan.robot.model import IK_ITERATIONS, IK_TOLERANCE, RobotModel, SerialArm
from rcmplan.robot.needle import StraightNeedle

ArmArrays = tuple[FloatArray, NDArray[np.int64]]
PROBE_TOL = 1e-12
# Newton steps within which the screen clears a target: the shipped arms' injection paths need
# at most 5 of the IK_ITERATIONS; a slower solve might end otherwise in the reference
CLEAR_ITERATIONS = IK_ITERATIONS // 4
_PROBE_PHASES = (0.3, 1.9, 4.1)  # [rad]: probe k is home + 0.1 sin(1.3 j + phase_k) per joint
_checked: weakref.WeakKeyDictionary[object, ArmArrays | None] = weakref.WeakKeyDictionary()


def pack_arm(robot: Any) -> ArmArrays:
    """The kernels' arrays (A, ix) of a SerialArm-like model (`chain_kinematics.pack`)."""
    return pack(robot.chain, robot.needle.mount, robot.needle.length, robot.home, robot.active)


def _arm_like(robot: object) -> bool:
    """True for a model with a JointChain `chain`, a StraightNeedle `needle`, >= 5 active."""
    chain, needle = getattr(robot, "chain", None), getattr(robot, "needle", None)
    active = getattr(robot, "active", ())
    return (isinstance(chain, JointChain) and isinstance(needle, StraightNeedle)
            and len(active) >= 5 and all(0 <= i < chain.n for i in active))  # fmt: skip


def probes(robot: RobotModel) -> FloatArray:
    """The three probe configurations (3, n) near home, in [rad] or [m]."""
    j = np.arange(len(robot.home))
    return np.array([robot.home + 0.1 * np.sin(1.3 * j + ph) for ph in _PROBE_PHASES])


def _reproduces(robot: RobotModel, packed: ArmArrays) -> bool:
    """True if the kernels give the model's X_ext and J_a (both variants) at the probes."""
    k = fast_cache.chain_kernels()
    A, ix = packed
    m = int(ix[1])
    W, x, J = np.empty(k.work_shape(int(ix[0]), m)), np.empty(6), np.empty((6, m + 1))
    for q in probes(robot):
        for lam in (0.0, 0.7, 1.0):
            for variant in VARIANTS:
                k.task_jacobian(A, ix, W, q, lam, variant == "thesis", x, J)
                ref_J = augmented_jacobian(robot, q, lam, variant)  # type: ignore[arg-type]
                if ref_J.shape != J.shape or np.abs(ref_J - J).max() > PROBE_TOL:
                    return False
            if np.abs(extended_task(robot, q, lam) - x).max() > PROBE_TOL:
                return False
    return True


def arm_arrays(robot: RobotModel) -> ArmArrays | None:
    """The kernels' arrays for `robot` if they reproduce it (see the module docstring), else
    None. Checked once per model object."""
    if robot in _checked:
        return _checked[robot]
    packed: ArmArrays | None = None
    if _arm_like(robot):
        packed = pack_arm(robot)
        with np.errstate(all="ignore"):
            if not _reproduces(robot, packed):
                packed = None
    _checked[robot] = packed
    return packed


def arm_supported(robot: RobotModel) -> bool:
    """True if the chain kernels reproduce `robot` (see `arm_arrays`)."""
    return arm_arrays(robot) is not None


def check_arm_targets(robot: RobotModel, targets: FloatArray) -> bool:
    """`solve_pose` on every X_ext target (N, 6) of a path, screened in compiled code, for a
    SerialArm itself whose kinematics the kernels reproduce; False (nothing done) otherwise.

    The kernel runs `needle_pose`'s Newton method (the same cap and tolerance, each target
    seeded with the previous one's joints, the first with home) and flags every target that
    might fail (`chain_kernels.screen_targets`). Where it flags any, the reference check runs
    from the first target through the last flagged one, so that each flagged target gets the
    reference's seed and raises the reference's exception, message and all.
    """
    packed = arm_arrays(robot) if type(robot) is SerialArm else None
    if packed is None:
        return False
    k, (A, ix) = fast_cache.chain_kernels(), packed
    targets = np.ascontiguousarray(targets, dtype=np.float64)
    flags = np.zeros(targets.shape[0], dtype=np.bool_)
    W = np.empty(k.work_shape(int(ix[0]), int(ix[1])))
    bounds = (np.ascontiguousarray(robot.lower, dtype=np.float64),
              np.ascontiguousarray(robot.upper, dtype=np.float64),
              np.ascontiguousarray(robot.home, dtype=np.float64))  # fmt: skip
    k.screen_targets(A, ix, W, *bounds, IK_ITERATIONS, CLEAR_ITERATIONS, IK_TOLERANCE, targets,
                     flags)  # fmt: skip
    flagged = np.flatnonzero(flags)
    seed = None
    for target in targets[: flagged[-1] + 1 if flagged.size else 0]:
        seed = solve_pose(robot, target, seed).q
    return True


def _thesis(variant: JacobianVariant) -> bool:
    if variant not in VARIANTS:
        raise InvalidInputError("variant", variant, f"one of {VARIANTS}")
    return variant == "thesis"


class FastArm:
    """Compiled X_ext, J_a and control steps of a SerialArm (not re-entrant: one work array).

    Args:
        arm: A model `arm_supported` accepts (else InvalidInputError; MissingExtraError without
            numba).
        posture_gain: k_p in [0, 1] of the redundant pinv step (`PinvSolver.posture_gain`).
    """

    def __init__(self, arm: RobotModel, posture_gain: float = 0.05) -> None:
        self._k = fast_cache.chain_kernels()
        packed = arm_arrays(arm)
        if packed is None:
            raise InvalidInputError("arm", getattr(arm, "name", arm), "a SerialArm whose X_ext "
                                    "and J_a the chain kernels reproduce")  # fmt: skip
        self.arm, (self.A, self.ix) = arm, packed
        self.n, self.m = int(self.ix[0]), int(self.ix[1])
        self.posture_gain = scalar("posture_gain", posture_gain, 0.0, 1.0)
        self.W = np.empty(self._k.work_shape(self.n, self.m))
        self._pinv = functools.partial(self._k.pinv_step, self.A, self.ix, self.W)
        self._dls = functools.partial(self._k.dls_step, self.A, self.ix, self.W)

    def _q(self, q: FloatArray) -> FloatArray:
        return np.ascontiguousarray(vector("q", q, self.n), dtype=np.float64)

    def task_jacobian(
        self, q: FloatArray, lam: float, variant: JacobianVariant = "exact"
    ) -> tuple[FloatArray, FloatArray]:
        """X_ext (6,) and J_a (6, m + 1) at (q, lambda)."""
        x, J = np.empty(6), np.empty((6, self.m + 1))
        self._k.task_jacobian(self.A, self.ix, self.W, self._q(q), float(lam), _thesis(variant),
                              x, J)  # fmt: skip
        return x, J

    def task(self, q: FloatArray, lam: float) -> FloatArray:
        """X_ext = (x_tip [m], phi, psi [rad], p_rcm [m]) at (q, lambda), a (6,) array."""
        return self.task_jacobian(q, lam)[0]

    def augmented_jacobian(
        self, q: FloatArray, lam: float, variant: JacobianVariant = "exact"
    ) -> FloatArray:
        """J_a (6, m + 1) at (q, lambda), "exact" or "thesis" angle rows."""
        return self.task_jacobian(q, lam, variant)[1]

    def step(
        self, q: FloatArray, lam: float, target: FloatArray, K: FloatArray,
        out: FloatArray | None = None, variant: JacobianVariant = "exact",
    ) -> FloatArray:  # fmt: skip
        """One `PinvSolver` step (dq[active] [rad, m], dlambda), (m + 1,), for the X_ext target.

        No argument checks (the hot path): q (n,), target (6,) and K (6,) must be contiguous
        float64 arrays; `out` (m + 1,) is filled and returned when given.
        """
        d = np.empty(self.m + 1) if out is None else out
        self._pinv(q, lam, target, K, self.posture_gain, variant == "thesis", d)
        return d

    def dls_step(
        self, q: FloatArray, lam: float, target: FloatArray, damping: float,
        out: FloatArray | None = None,
    ) -> FloatArray:  # fmt: skip
        """One `DlsSolver` step (m + 1,) toward the X_ext target with damping D [m]; the same
        hot-path contract as `step`. UnreachableTargetError if the target fixes no tip."""
        d = np.empty(self.m + 1) if out is None else out
        if not self._dls(q, lam, target, damping, d):
            raise UnreachableTargetError("needle axis perpendicular to x: tip x does not fix "
                                         "the tip")  # fmt: skip
        return d
