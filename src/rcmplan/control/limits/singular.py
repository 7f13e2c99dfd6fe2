"""The singular margin: the robot's singular terms kept above a floor (iRAM!S: cos q1, cos q3)."""

from __future__ import annotations

import numpy as np

from rcmplan.control.limits.base import Constraint, Kinematics, StepInput
from rcmplan.control.limits.rows import damper_rows
from rcmplan.robot.model import RobotModel


class SingularMargin:
    """One damper row per singular term of the robot (`RobotModel.singular_terms`), each kept
    above `QpLimits.singular_floor`, approached at `singular_gain` (iRAM!S: cos q1 and cos q3,
    with |q1|, |q3| < pi/2 on the PCJMs; `rows.damper_rows`)."""

    def constraint(self, robot: RobotModel, inp: StepInput, kin: Kinematics) -> Constraint:
        """The rows."""
        floor = inp.limits.singular_floor(robot)
        values, grads = robot.singular_terms(inp.q)
        active = list(robot.active)
        grads_x = np.ascontiguousarray(grads[:, active] @ kin.T[: len(active)])
        values = np.ascontiguousarray(values, dtype=np.float64)
        k = values.shape[0]
        G, h = np.empty((k, kin.T.shape[1])), np.empty(k)
        damper_rows(grads_x, values, floor, inp.limits.singular_gain, G, h, 0)
        return Constraint.rows(G, h)
