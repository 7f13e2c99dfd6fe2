"""What every limit reads: the step's input, the state's shared kinematics, and the row types.

QP variables x = (ds[active], l dlambda) / SCALE: actuator increments of the active joints and
the RCM's move along the needle, in micrometres or microradians (qp_problem.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple, Protocol

import numpy as np

from rcmplan._validate import FloatArray, array, flag
from rcmplan.control.limits.rows import RECOVERY, SCALE, damper_bound
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.model import RobotModel

# An actuator step within this fraction of speed x dt is at its speed bound (DAQP returns bound
# values exactly; the fraction covers rounding).
SPEED_ACTIVE = 1e-9

__all__ = ["RECOVERY", "SCALE", "SPEED_ACTIVE", "Constraint", "Kinematics", "Limit", "StepInput",
           "damper_row", "kinematics", "no_rows", "variable_map"]  # fmt: skip


@dataclass(frozen=True)
class StepInput:
    """State and settings of one step: joints q (n,), lambda, the task's target and error
    (6,) (X_ext; a curved needle's X_c: 7), gains K, damping D, control period dt in [s] and
    the task rows' weights (`qp_problem.cost_weights`). Each limit holds its own parameters."""

    q: FloatArray
    lam: float
    target: FloatArray
    error: FloatArray
    K: FloatArray
    damping: float
    dt: float
    weights: FloatArray


class Kinematics(NamedTuple):
    """Quantities of one state shared by the QP rows, computed once.

    Attributes:
        s: Actuators (n,). T: d(q[active], lambda)/d(s[active], l lambda) (m + 1, m + 1).
        J_tip, J_rcm: d p / d(q[active], lambda) (3, m + 1) of the tip and of p(lambda).
        tip, rcm: Tip and RCM point (3,) in [m]. axis: Unit needle axis (3,).
        JT_tip, JT_rcm: J_tip T and J_rcm T (3, m + 1): the points' motion per unit of
            x SCALE, what the row kernels read.
    """

    s: FloatArray
    T: FloatArray
    J_tip: FloatArray
    J_rcm: FloatArray
    tip: FloatArray
    rcm: FloatArray
    axis: FloatArray
    JT_tip: FloatArray
    JT_rcm: FloatArray


class _ConstraintFields(NamedTuple):
    G: FloatArray
    h: FloatArray
    equality: bool = False


class Constraint(_ConstraintFields):
    """Rows G x <= h (or G x = h when `equality`), x in QP units: G (k, m) and h (k,) finite,
    equality True or False (InvalidInputError otherwise)."""

    __slots__ = ()

    def __new__(cls, G: FloatArray, h: FloatArray, equality: bool = False) -> Constraint:
        G, h = array("G", G, 2), array("h", h, 1)
        if G.shape[0] != h.shape[0]:
            raise InvalidInputError("h", h, f"one bound per row of G ({G.shape[0]})")
        return super().__new__(cls, G, h, flag("equality", equality))

    @classmethod
    def rows(cls, G: FloatArray, h: FloatArray, equality: bool = False) -> Constraint:
        """The rows a limit builds at each step from the state's kinematics (finite arrays of
        matching shapes), made without the checks (the QP step builds several per period)."""
        return cls._make((G, h, equality))


class Limit(Protocol):
    """A limit on one control step."""

    def constraint(self, robot: RobotModel, inp: StepInput, kin: Kinematics) -> Constraint:
        """Its rows at this state."""
        ...


def variable_map(robot: RobotModel, q: FloatArray) -> FloatArray:
    """T = d(q[active], lambda) / d(s[active], l lambda), (m + 1, m + 1): the actuator map's
    dq/ds on the active joints (iRAM!S: eqs. 2.1, 2.2) and 1 / l for lambda."""
    active = list(robot.active)
    m = len(active)
    T = np.zeros((m + 1, m + 1))
    T[:m, :m] = robot.joint_rates(q)[np.ix_(active, active)]
    T[m, m] = 1.0 / robot.needle_length
    return T


def kinematics(robot: RobotModel, q: FloatArray, lam: float) -> Kinematics:
    """The shared quantities at (q, lambda)."""
    T = variable_map(robot, q)
    J_tip, J_rcm = robot.tip_jacobian(q), robot.needle_point_jacobian(q, lam)
    return Kinematics(
        robot.actuators_from_joints(q),
        T,
        J_tip,
        J_rcm,
        robot.tip(q),
        robot.needle_point(q, lam),
        robot.needle_axis(q),
        J_tip @ T,
        J_rcm @ T,
    )


def no_rows(kin: Kinematics) -> Constraint:
    """A limit that holds nothing at this state."""
    return Constraint.rows(np.zeros((0, kin.T.shape[1])), np.zeros(0))


def damper_row(
    grad: FloatArray, value: float, floor: float, gain: float, recovery: float = RECOVERY
) -> tuple[FloatArray, float]:
    """One velocity-damper row G x <= h for value + grad x SCALE >= floor, approached at `gain`
    (`rows.damper_bound`)."""
    return -grad, damper_bound(value, floor, gain, recovery)
