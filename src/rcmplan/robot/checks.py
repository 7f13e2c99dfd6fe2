"""Checks that an argument is a robot model (`RobotModel`), at the cost of a set lookup once a
class has passed (the protocol check reads some thirty attributes)."""

from __future__ import annotations

from typing import Any

from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.model import RobotModel

_PASSED: set[type] = set()
VALID = "a robot model (rcmplan.RobotModel: Iramis(), make_robot(NAME or FILE.toml), a SerialArm)"


def robot_model(name: str, robot: Any) -> RobotModel:
    """robot if it is a RobotModel, else InvalidInputError naming `name`."""
    kind = robot.__class__
    if kind not in _PASSED:
        if not isinstance(robot, RobotModel):
            raise InvalidInputError(name, robot, VALID)
        _PASSED.add(kind)
    model: RobotModel = robot
    return model
