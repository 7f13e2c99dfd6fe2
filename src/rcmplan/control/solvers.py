"""Step solvers: from the current state and a target to an increment (delta q, delta lambda).

Each solver states its own task error (what the loop drives to zero), its tolerance per error
component, and one step. RCM solvers take an X_ext target (6,); free-space solvers a tip point
(3,). Joint increments cover q0..q4; the needle roll q5 is not moved.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar, Literal, NamedTuple, Protocol

import numpy as np

from rcmplan._validate import FloatArray, scalar, vector
from rcmplan.control.augmented import VARIANTS, JacobianVariant, augmented_jacobian, extended_task
from rcmplan.control.targets import tip_of_target
from rcmplan.control.tasks import axis_from_angles, rcm_jacobian, rcm_point, tip_position_jacobian
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.iramis import Iramis

SolverKind = Literal["rcm", "free"]


class Tolerance(NamedTuple):
    """Loop tolerances, kept apart by unit: position in [m], angle in [rad]."""

    position: float = 1e-8
    angle: float = 1e-7

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

    def error(self, robot: Iramis, q: FloatArray, lam: float, target: FloatArray) -> FloatArray:
        """The task error the loop drives to zero."""
        ...

    def tolerance(self) -> FloatArray:
        """Tolerance per error component (same shape as the error)."""
        ...

    def step(
        self, robot: Iramis, q: FloatArray, lam: float, target: FloatArray, error: FloatArray
    ) -> tuple[FloatArray, float]:
        """(delta q0..q4 (5,), delta lambda)."""
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


def check_damping(D: float) -> float:
    """Return the damping constant if positive and finite, else raise."""
    return scalar("damping", D, 0.0, np.inf, low_open=True, high_open=True)


@dataclass(frozen=True)
class PinvSolver:
    """Augmented-Jacobian step d theta_ext = J_a^+ K e (eq. 3.17); J_a is square: J_a^+ = J_a^-1.

    Attributes:
        K: Diagonal gains (6,), each in (0, 2).
        variant: "exact" angle rows or the "thesis" rows of eq. 6.1.
        tol: Loop tolerance.
    """

    K: tuple[float, ...] = (1.0,) * 6
    variant: JacobianVariant = "exact"
    tol: Tolerance = field(default_factory=Tolerance)
    name: ClassVar[str] = "pinv"
    kind: ClassVar[SolverKind] = "rcm"

    def __post_init__(self) -> None:
        object.__setattr__(self, "K", tuple(check_gains(self.K)))
        if self.variant not in VARIANTS:
            raise InvalidInputError("variant", self.variant, f"one of {VARIANTS}")
        self.tol.checked()

    def error(self, robot: Iramis, q: FloatArray, lam: float, target: FloatArray) -> FloatArray:
        """X_ext target minus X_ext now: (x [m], phi, psi [rad], p_rcm [m])."""
        return target - extended_task(robot, q, lam)

    def tolerance(self) -> FloatArray:
        """(position, angle, angle, position x3)."""
        return self.tol.x_ext()

    def step(
        self, robot: Iramis, q: FloatArray, lam: float, target: FloatArray, error: FloatArray
    ) -> tuple[FloatArray, float]:
        """Solve J_a d = K e."""
        J = augmented_jacobian(robot, q, lam, self.variant)
        d = np.asarray(np.linalg.solve(J, np.asarray(self.K) * error), dtype=np.float64)
        return d[:5], float(d[5])


def dls_solve(J: FloatArray, e: FloatArray, D: float) -> FloatArray:
    """J^T f with (J J^T + D^2 I) f = e (eqs. 2.19, 2.20), without forming an inverse."""
    A = J @ J.T
    A[np.diag_indices_from(A)] += D * D
    d: FloatArray = J.T @ np.linalg.solve(A, e)
    return d


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
        check_damping(self.damping)
        self.tol.checked()

    def error(self, robot: Iramis, q: FloatArray, lam: float, target: FloatArray) -> FloatArray:
        """(tip target - tip, trocar - p_rcm), both in [m] (base task for a pivot)."""
        e = np.empty(6)
        tip = tip_of_target(target)
        e[:3] = tip - robot.needle_point(q, 1.0)
        if _is_pivot(tip, target):
            base = tip - robot.params.l6 * axis_from_angles(target[1], target[2])
            e[3:] = base - robot.needle_point(q, 0.0)
        else:
            e[3:] = target[3:] - rcm_point(robot, q, lam)
        return e

    def tolerance(self) -> FloatArray:
        """Position tolerance on all six components."""
        return np.full(6, self.tol.position)

    def step(
        self, robot: Iramis, q: FloatArray, lam: float, target: FloatArray, error: FloatArray
    ) -> tuple[FloatArray, float]:
        """One DLS step on the stacked (tip, RCM) task."""
        pivot = _is_pivot(tip_of_target(target), target)
        J = np.vstack(
            [tip_position_jacobian(robot, q), rcm_jacobian(robot, q, 0.0 if pivot else lam)]
        )
        if pivot:
            J[3:, 5] = 0.0
        d = dls_solve(J, error, self.damping)
        return d[:5], float(d[5])


def _is_pivot(tip: FloatArray, target: FloatArray) -> bool:
    """True when the target's tip lies on its trocar point (within 1 nm)."""
    return bool(np.linalg.norm(tip - target[3:]) < 1e-9)


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
        scalar("damping", self.damping, 0.0, np.inf, high_open=True)
        self.tol.checked()

    @property
    def name(self) -> str:
        """ "tip-pinv" or "tip-dls"."""
        return "tip-dls" if self.damping > 0 else "tip-pinv"

    def error(self, robot: Iramis, q: FloatArray, lam: float, target: FloatArray) -> FloatArray:
        """Tip target minus tip, in [m]."""
        return target[:3] - robot.needle_point(q, 1.0)

    def tolerance(self) -> FloatArray:
        """Position tolerance on x, y, z."""
        return np.full(3, self.tol.position)

    def step(
        self, robot: Iramis, q: FloatArray, lam: float, target: FloatArray, error: FloatArray
    ) -> tuple[FloatArray, float]:
        """Minimum-norm (or damped) step on the 3x5 tip Jacobian; lambda unchanged."""
        J = tip_position_jacobian(robot, q)[:, :5]
        return dls_solve(J, error, self.damping), 0.0
