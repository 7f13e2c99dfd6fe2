"""Real robot arms shipped by the `example-robot-data` package, as `JointChain`s by name.

The chains end at the arm's flange, in a frame whose z axis is the last joint's axis (the
flange normal), so a tool mounted along z rolls with the last joint:

- UR5 (`ur_description/urdf/ur5_robot.urdf`): 6 revolute joints up to `tool0`. Its sibling
  `ee_link` has the last joint's axis as x (the ROS-Industrial convention), so `tool0` is used.
- Panda (`panda_description/urdf/panda.urdf`): 7 revolute joints up to `panda_link8`, the
  flange 0.107 m along joint 7's z axis (before the hand's -45 deg turn about z).

Both chains are placed at the URDF root (`base` identity). Lengths in m, angles in rad.
"""

from __future__ import annotations

from importlib import metadata
from pathlib import Path

from rcmplan.exceptions import InvalidInputError, MissingExtraError
from rcmplan.robot.chain import JointChain
from rcmplan.robot.urdf import load_urdf

PACKAGE = "example-robot-data"
ROBOTS_DIR = "cmeel.prefix/share/example-robot-data/robots"
_FILES = {
    "ur5": ("ur_description/urdf/ur5_robot.urdf", "tool0"),
    "panda": ("panda_description/urdf/panda.urdf", "panda_link8"),
}
ROBOT_FILES: tuple[str, ...] = tuple(_FILES)


def robots_dir() -> Path:
    """The `robots` folder of the installed example-robot-data package.

    Raises:
        MissingExtraError: The package (extra `robots`) is not installed.
    """
    try:
        dist = metadata.distribution(PACKAGE)
    except metadata.PackageNotFoundError as exc:
        raise MissingExtraError(PACKAGE, "robots") from exc
    folder = Path(str(dist.locate_file(ROBOTS_DIR)))
    if not folder.is_dir():
        raise MissingExtraError(PACKAGE, "robots")
    return folder


def robot_file(name: str) -> Path:
    """The URDF file of a shipped robot (one of ROBOT_FILES)."""
    if name not in _FILES:
        raise InvalidInputError("robot name", name, "one of " + ", ".join(ROBOT_FILES))
    return robots_dir() / _FILES[name][0]


def flange_frame(name: str) -> str:
    """The link a shipped robot's chain ends at (its flange), one of ROBOT_FILES."""
    if name not in _FILES:
        raise InvalidInputError("robot name", name, "one of " + ", ".join(ROBOT_FILES))
    return _FILES[name][1]


def robot_chain(name: str) -> JointChain:
    """A shipped robot's chain from its URDF root to its flange frame."""
    path = robot_file(name)
    return load_urdf(path, _FILES[name][1], name=name)


def ur5_chain() -> JointChain:
    """The UR5 from `base_link` (z up, at the URDF root) to `tool0` (z = wrist 3 axis)."""
    return robot_chain("ur5")


def panda_chain() -> JointChain:
    """The Franka Panda from `panda_link0` to the flange `panda_link8` (z = joint 7 axis)."""
    return robot_chain("panda")
