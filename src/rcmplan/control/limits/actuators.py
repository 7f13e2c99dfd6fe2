"""Actuator travel and speed over one control period, and lambda in [0, 1], as bounds on x."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rcmplan._jit import njit
from rcmplan._validate import FloatArray, scalar
from rcmplan.control.limits.base import Kinematics, StepInput
from rcmplan.control.limits.rows import SCALE
from rcmplan.robot.model import RobotModel


@njit(cache=True, borrows=True)
def actuator_bounds(s: FloatArray, lower: FloatArray, upper: FloatArray, speed: FloatArray,
                    margin: float, dt: float, lam: float, length: float, lb: FloatArray,
                    ub: FloatArray) -> None:  # fmt: skip
    """lb <= x <= ub in QP units for m active actuators at s (m,) with travel [lower, upper]
    (m,) less `margin` and speeds (m,) over dt, then the RCM's move along the needle within
    lambda in [0, 1] (lb, ub: (m + 1,)). An actuator past its soft travel may stay or move
    back, never further out."""
    m = s.shape[0]
    for i in range(m):
        lo = lower[i] + margin - s[i]
        hi = upper[i] - margin - s[i]
        step = speed[i] * dt
        lb[i] = min(max(lo, -step), 0.0) / SCALE
        ub[i] = max(min(hi, step), 0.0) / SCALE
    lb[m] = -lam * length / SCALE
    ub[m] = (1.0 - lam) * length / SCALE


@dataclass(frozen=True)
class ActuatorLimit:
    """lb <= x <= ub: each active actuator within travel less `margin` [m] (or [rad]) and moving
    at most speed x dt; the RCM within the needle (`actuator_bounds`)."""

    margin: float = 0.5e-3

    def __post_init__(self) -> None:
        object.__setattr__(self, "margin", scalar("margin", self.margin, 0.0, 0.1))

    def bounds(
        self, robot: RobotModel, inp: StepInput, kin: Kinematics
    ) -> tuple[FloatArray, FloatArray]:
        """(lb, ub) in QP units."""
        active = list(robot.active)
        m = len(active)
        lb, ub = np.empty(m + 1), np.empty(m + 1)
        actuator_bounds(kin.s[active], robot.lower[active], robot.upper[active],
                        robot.speed[active], self.margin, inp.dt, inp.lam,
                        robot.needle_length, lb, ub)  # fmt: skip
        return lb, ub
