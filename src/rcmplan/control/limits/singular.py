"""The singular margin: the robot's singular terms kept above a floor (iRAM!S: cos q1, cos q3)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rcmplan._validate import scalar
from rcmplan.control.limits.base import Constraint, Kinematics, StepInput
from rcmplan.control.limits.rows import damper_rows
from rcmplan.robot.model import RobotModel


@dataclass(frozen=True)
class SingularMargin:
    """One damper row per singular term of the robot (`RobotModel.singular_terms`), each kept
    above a floor, approached at `gain` (iRAM!S: cos q1 and cos q3, with |q1|, |q3| < pi/2 on
    the PCJMs; `rows.damper_rows`).

    Attributes:
        floor: Smallest value of the terms kept, in (0, 1); None: 1.5 times the robot's
            singular threshold (iRAM!S: 0.15).
        gain: Damper gain in (0, 1].
    """

    floor: float | None = None
    gain: float = 0.5

    def __post_init__(self) -> None:
        if self.floor is not None:
            floor = scalar("floor", self.floor, 0.0, 1.0, low_open=True, high_open=True)
            object.__setattr__(self, "floor", floor)
        object.__setattr__(self, "gain", scalar("gain", self.gain, 0.0, 1.0, low_open=True))

    def floor_for(self, robot: RobotModel) -> float:
        """The floor kept on `robot`."""
        return 1.5 * robot.singular_threshold if self.floor is None else self.floor

    def constraint(self, robot: RobotModel, inp: StepInput, kin: Kinematics) -> Constraint:
        """The rows."""
        floor = self.floor_for(robot)
        values, grads = robot.singular_terms(inp.q)
        active = list(robot.active)
        grads_x = np.ascontiguousarray(grads[:, active] @ kin.T[: len(active)])
        values = np.ascontiguousarray(values, dtype=np.float64)
        k = values.shape[0]
        G, h = np.empty((k, kin.T.shape[1])), np.empty(k)
        damper_rows(grads_x, values, floor, self.gain, G, h, 0)
        return Constraint.rows(G, h)
