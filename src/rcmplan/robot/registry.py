"""Robots by name or file, so commands and scenario files can say `--robot ur5` or
`--robot my_arm.toml`.

"iramis" is the thesis robot (closed forms, no extra needed). The other names are the robot
files shipped in `rcmplan/robots/` (found by listing that folder); any other robot file (a
path ending in .toml, format of `rcmplan.robot.robot_file`) is loaded the same way.
"""

from __future__ import annotations

from os import PathLike
from pathlib import Path

from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.iramis import Iramis
from rcmplan.robot.model import RobotModel
from rcmplan.robot.names import BUILT_IN, DEFAULT_ROBOT, VALID, check_robot, is_robot_file

__all__ = [
    "BUILT_IN",
    "DEFAULT_ROBOT",
    "ROBOTS",
    "VALID",
    "check_robot",
    "is_robot_file",
    "make_robot",
    "summary_fields",
]


def shipped_robots() -> dict[str, str]:
    """Every robot available by name with its description: iramis, then the shipped files."""
    from rcmplan.robot.library import shipped_robot_files
    from rcmplan.robot.robot_file import read_robot_file

    files = shipped_robot_files()
    return {**BUILT_IN, **{n: read_robot_file(p).description for n, p in files.items()}}


ROBOTS: dict[str, str] = shipped_robots()


def summary_fields(robot: str) -> dict[str, str]:
    """What every run's summary.json says of its robot: `robot`, the robot's name, and for a
    robot file `robot_file`, the file's absolute path (the name is the file's `name`)."""
    if not is_robot_file(robot):
        return {"robot": robot}
    from rcmplan.robot.robot_file import read_robot_file

    return {"robot": read_robot_file(robot).name, "robot_file": str(Path(robot).resolve())}


def make_robot(name_or_path: str | Path = DEFAULT_ROBOT) -> RobotModel:
    """The robot named `name_or_path` (one of ROBOTS) or described by that robot file."""
    if not isinstance(name_or_path, str | PathLike):
        raise InvalidInputError("robot", name_or_path, VALID)
    robot = check_robot(str(name_or_path))
    if robot == "iramis":
        return Iramis()
    from rcmplan.robot.library import shipped_robot_file
    from rcmplan.robot.robot_file import load_robot_file

    path = Path(robot) if is_robot_file(robot) else shipped_robot_file(robot)
    return load_robot_file(path).arm
