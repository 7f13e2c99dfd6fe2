"""The tip's speed: each base-frame component of the tip's step within tip_speed x dt."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rcmplan._jit import njit
from rcmplan._validate import FloatArray, scalar
from rcmplan.control.limits.base import Constraint, Kinematics, StepInput
from rcmplan.control.limits.rows import SCALE
from rcmplan.robot.model import RobotModel


@njit(cache=True, borrows=True)
def speed_rows(JT_tip: FloatArray, step: float, G: FloatArray, h: FloatArray, r: int) -> int:
    """Six rows from r: -step <= JT_tip x SCALE <= step per base axis (`step` [m], to first
    order). Returns r + 6."""
    for i in range(3):
        for j in range(JT_tip.shape[1]):
            G[r + i, j] = JT_tip[i, j]
            G[r + 3 + i, j] = -JT_tip[i, j]
        h[r + i] = h[r + 3 + i] = step / SCALE
    return r + 6


@dataclass(frozen=True)
class TipSpeed:
    """-v dt <= J_tip T x SCALE <= v dt per base axis (six rows, to first order; `speed_rows`).

    Attributes:
        speed: v, the tip's largest speed along each base axis in [m/s], in (0, 1].
    """

    speed: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "speed", scalar("speed", self.speed, 0.0, 1.0, low_open=True))

    def constraint(self, robot: RobotModel, inp: StepInput, kin: Kinematics) -> Constraint:
        """The rows."""
        G, h = np.empty((6, kin.T.shape[1])), np.empty(6)
        speed_rows(kin.JT_tip, self.speed * inp.dt, G, h, 0)
        return Constraint.rows(G, h)
