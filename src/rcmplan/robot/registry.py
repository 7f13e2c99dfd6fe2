"""Robots by name, so commands and scenario files can say `--robot ur5`.

"iramis" is the thesis robot (closed forms, no extra needed); "ur5" and "panda" are arms from
their URDF files in the `example-robot-data` package (the `robots` extra), each holding a
straight needle on its flange (`rcmplan.robot.arms`).
"""

from __future__ import annotations

from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.iramis import Iramis
from rcmplan.robot.model import RobotModel

ROBOTS: dict[str, str] = {
    "iramis": "iRAM!S eye-surgery robot of the reference thesis (Table 2.1): 2 PCJMs, "
    "a prismatic stage and a needle roll",
    "ur5": "Universal Robots UR5 (6 revolute joints, URDF of example-robot-data), "
    "60 mm needle on tool0",
    "panda": "Franka Emika Panda (7 revolute joints, URDF of example-robot-data), "
    "60 mm needle on panda_link8; redundant",
}
DEFAULT_ROBOT = "iramis"


def make_robot(name: str = DEFAULT_ROBOT) -> RobotModel:
    """The robot registered under `name` (one of ROBOTS)."""
    if name not in ROBOTS:
        raise InvalidInputError("robot", name, "one of " + ", ".join(ROBOTS))
    if name == "iramis":
        return Iramis()
    from rcmplan.robot.arms import shipped_arm

    return shipped_arm(name)
