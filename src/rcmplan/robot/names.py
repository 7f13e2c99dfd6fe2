"""The robots by name, without loading any: what `--robot` accepts (`check_robot`), read by
the command line as it starts, so this module imports no robot model (numba, scipy).

"iramis" is the thesis robot; the other names are the robot files shipped in `rcmplan/robots/`
(found by listing that folder). `rcmplan.robot.registry` builds the robot a name stands for.
"""

from __future__ import annotations

from pathlib import Path

from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.library import ROBOT_FILES

DEFAULT_ROBOT = "iramis"
BUILT_IN = {
    "iramis": "iRAM!S eye-surgery robot of the reference thesis (Table 2.1): 2 PCJMs, "
    "a prismatic stage and a needle roll",
}
ROBOT_NAMES: tuple[str, ...] = (*BUILT_IN, *ROBOT_FILES)
VALID = "one of " + ", ".join(ROBOT_NAMES) + ", or a robot file (an existing .toml file)"


def is_robot_file(robot: str) -> bool:
    """True when `robot` names a robot file rather than a robot by name."""
    return robot not in ROBOT_NAMES and robot.endswith(".toml")


def check_robot(robot: str) -> str:
    """`robot` if it is a robot name or an existing .toml file, else InvalidInputError."""
    if robot in ROBOT_NAMES or (is_robot_file(robot) and Path(robot).is_file()):
        return robot
    if is_robot_file(robot):
        missing = str(Path(robot).absolute())  # where a relative name was looked for
        raise InvalidInputError("robot", robot, f"{VALID}; there is no file {missing!r}")
    raise InvalidInputError("robot", robot, VALID)
