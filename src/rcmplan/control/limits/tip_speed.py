"""The tip's speed: each base-frame component of the tip's step within tip_speed x dt."""

from __future__ import annotations

import numpy as np

from rcmplan.control.limits.base import SCALE, Constraint, Kinematics, StepInput, no_rows
from rcmplan.robot.model import RobotModel


class TipSpeed:
    """-v dt <= J_tip T x SCALE <= v dt per axis (six rows, to first order), v =
    `QpLimits.tip_speed`; none when it is None."""

    def constraint(self, robot: RobotModel, inp: StepInput, kin: Kinematics) -> Constraint:
        """The rows, or none."""
        v = inp.limits.tip_speed
        if v is None:
            return no_rows(kin)
        J = kin.J_tip @ kin.T
        h = np.full(6, v * inp.dt / SCALE)
        return Constraint.rows(np.vstack([J, -J]), h)
