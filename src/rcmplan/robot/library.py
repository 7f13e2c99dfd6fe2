"""The arms shipped with rcmplan, one robot file each in `rcmplan/robots/` (the format of
`rcmplan.robot.robot_file`), and the model files of the `example-robot-data` package they use.

A shipped arm's name is its file's name. The chains end at the arm's flange, in a frame whose z
axis is the last joint's axis (the flange normal), so a needle along z rolls with that joint:

- UR5 (`ur_description/urdf/ur5_robot.urdf`): 6 revolute joints up to `tool0`. Its sibling
  `ee_link` has the last joint's axis as x (the ROS-Industrial convention), so `tool0` is used.
- Panda (`panda_description/urdf/panda.urdf`): 7 revolute joints up to `panda_link8`, the
  flange 0.107 m along joint 7's z axis (before the hand's -45 deg turn about z).

Both chains are placed at the URDF root (`base` identity). Lengths in m, angles in rad.
"""

from __future__ import annotations

from importlib import metadata, resources
from pathlib import Path

from rcmplan.exceptions import InvalidInputError, MissingExtraError

PACKAGE = "example-robot-data"
ROBOTS_DIR = "cmeel.prefix/share/example-robot-data/robots"
PACKAGE_URI = f"package://{PACKAGE}/"


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


def package_file(uri: str) -> Path:
    """The file a `package://example-robot-data/<path>` URI names, under `robots_dir()`."""
    if not uri.startswith(PACKAGE_URI):
        raise InvalidInputError("model file URI", uri, f"{PACKAGE_URI}<path under its robots>")
    return robots_dir() / uri[len(PACKAGE_URI) :]


def shipped_robot_files() -> dict[str, Path]:
    """The robot files shipped with rcmplan by name (the file name without .toml), sorted."""
    folder = resources.files("rcmplan.robots")
    names = sorted(f.name[:-5] for f in folder.iterdir() if f.name.endswith(".toml"))
    return {n: Path(str(folder.joinpath(f"{n}.toml"))) for n in names}


ROBOT_FILES: tuple[str, ...] = tuple(shipped_robot_files())


def shipped_robot_file(name: str) -> Path:
    """The robot file of a shipped arm (one of ROBOT_FILES)."""
    files = shipped_robot_files()
    if name not in files:
        raise InvalidInputError("robot name", name, "one of " + ", ".join(files))
    return files[name]
