"""The singular margin: the robot's singular terms kept above a floor (iRAM!S: cos q1, cos q3)."""

from __future__ import annotations

import numpy as np

from rcmplan.control.limits.base import Constraint, Kinematics, StepInput, damper_row
from rcmplan.robot.model import RobotModel


class SingularMargin:
    """One damper row per singular term of the robot (`RobotModel.singular_terms`), each kept
    above `QpLimits.singular_floor`, approached at `singular_gain` (iRAM!S: cos q1 and cos q3,
    with |q1|, |q3| < pi/2 on the PCJMs)."""

    def constraint(self, robot: RobotModel, inp: StepInput, kin: Kinematics) -> Constraint:
        """The rows."""
        floor = inp.limits.singular_floor(robot)
        values, grads = robot.singular_terms(inp.q)
        active = list(robot.active)
        rows, hs = [], []
        for value, grad in zip(values, grads[:, active] @ kin.T[: len(active)], strict=True):
            g, h = damper_row(grad, float(value), floor, inp.limits.singular_gain)
            rows.append(g)
            hs.append(h)
        return Constraint.rows(np.array(rows), np.array(hs))
