"""Actuator travel and speed over one control period, and lambda in [0, 1], as bounds on x."""

from __future__ import annotations

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.control.limits.base import SCALE, Kinematics, StepInput
from rcmplan.robot.model import RobotModel


class ActuatorLimit:
    """lb <= x <= ub: each active actuator within travel less `travel_margin` and moving at most
    speed x dt; the RCM within the needle. An actuator already past its soft travel may stay or
    move back, never further out."""

    def bounds(
        self, robot: RobotModel, inp: StepInput, kin: Kinematics
    ) -> tuple[FloatArray, FloatArray]:
        """(lb, ub) in QP units."""
        active = list(robot.active)
        s, margin = kin.s, inp.limits.travel_margin
        lo = robot.lower[active] + margin - s[active]
        hi = robot.upper[active] - margin - s[active]
        step = robot.speed[active] * inp.dt
        length = robot.needle_length
        lb = np.append(np.minimum(np.maximum(lo, -step), 0.0), -inp.lam * length)
        ub = np.append(np.maximum(np.minimum(hi, step), 0.0), (1.0 - inp.lam) * length)
        return lb / SCALE, ub / SCALE
