"""Step solvers: from the current state and a target to an increment (delta q, delta lambda).

Each solver states its own task error (what the loop drives to zero), its tolerance per error
component, and one step. RCM solvers take an X_ext target (6,); free-space solvers a tip point
(3,). Joint increments cover the robot's active joints (iRAM!S: q0..q4; the needle roll is not
moved). On a redundant robot (more than five active joints) the pseudoinverse step is the
minimum-norm solution plus a posture term in the null space of J_a.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, ClassVar, Literal, NamedTuple, Protocol

import numpy as np

from rcmplan import linalg
from rcmplan._validate import FloatArray, instance, scalar, text, vector
from rcmplan.control.augmented import augmented_jacobian, extended_task
from rcmplan.control.dls_task import dls_error, is_pivot
from rcmplan.control.targets import checked_target, finite_step, tip_of_target
from rcmplan.control.tasks import (
    TIP_AND_BASE,
    TIP_AND_RCM,
    TIP_POSITION,
    VARIANTS,
    JacobianVariant,
    Posture,
    stack_jacobian,
)
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.model import RobotModel
from rcmplan.robot.needle import axis_from_angles

SolverKind = Literal["rcm", "free"]


class _ToleranceFields(NamedTuple):
    position: float = 1e-8
    angle: float = 1e-7


class Tolerance(_ToleranceFields):
    """Loop tolerances, kept apart by unit: position in [m], angle in [rad], each positive and
    finite (InvalidInputError otherwise)."""

    __slots__ = ()

    def __new__(cls, position: float = 1e-8, angle: float = 1e-7) -> Tolerance:
        inf = math.inf
        p = scalar("tolerance.position", position, 0.0, inf, low_open=True, high_open=True)
        a = scalar("tolerance.angle", angle, 0.0, inf, low_open=True, high_open=True)
        return super().__new__(cls, p, a)

    def x_ext(self) -> FloatArray:
        """Per-component tolerance of an X_ext error: (position, angle, angle, position x3)."""
        p, a = self
        return np.array([p, a, a, p, p, p])

    def checked(self) -> Tolerance:
        """Return self if both tolerances are positive and finite, else raise."""
        scalar("tolerance.position", self.position, 0.0, np.inf, low_open=True, high_open=True)
        scalar("tolerance.angle", self.angle, 0.0, np.inf, low_open=True, high_open=True)
        return self


class Solver(Protocol):
    """One step of a differential IK method."""

    @property
    def name(self) -> str:
        """Short method name for logs."""
        ...

    @property
    def kind(self) -> SolverKind:
        """ "rcm" (X_ext targets) or "free" (tip points)."""
        ...

    def error(self, robot: RobotModel, q: FloatArray, lam: float, target: FloatArray) -> FloatArray:
        """The task error the loop drives to zero."""
        ...

    def tolerance(self) -> FloatArray:
        """Tolerance per error component (same shape as the error)."""
        ...

    def step(
        self, robot: RobotModel, q: FloatArray, lam: float, target: FloatArray, error: FloatArray
    ) -> tuple[FloatArray, float]:
        """(delta q[active] (m,), delta lambda)."""
        ...


def check_gains(K: object) -> FloatArray:
    """Return K as a (6,) array with every entry in (0, 2), else raise.

    In a full Newton step d theta = J_a^-1 K e each task error is multiplied by (1 - K_ii) per
    iteration (to first order): K_ii in (0, 2) converges, K_ii <= 0 or >= 2 does not.
    """
    k = vector("K", K, 6)
    if np.any(k <= 0.0) or np.any(k >= 2.0):
        raise InvalidInputError(
            "K",
            K,
            "six gains in (0, 2): each error is scaled by (1 - K_ii) per Newton iteration, so "
            "K_ii <= 0 never converges and K_ii >= 2 diverges",
        )
    return k


# DLS regularises a rank-deficient task only through D^2: in a pivot about the tip (lambda = 1)
# lambda moves neither the tip nor the base, so J J^T (entries about 1: the prismatic joints)
# is singular and J J^T + D^2 I must stay resolvable in floating point. D >= 1e-6 keeps D^2
# four orders above the 1e-16 resolution; with D = 1e-12 the reference solve raised LinAlgError
# and the compiled one took an 807 um step.
MIN_DAMPING = 1e-6


def check_damping(D: float) -> float:
    """Return the damping constant in [m] if finite and at least MIN_DAMPING, else raise."""
    return scalar("damping", D, MIN_DAMPING, np.inf, high_open=True)


@dataclass(frozen=True)
class PinvSolver:
    """Augmented-Jacobian step d theta_ext = J_a^+ K e (eq. 3.17); J_a is square: J_a^+ = J_a^-1.

    On a redundant robot, d theta_ext = J_a^+ K e + (I - J_a^+ J_a) k_p (home - theta_ext) over
    the active joints (lambda has no preferred value).

    Attributes:
        K: Diagonal gains (6,), each in (0, 2).
        variant: "exact" angle rows or the "thesis" rows of eq. 6.1.
        tol: Loop tolerance.
        posture_gain: k_p in [0, 1]: the fraction of the way to the home posture taken per
            step in the null space (redundant robots only).
    """

    K: tuple[float, ...] = (1.0,) * 6
    variant: JacobianVariant = "exact"
    tol: Tolerance = field(default_factory=Tolerance)
    posture_gain: float = 0.05
    name: ClassVar[str] = "pinv"
    kind: ClassVar[SolverKind] = "rcm"

    def __post_init__(self) -> None:
        object.__setattr__(self, "K", tuple(check_gains(self.K)))
        text("variant", self.variant, VARIANTS)
        gain = scalar("posture_gain", self.posture_gain, 0.0, 1.0)
        object.__setattr__(self, "posture_gain", gain)
        instance("tol", self.tol, Tolerance, "a Tolerance").checked()

    def error(self, robot: RobotModel, q: FloatArray, lam: float, target: FloatArray) -> FloatArray:
        """X_ext target minus X_ext now: (x [m], phi, psi [rad], p_rcm [m])."""
        return checked_target(target, 6) - extended_task(robot, q, lam)

    def tolerance(self) -> FloatArray:
        """(position, angle, angle, position x3)."""
        return self.tol.x_ext()

    def step(
        self, robot: RobotModel, q: FloatArray, lam: float, target: FloatArray, error: FloatArray
    ) -> tuple[FloatArray, float]:
        """Solve J_a d = K e (square), or the minimum-norm step plus the null-space posture (the
        target enters through the error, checked here)."""
        error = checked_target(error, 6, "error", finite=False)  # NaN shows in the step
        Ke = np.asarray(self.K) * error
        J = augmented_jacobian(robot, q, lam, self.variant)
        d = finite_step(pinv_solve(J, Ke, robot, q, lam, self.posture_gain), robot, q, error)
        return d[:-1], float(d[-1])


def pinv_solve(
    J: FloatArray, Ke: FloatArray, robot: RobotModel, q: FloatArray, lam: float, gain: float
) -> FloatArray:
    """d with J d = K e (`linalg.pinv`): solved when J is square; otherwise the minimum-norm
    solution plus (I - J^+ J) z, z = gain (home - q) on the active joints (lambda has no
    preferred value)."""
    z = np.zeros(J.shape[1])
    if J.shape[0] < J.shape[1]:
        z[:-1] = gain * (Posture().value(robot, robot.home, lam) - Posture().value(robot, q, lam))
    return linalg.step(J, Ke, z=z)


@dataclass(frozen=True)
class DlsSolver:
    """Damped least squares on the task pair of the thesis's V-REP IK group.

    Tip to the target point and the RCM point to the trocar, over (q0..q4, lambda). When the
    target puts the tip on the trocar (a pivot about the tip, lambda = 1) the two points coincide
    and fix no direction; the second task is then the needle base to its place on the target
    axis, l6 behind the tip.

    Attributes:
        damping: D > 0 (eq. 2.18), in units of the stacked task (m).
        tol: Loop tolerance (positions only).
    """

    damping: float = 1e-4
    tol: Tolerance = field(default_factory=Tolerance)
    name: ClassVar[str] = "dls"
    kind: ClassVar[SolverKind] = "rcm"

    def __post_init__(self) -> None:
        object.__setattr__(self, "damping", check_damping(self.damping))
        instance("tol", self.tol, Tolerance, "a Tolerance").checked()

    def error(self, robot: RobotModel, q: FloatArray, lam: float, target: FloatArray) -> FloatArray:
        """(tip target - tip, trocar - p_rcm), both in [m] (base task for a pivot)."""
        target = checked_target(target, 6)
        tip, e = tip_of_target(target), np.empty(6)
        pivot = is_pivot(tip, target)
        p = robot.needle_point(q, 0.0 if pivot else lam)
        a = axis_from_angles(target[1], target[2])
        dls_error(tip, a, pivot, robot.needle_length, target, robot.tip(q), p, e)
        return e

    def tolerance(self) -> FloatArray:
        """Position tolerance on all six components."""
        return np.full(6, self.tol.position)

    def step(
        self, robot: RobotModel, q: FloatArray, lam: float, target: FloatArray, error: FloatArray
    ) -> tuple[FloatArray, float]:
        """One DLS step on the stacked (tip, RCM) task."""
        target = checked_target(target, 6, finite=False)  # NaN: no pivot, error() refuses it
        error = checked_target(error, 6, "error", finite=False)  # NaN shows in the step
        pivot = is_pivot(tip_of_target(target), target)
        J = stack_jacobian(TIP_AND_BASE if pivot else TIP_AND_RCM, robot, q, lam)
        d = finite_step(linalg.step(J, error, self.damping), robot, q, error)
        return d[:-1], float(d[-1])


@dataclass(frozen=True)
class TipSolver:
    """Unconstrained tip IK for free-space motion outside the eye: pseudoinverse or DLS.

    Attributes:
        damping: 0 for the minimum-norm pseudoinverse step, D > 0 for damped least squares.
        tol: Loop tolerance (positions only).
    """

    damping: float = 0.0
    tol: Tolerance = field(default_factory=Tolerance)
    kind: ClassVar[SolverKind] = "free"

    def __post_init__(self) -> None:
        damping = scalar("damping", self.damping, 0.0, np.inf, high_open=True)
        object.__setattr__(self, "damping", damping)
        instance("tol", self.tol, Tolerance, "a Tolerance").checked()

    @property
    def name(self) -> str:
        """ "tip-pinv" or "tip-dls"."""
        return "tip-dls" if self.damping > 0 else "tip-pinv"

    def error(self, robot: RobotModel, q: FloatArray, lam: float, target: FloatArray) -> FloatArray:
        """Tip target minus tip, in [m] (a tip point (3,), or the first three entries of a
        longer target)."""
        return _tip_point(target) - robot.tip(q)

    def tolerance(self) -> FloatArray:
        """Position tolerance on x, y, z."""
        return np.full(3, self.tol.position)

    def step(
        self, robot: RobotModel, q: FloatArray, lam: float, target: FloatArray, error: FloatArray
    ) -> tuple[FloatArray, float]:
        """Minimum-norm (or damped) step on the (3, m) tip Jacobian; lambda unchanged."""
        error = checked_target(error, 3, "error", finite=False)  # the target enters through it
        J = TIP_POSITION.jacobian(robot, q, lam)[:, :-1]
        return finite_step(linalg.step(J, error, self.damping), robot, q, error), 0.0


def _tip_point(target: Any) -> FloatArray:
    """The tip point (3,) of a free-space target: a point, or the head of a longer target."""
    if target.__class__ is np.ndarray and target.ndim == 1 and target.shape[0] > 3:
        target = target[:3]
    return checked_target(target, 3)
