"""The quadratic programme of one QP control step, built as plain arrays tests can inspect.

Decision variables x = (ds[active], l dlambda) / SCALE: the increments of the actuators of the
active joints (iRAM!S: the sliders L1..L5, the roll q5 is not moved; an arm: its joints) and the
RCM's move along the needle, in micrometres or microradians (SCALE = 1e-6) so that every solver
sees numbers of order one. Actuator increments (not joint increments) make travel and speed
limits exact variable bounds; the joint step is recovered exactly through the actuator map
(iRAM!S: the PCJM maps, eqs. 2.1, 2.2).

    minimise   1/2 |W (J x SCALE - K e)|^2 / SCALE^2 + 1/2 D^2 |x|^2
    subject to lb <= x <= ub                      ActuatorLimit: travel, speed over dt,
                                                  lambda in [0, 1]
               A x = b  or  G_rcm x <= h_rcm      RcmLimit: linearised equality or a box
               G_eye x <= h_eye                   RetinaBarrier: velocity damper with a gain
               G_sing x <= h_sing                 SingularMargin: the robot's singular terms
                                                  above a margin (iRAM!S: cos q1, cos q3)
               G_tip x <= h_tip                   TipSpeed: the tip's step per axis (if set)

Each row block comes from a limit object holding its own parameters (`rcmplan.control.limits`;
`QpLimits.rows` builds the standard ones from a scenario's settings); a new limit is one file
with a `constraint(robot, inp, kin)` method, passed to `build_step` in the list of limits.

J = J_a(q, lambda) T is the augmented Jacobian (eq. 3.15, exact angle rows) times the map
T = d(q[active], lambda) / d(s[active], l lambda); e the X_ext error; W weights the task rows
(angles in metres through `angle_weight`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.control.configuration import Configuration
from rcmplan.control.cost import weighted_cost, x_ext_jacobian
from rcmplan.control.curved import CURVED_TASKS
from rcmplan.control.curved import task_jacobian as curved_task_jacobian
from rcmplan.control.limits import ActuatorLimit, Limit, RetinaBarrier, StepInput
from rcmplan.control.limits.base import SCALE, Kinematics, kinematics, variable_map
from rcmplan.control.targets import target_tip
from rcmplan.robot.model import RobotModel

__all__ = ["SCALE", "QPProblem", "StepInput", "StepQP", "build_step", "kinematics",
           "task_jacobian", "variable_map"]  # fmt: skip


class CostTerm(Protocol):
    """A term of the QP's cost: its (H, f) over x at a configuration (`objective.Objective`)."""

    def cost(self, cfg: Configuration) -> tuple[FloatArray, FloatArray]: ...


@dataclass(frozen=True)
class QPProblem:
    """min 1/2 x'Px + q'x s.t. Gx <= h, Ax = b, lb <= x <= ub (qpsolvers' convention)."""

    P: FloatArray
    q: FloatArray
    G: FloatArray
    h: FloatArray
    A: FloatArray
    b: FloatArray
    lb: FloatArray
    ub: FloatArray


@dataclass(frozen=True)
class StepQP:
    """A step's QP and what is needed to read its solution.

    Attributes:
        problem: The QP.
        task: d X_ext / d x (6, m + 1) in SI units per unit of x (times SCALE).
        sliders: The actuator positions s (n,) at which the QP was built.
        contact: True if the step's target is a retina contact (margin relaxed).
    """

    problem: QPProblem
    task: FloatArray
    sliders: FloatArray
    contact: bool


def task_jacobian(kin: Kinematics, J_angles: FloatArray) -> FloatArray:
    """d X_ext / d x = J_a T, J_a with the exact angle rows J_angles (2, m + 1) (eq. 3.15)."""
    task = np.empty((6, kin.T.shape[1]))
    x_ext_jacobian(kin.JT_tip, np.ascontiguousarray(J_angles @ kin.T), kin.JT_rcm, task)
    return task


def cost(task: FloatArray, inp: StepInput) -> tuple[FloatArray, FloatArray]:
    """P and q of the weighted task error plus damping (`weighted_cost`)."""
    n = task.shape[1]
    P, f = np.empty((n, n)), np.empty(n)
    weighted_cost(np.ascontiguousarray(task), inp.weights, inp.K, inp.error, inp.damping, P, f)
    return P, f


def build_step(
    robot: RobotModel,
    inp: StepInput,
    limits: tuple[Limit, ...],
    bounds: ActuatorLimit | None = None,
    objectives: Sequence[CostTerm] = (),
) -> StepQP:
    """The QP of one control step (see module docstring): its rows from `limits` in their
    order, its variable bounds from `bounds` (default `ActuatorLimit()`), its cost the X_ext
    (or X_c) task's plus each objective's term (`objective.Objective`)."""
    kin = kinematics(robot, inp.q, inp.lam)
    if inp.target.shape[0] == 7:  # a curved needle's X_c (`rcmplan.control.curved`)
        task = curved_task_jacobian(CURVED_TASKS, robot, inp.q, inp.lam) @ kin.T
    else:
        task = task_jacobian(kin, robot.needle_angles_jacobian(inp.q))
    P, qv = cost(task, inp)
    if objectives:
        cfg = Configuration.known(robot, inp.q, inp.lam, kin)
        for term in objectives:
            H, f = term.cost(cfg)
            P, qv = P + H, qv + f
    lb, ub = (bounds or ActuatorLimit()).bounds(robot, inp, kin)
    rows = [lim.constraint(robot, inp, kin) for lim in limits]
    ineq = [c for c in rows if not c.equality]
    eq = [c for c in rows if c.equality]
    width = task.shape[1]
    G = np.vstack([c.G for c in ineq]) if ineq else np.zeros((0, width))
    h = np.concatenate([c.h for c in ineq]) if ineq else np.zeros(0)
    A = np.vstack([c.G for c in eq]) if eq else np.zeros((0, width))
    b = np.concatenate([c.h for c in eq]) if eq else np.zeros(0)
    tip = target_tip(inp.target)
    contact = any(isinstance(lim, RetinaBarrier) and lim.is_contact(tip) for lim in limits)
    return StepQP(QPProblem(P, qv, G, h, A, b, lb, ub), task * SCALE, kin.s, contact)
