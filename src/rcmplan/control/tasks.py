"""Tasks: a value and its exact Jacobian over theta_ext = (q[active], lambda) (eq. 3.11).

A task reads the robot model at (q, lambda). The thesis's extended task X_ext = (x_tip, phi, psi,
p_rcm) (eq. 3.14) is the stacking `X_EXT` of three tasks, and its Jacobian is J_a (eq. 3.15);
damped least squares stacks the tip and the RCM point (`TIP_AND_RCM`). Needle angles are
defined in `rcmplan.robot.needle`; on iRAM!S their exact rows are e_q1 and e_q3.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar, Literal, Protocol

import numpy as np

from rcmplan._validate import F64, FloatArray, text, vector
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.model import RobotModel
from rcmplan.robot.needle import angles_from_axis

JacobianVariant = Literal["exact", "thesis"]
VARIANTS: tuple[str, ...] = ("exact", "thesis")


class Task(Protocol):
    """A task: its values at (q, lambda) and their Jacobian (values, m + 1)."""

    def value(self, robot: RobotModel, q: FloatArray, lam: float) -> FloatArray: ...
    def jacobian(self, robot: RobotModel, q: FloatArray, lam: float) -> FloatArray: ...


@dataclass(frozen=True)
class TipPosition:
    """Rows `axes` (distinct indices among 0, 1, 2) of the needle tip position in [m]
    (eq. 2.7); lambda moves no tip."""

    axes: tuple[int, ...] = (0, 1, 2)

    def __post_init__(self) -> None:
        axes = self.axes
        ok = (
            isinstance(axes, tuple | list)
            and 0 < len(axes) == len(set(axes))
            and all(type(a) is int and 0 <= a <= 2 for a in axes)
        )
        if not ok:
            raise InvalidInputError("axes", axes, "distinct axis indices among 0, 1, 2")
        object.__setattr__(self, "axes", tuple(axes))

    @property
    def size(self) -> int:
        """Number of rows."""
        return len(self.axes)

    def value(self, robot: RobotModel, q: FloatArray, lam: float) -> FloatArray:
        """The tip coordinates."""
        return robot.tip(q)[list(self.axes)]

    def jacobian(self, robot: RobotModel, q: FloatArray, lam: float) -> FloatArray:
        """Rows of d p_tip / d theta_ext with a zero lambda column."""
        return robot.tip_jacobian(q)[list(self.axes)]


@dataclass(frozen=True)
class NeedleAngles:
    """The needle angles (phi, psi) in [rad].

    Attributes:
        variant: "exact" rows (the derivative of phi, psi), or "thesis": the geometric angular
            velocities (omega_y, omega_z) of eq. 6.1, a cos-scaled approximation (NOTES.md).
    """

    variant: JacobianVariant = "exact"
    size: ClassVar[int] = 2

    def __post_init__(self) -> None:
        text("variant", self.variant, VARIANTS)

    def value(self, robot: RobotModel, q: FloatArray, lam: float) -> FloatArray:
        """(phi, psi)."""
        return np.array(angles_from_axis(robot.needle_axis(q)))

    def jacobian(self, robot: RobotModel, q: FloatArray, lam: float) -> FloatArray:
        """(2, m + 1) rows."""
        if self.variant == "exact":
            return robot.needle_angles_jacobian(q)
        return robot.needle_angular_jacobian(q)[1:3]


@dataclass(frozen=True)
class RcmPoint:
    """The RCM point p(lambda) on the needle in [m] (eqs. 3.7-3.10)."""

    size: ClassVar[int] = 3

    def value(self, robot: RobotModel, q: FloatArray, lam: float) -> FloatArray:
        """p(lambda)."""
        return robot.needle_point(q, lam)

    def jacobian(self, robot: RobotModel, q: FloatArray, lam: float) -> FloatArray:
        """J_c = d p(lambda) / d theta_ext (eq. 3.10)."""
        return robot.needle_point_jacobian(q, lam)


@dataclass(frozen=True)
class NeedleBase:
    """The needle base p(0) in [m], held fixed in lambda (a pivot about the tip)."""

    size: ClassVar[int] = 3

    def value(self, robot: RobotModel, q: FloatArray, lam: float) -> FloatArray:
        """p(0)."""
        return robot.needle_point(q, 0.0)

    def jacobian(self, robot: RobotModel, q: FloatArray, lam: float) -> FloatArray:
        """d p(0) / d theta_ext with a zero lambda column."""
        J = robot.needle_point_jacobian(q, 0.0)
        J[:, -1] = 0.0
        return J


@dataclass(frozen=True)
class Posture:
    """The active joints themselves: a redundant arm's preferred posture (null space)."""

    def value(self, robot: RobotModel, q: FloatArray, lam: float) -> FloatArray:
        """q[active]."""
        n = len(robot.home)
        if q.__class__ is not np.ndarray or q.dtype is not F64 or q.shape != (n,):
            q = vector("q", q, n)
        value: FloatArray = q[list(robot.active)]
        if not math.isfinite(sum(value.tolist())):
            vector("q", q, n)  # names the non-finite entry
        return value

    def jacobian(self, robot: RobotModel, q: FloatArray, lam: float) -> FloatArray:
        """[I 0], (m, m + 1)."""
        m = len(robot.active)
        return np.eye(m, m + 1)


def stack_value(
    tasks: tuple[Task, ...], robot: RobotModel, q: FloatArray, lam: float
) -> FloatArray:
    """The tasks' values one after another."""
    return np.concatenate([t.value(robot, q, lam) for t in tasks])


def stack_jacobian(
    tasks: tuple[Task, ...], robot: RobotModel, q: FloatArray, lam: float
) -> FloatArray:
    """The tasks' Jacobians one above another."""
    return np.vstack([t.jacobian(robot, q, lam) for t in tasks])


X_EXT: dict[str, tuple[Task, ...]] = {
    "exact": (TipPosition((0,)), NeedleAngles("exact"), RcmPoint()),
    "thesis": (TipPosition((0,)), NeedleAngles("thesis"), RcmPoint()),
}  # made once: the loop asks for them at every iteration


def x_ext_tasks(variant: JacobianVariant = "exact") -> tuple[Task, ...]:
    """X_ext = (x_tip, phi, psi, p_rcm) as tasks (eq. 3.14)."""
    tasks = X_EXT.get(variant) if isinstance(variant, str) else None
    if tasks is None:
        raise InvalidInputError("variant", variant, f"one of {VARIANTS}")
    return tasks


TIP_POSITION = TipPosition()
TIP_AND_RCM: tuple[Task, ...] = (TIP_POSITION, RcmPoint())
TIP_AND_BASE: tuple[Task, ...] = (TIP_POSITION, NeedleBase())
