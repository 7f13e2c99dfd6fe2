"""Tasks and step solvers for a curved needle: the third rotation (thesis ch. 5).

A straight needle's roll moves no point of it, so X_ext (eq. 3.14) has six rows for five joints
and lambda. A curved tip turns with the roll, so the roll joins theta_ext (m = 6 on iRAM!S and
the UR5) and the task gains a row. The curved needle's task is

    X_c = (p_tip (3), rho, p_rcm (3)),    J_c = [J_tip; J_rho; J_rcm]   (7, m + 1)

with p_tip the arc's end, rho the needle roll (`rcmplan.robot.needle.roll_from_axes`; on iRAM!S
rho = q5) and p_rcm = p(lambda) on the straight shaft. The thesis's X_ext fixes the tip by its
x and the needle angles, because a straight tip lies on the needle line; a curved tip does not,
so X_c states it whole and fixes the tip direction through the roll: with the tip and the shaft
line through the trocar fixed, the roll is the one remaining freedom of the needle and sets the
tip tangent. J_c is square when m = 6, wider on a redundant arm (pinv adds the null-space
posture). A target is the (7,) vector X_c; the RCM is its last three entries, as in X_ext.

Outside the eye (`CurvedPoseSolver`) the needle follows whole poses: (p_tip, rho, p_base), the
shaft's base instead of the RCM, so that the arc can pass the trocar (`rcmplan.control
.curved_targets.entry_poses`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from rcmplan._validate import FloatArray, scalar, vector
from rcmplan.control.curved_step import (
    CURVED_DLS,
    CURVED_PINV,
    CURVED_POSE,
    arm_step,
    iramis_step,
)
from rcmplan.control.limited_tip import limited_step
from rcmplan.control.solvers import SolverKind, Tolerance, check_damping
from rcmplan.control.targets import checked_target, finite_step
from rcmplan.control.tasks import NeedleBase, RcmPoint, Task, TipPosition
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.chain_kinematics import frames
from rcmplan.robot.curved import CurvedTipRobot
from rcmplan.robot.curved_block import wrap
from rcmplan.robot.iramis_kernels import trig
from rcmplan.robot.model import RobotModel

TARGET_WIDTH = 7
ROLL_ROW = 3


def curved(robot: RobotModel) -> CurvedTipRobot:
    """`robot` if it holds a curved needle, else InvalidInputError."""
    if not isinstance(robot, CurvedTipRobot) or not robot.needle.curved:
        raise InvalidInputError("robot", robot.name, "a robot holding a curved needle")
    return robot


@dataclass(frozen=True)
class NeedleRoll:
    """The needle roll rho in [rad] (the third rotation)."""

    size: ClassVar[int] = 1

    def value(self, robot: RobotModel, q: FloatArray, lam: float) -> FloatArray:
        """(rho,)."""
        return np.array([curved(robot).roll(q)])

    def jacobian(self, robot: RobotModel, q: FloatArray, lam: float) -> FloatArray:
        """(1, m + 1)."""
        return curved(robot).roll_jacobian(q)[None, :]


CURVED_TASKS: tuple[Task, ...] = (TipPosition(), NeedleRoll(), RcmPoint())
CURVED_POSE_TASKS: tuple[Task, ...] = (TipPosition(), NeedleRoll(), NeedleBase())


def task_error(
    tasks: tuple[Task, ...], robot: RobotModel, q: FloatArray, lam: float, target: FloatArray
) -> FloatArray:
    """target - value of the 7-row stack, the roll error wrapped to [-pi, pi)."""
    value = np.concatenate([t.value(robot, q, lam) for t in tasks])
    e = vector("target", target, TARGET_WIDTH) - value
    e[ROLL_ROW] = wrap(e[ROLL_ROW])
    return e


def task_jacobian(
    tasks: tuple[Task, ...], robot: RobotModel, q: FloatArray, lam: float
) -> FloatArray:
    """The stack's Jacobian (7, m + 1)."""
    return np.vstack([t.jacobian(robot, q, lam) for t in tasks])


def check_gains7(K: object) -> FloatArray:
    """K as a (7,) array with every entry in (0, 2) (see `solvers.check_gains`), else raise."""
    k = vector("K", K, TARGET_WIDTH)
    if np.any(k <= 0.0) or np.any(k >= 2.0):
        raise InvalidInputError("K", K, "seven gains in (0, 2) (tip x3, roll, RCM x3)")
    return k


def gains_from_x_ext(K: tuple[float, ...]) -> tuple[float, ...]:
    """Curved-needle gains from X_ext gains: the tip's from x, the roll's from phi, the RCM's."""
    k = tuple(float(v) for v in K)
    return (k[0], k[0], k[0], k[1], k[3], k[4], k[5])


def _tolerance(tol: Tolerance) -> FloatArray:
    p, a = tol
    return np.array([p, p, p, a, p, p, p])


def kernel_step(
    robot: RobotModel, code: int, K: FloatArray, damping: float, gain: float, q: FloatArray,
    lam: float, error: FloatArray,
) -> FloatArray:  # fmt: skip
    """The compiled loops' step d = (dq[active], dlambda) (m + 1,) of the curved solver `code`
    (`curved_step`) at (q, lambda) for its error (7,); `gain` is the null-space posture's.
    A step that is not finite raises as the straight needle's solvers' do (`finite_step`:
    InvalidInputError naming a non-finite error or q, or SingularPoseError)."""
    arrays = curved(robot).arrays
    assert arrays is not None  # `curved` refuses a straight needle
    q = vector("q", q, arrays.n)
    e = checked_target(error, TARGET_WIDTH, "error", finite=False)  # refused by finite_step
    d, work = np.empty(arrays.m + 1), np.empty(arrays.work_shape())
    if arrays.P is not None:
        iramis_step(arrays.P, code, K, damping, q, trig(q), float(lam), e, work, d, np.empty(3))
    else:
        A, ix = arrays.arm()
        frames(A, ix, q, work)
        arm_step(A, ix, work, code, K, gain, damping, q, float(lam), e, d)
    return finite_step(d, robot, q, e)


class CurvedSolver:
    """What the curved-needle solvers share: the task X_c, its error and its tolerance."""

    tasks: ClassVar[tuple[Task, ...]] = CURVED_TASKS
    kind: ClassVar[SolverKind] = "rcm"
    target_width: ClassVar[int] = TARGET_WIDTH
    code: ClassVar[int]
    tol: Tolerance

    def error(self, robot: RobotModel, q: FloatArray, lam: float, target: FloatArray) -> FloatArray:
        """X_c target minus X_c now: (p_tip [m], rho [rad], p_rcm [m])."""
        return task_error(self.tasks, robot, q, lam, target)

    def tolerance(self) -> FloatArray:
        """(position x3, angle, position x3)."""
        return _tolerance(self.tol)


@dataclass(frozen=True)
class CurvedPinvSolver(CurvedSolver):
    """d theta_ext = J_c^+ K e (eq. 3.17 on X_c), plus the null-space posture when J_c is wide.

    Attributes:
        K: Gains (7,) in (0, 2): tip x3, roll, RCM x3.
        tol: Loop tolerance. posture_gain: k_p in [0, 1] (redundant robots only).
    """

    K: tuple[float, ...] = (1.0,) * TARGET_WIDTH
    tol: Tolerance = field(default_factory=Tolerance)
    posture_gain: float = 0.05
    name: ClassVar[str] = "pinv"
    code: ClassVar[int] = CURVED_PINV

    def __post_init__(self) -> None:
        object.__setattr__(self, "K", tuple(check_gains7(self.K)))
        scalar("posture_gain", self.posture_gain, 0.0, 1.0)
        self.tol.checked()

    def step(
        self, robot: RobotModel, q: FloatArray, lam: float, target: FloatArray, error: FloatArray
    ) -> tuple[FloatArray, float]:
        """Solve J_c d = K e (square) or the minimum-norm step plus the null-space posture
        (`curved_step.step`)."""
        K = np.asarray(self.K, dtype=np.float64)
        d = kernel_step(robot, self.code, K, 0.0, self.posture_gain, q, lam, error)
        return d[:-1], float(d[-1])


@dataclass(frozen=True)
class CurvedDlsSolver(CurvedSolver):
    """Damped least squares (eqs. 2.19, 2.20) on X_c, the roll row scaled by the shaft length
    l_s so that every row is in [m] (one damping for all).

    Attributes:
        damping: D > 0 in [m]. tol: Loop tolerance.
    """

    damping: float = 1e-4
    tol: Tolerance = field(default_factory=Tolerance)
    name: ClassVar[str] = "dls"
    code: ClassVar[int] = CURVED_DLS

    def __post_init__(self) -> None:
        check_damping(self.damping)
        self.tol.checked()

    def step(
        self, robot: RobotModel, q: FloatArray, lam: float, target: FloatArray, error: FloatArray
    ) -> tuple[FloatArray, float]:
        """One DLS step with the roll row and error times l_s (`curved_step.step`)."""
        d = kernel_step(robot, self.code, np.ones(TARGET_WIDTH), self.damping, 0.0, q, lam, error)
        return d[:-1], float(d[-1])


@dataclass(frozen=True)
class CurvedPoseSolver(CurvedPinvSolver):
    """Whole needle poses (p_tip, rho, p_base) outside the RCM: Gauss-Newton (minimum norm;
    lambda has no effect and stays)."""

    tasks: ClassVar[tuple[Task, ...]] = CURVED_POSE_TASKS
    name: ClassVar[str] = "pose-pinv"
    kind: ClassVar[SolverKind] = "free"
    code: ClassVar[int] = CURVED_POSE

    def step(
        self, robot: RobotModel, q: FloatArray, lam: float, target: FloatArray, error: FloatArray
    ) -> tuple[FloatArray, float]:
        """The least-squares step on the (7, m) pose Jacobian (`curved_step.step`; with more
        than six active joints, where that Jacobian is rank-deficient both ways, the
        minimum-norm one)."""
        K = np.asarray(self.K, dtype=np.float64)
        return kernel_step(robot, self.code, K, 0.0, 0.0, q, lam, error)[:-1], 0.0


@dataclass(frozen=True)
class LimitedPoseSolver(CurvedPoseSolver):
    """`CurvedPoseSolver`'s step shortened so that each actuator moves at most speed x dt and
    stays within its travel less `travel_margin` (`limited_tip.limited_step`): the QP's
    free-space phases on a curved needle, which hold the QP's actuator limits as its RCM
    phases do.

    Attributes:
        dt: Control period in [s]. travel_margin: Distance kept from each travel end.
    """

    dt: float = 1e-3
    travel_margin: float = 0.5e-3
    name: ClassVar[str] = "pose-limited"

    def __post_init__(self) -> None:
        super().__post_init__()
        scalar("dt", self.dt, 0.0, 1.0, low_open=True)
        scalar("travel_margin", self.travel_margin, 0.0, 0.1)

    def step(
        self, robot: RobotModel, q: FloatArray, lam: float, target: FloatArray, error: FloatArray
    ) -> tuple[FloatArray, float]:
        """The pose step, shortened to the actuators' speed and travel."""
        dq, _ = super().step(robot, q, lam, target, error)
        return limited_step(robot, q, dq, self.dt, self.travel_margin), 0.0
