"""One period of a servo loop, for teleoperation and the subretinal episode: unlike Algorithm 1
(`rcmplan.controller`), which converges on each target, a servo takes ONE step per control
period towards a target that moves every period.

A period reads the plant (`read`: actuators, joints, the needle's ends, lambda of the needle
point closest to the trocar, the tip), then steps (`step`: the X_ext error, one solver step,
the compiled one where it applies, the command and the plant's advance). A caller plans its
target between the two.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

from rcmplan._validate import FloatArray
from rcmplan.control.augmented import extended_task
from rcmplan.control.plant import Plant
from rcmplan.control.qp import QpSolver
from rcmplan.exceptions import MissingExtraError
from rcmplan.robot.model import RobotModel
from rcmplan.robot.needle import closest_lambda

if TYPE_CHECKING:
    from rcmplan.compiled.qp_period import StepFunction


def fast_period_step(solver: QpSolver) -> StepFunction | None:
    """The QP's compiled single step where it applies (`rcmplan.compiled.qp_period`), else
    None; without DAQP's C binding, None. (Imported here: the compiled modules load numba.)"""
    from rcmplan.compiled.qp_period import period_step

    try:
        return period_step(solver)
    except MissingExtraError:
        return None


class Reading(NamedTuple):
    """The plant read at the start of a period: actuators s, joints q, the needle's base and
    end (p(0), p(1)), lambda of the needle point closest to the trocar, the tip (SI units)."""

    s: FloatArray
    q: FloatArray
    base: FloatArray
    end: FloatArray
    lam: float
    tip: FloatArray

    @property
    def rcm(self) -> FloatArray:
        """The RCM point p(lambda) [m]."""
        rcm: FloatArray = self.base + self.lam * (self.end - self.base)
        return rcm


def read(robot: RobotModel, plant: Plant, trocar: FloatArray) -> Reading:
    """Read the plant and the needle's place relative to the trocar."""
    s = plant.read_actuators()
    q = robot.joints_from_actuators(s)
    base, end = robot.needle_point(q, 0.0), robot.needle_point(q, 1.0)
    return Reading(s, q, base, end, closest_lambda(base, end, trocar), robot.tip(q))


def step(robot: RobotModel, plant: Plant, solver: QpSolver, fast_step: StepFunction | None,
         now: Reading, target: FloatArray) -> FloatArray:  # fmt: skip
    """One step from the reading towards the X_ext target (the compiled step where given, else
    `solver.step`), commanded, and the plant advanced one period; returns the X_ext error at
    the reading."""
    q, lam = now.q, now.lam
    e: FloatArray = target - extended_task(robot, q, lam)
    if fast_step is not None:
        dq = fast_step(q, lam, target)
    else:
        dq, _ = solver.step(robot, q, lam, target, e)
    q_new = q.copy()
    q_new[list(robot.active)] += dq
    plant.command_actuators(robot.actuators_from_joints(q_new))
    plant.advance()
    return e
