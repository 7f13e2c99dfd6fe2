"""Robots from one file: a TOML `[robot]` table names the arm's model file, the flange frame, the
needle on it and the home pose. The shipped arms (`rcmplan/robots/*.toml`) use the same format.

    [robot]
    name = "kinova"                  # shown in outputs (required)
    description = "Kinova Jaco 2"    # one line for `rcmplan robot --list` (optional)
    urdf = "package://example-robot-data/kinova_description/robots/kinova.urdf"
    flange = "j2s6s200_end_effector" # URDF link (MJCF: body or site) holding the needle
    needle_axis = "+x"               # the needle's direction in the flange frame ("+z")
    needle_offset_mm = [0, 0, 25]    # the needle base in the flange frame ([0, 0, 0])
    needle_bend = "+y"               # where a curved needle bends, flange frame (see below)
    needle_length_mm = 60.0          # (60)
    home = [...]                     # joints at home, rad or m (absent: searched)

`urdf` or `mjcf` (exactly one) is a path relative to the robot file, an absolute path, or
`package://example-robot-data/<path under the package's robots folder>` (extra `robots`). The
needle starts at `needle_offset_mm` in the flange frame (the flange origin by default) and runs
along `needle_axis`, one of +x -x +y -y +z -z or a direction [x, y, z]: its mount's z axis
(`rcmplan.robot.arms.needle_mount`). A curved needle bends towards `needle_bend` (the same
forms, made normal to the needle: the mount's x axis; absent, `needle_mount` chooses it). The
last joint is held as the needle roll when it turns the needle about its own axis. A home,
given or searched (`rcmplan.robot.home_search`), lies within the joint limits; the arm is then
turned about the vertical so that the needle points along -x at home
(`rcmplan.robot.arms.place_arm`). Every fault raises `RobotFileError` naming the file and key.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from rcmplan._paths import keep, kept_file, read_kept
from rcmplan._validate import FloatArray, file_path, instance
from rcmplan.exceptions import (
    InvalidInputError,
    ModelFileError,
    NoHomeFoundError,
    RobotFileError,
    UnknownFrameError,
    did_you_mean,
)
from rcmplan.robot import home_search
from rcmplan.robot import robot_file_values as values
from rcmplan.robot.arms import BACKWARD_DEG, link_outward, needle_mount, place_arm, roll_joint
from rcmplan.robot.chain import JointChain
from rcmplan.robot.home_search import HomeSearch, search_home
from rcmplan.robot.model import SerialArm
from rcmplan.robot.needle import StraightNeedle

KEYS = ("name", "description", "urdf", "mjcf", "flange", "needle_axis", "needle_offset_mm",
        "needle_length_mm", "needle_bend", "home")  # fmt: skip
MIN_MOVING_JOINTS = 5  # joints moving the needle, to hold an RCM and reach a point
MAX_FILE_BYTES = 1 << 16
SINGULAR_THRESHOLD = 0.01  # the arms' smallest accepted singularity measure


@dataclass(frozen=True)
class RobotSpec:
    """A robot file as read and checked, before its model is loaded.

    Attributes:
        path: The robot file. name, description, flange: As written.
        model_kind: "urdf" or "mjcf"; model: the model file as written (see module docstring).
        needle_axis: One of NEEDLE_AXES, or a unit direction (3,) in the flange frame.
        needle_offset: The needle base (3,) in the flange frame [m]. needle_length: In [m].
        home: Joints at home in [rad] or [m], or None (searched).
        needle_bend: Where a curved needle bends in the flange frame (one of NEEDLE_AXES or a
            unit direction (3,)), or None (`needle_mount`'s choice).
    """

    path: Path
    name: str
    description: str
    model_kind: str
    model: str
    flange: str
    needle_axis: str | tuple[float, float, float] = "+z"
    needle_length: float = values.NEEDLE_LENGTH_MM / 1e3
    needle_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    home: tuple[float, ...] | None = None
    needle_bend: str | tuple[float, float, float] | None = None

    def error(self, key: str, value: Any, valid: str) -> RobotFileError:
        """A RobotFileError naming this file and `key`."""
        return RobotFileError(self.path, key, value, valid)


@dataclass(frozen=True)
class LoadedRobot:
    """An arm from a robot file and how its home was chosen.

    Attributes:
        arm: The SerialArm. spec: The file as read.
        home_searched: True when the file gives no home and the search chose it.
        measure: The arm's singularity measure at home (its manipulability: the inverse
            condition number of the needle's Jacobian, in [0, 1]).
    """

    arm: SerialArm
    spec: RobotSpec
    home_searched: bool
    measure: float

    def note(self) -> str:
        """One line saying what home was chosen, as a `home = [...]` line (rad) that gives the
        same pose to the bit when pasted into the file's [robot] table."""
        q = ", ".join(repr(float(v)) for v in self.arm.home)
        how = "chose home" if self.home_searched else "home"
        where = f"no home in {self.spec.path}; " if self.home_searched else ""
        measure = f"manipulability {self.measure:.3f}, inverse condition number of the needle's"
        keep = "; add that line to [robot] to keep it" if self.home_searched else ""
        names = self.arm.chain.joint_names
        metres = [n for n, p in zip(names, self.arm.chain.prismatic, strict=True) if p]
        unit = f"rad, m for {', '.join(metres)}" if metres else "rad"
        return f"robot {self.arm.name}: {where}{how} = [{q}] ({unit}; {measure} Jacobian){keep}"


def read_robot_file(path: str | Path) -> RobotSpec:
    """The checked [robot] table of a robot file (its model file is not opened here)."""
    path = Path(path)
    table = _table(path)

    def text(key: str, default: str | None = None) -> str:
        value = table.get(key, default)
        if key not in table and default is None:
            raise RobotFileError(path, key, "missing", "a string (the key is required)")
        if not isinstance(value, str) or (not value and default is None):
            raise RobotFileError(path, key, value, "a non-empty string")
        return value

    kinds = [k for k in ("urdf", "mjcf") if k in table]
    if len(kinds) != 1:
        value = "missing" if not kinds else "both urdf and mjcf"
        raise RobotFileError(path, "urdf", value, "one model file: urdf = PATH or mjcf = PATH")
    return RobotSpec(path, text("name"), text("description", ""), kinds[0], text(kinds[0]),
                     text("flange"), values.axis(path, table), values.length(path, table),
                     values.offset(path, table), values.home(path, table),
                     values.bend(path, table))  # fmt: skip


def _table(path: Path) -> dict[str, Any]:
    """The file's [robot] table, every key known."""
    try:
        raw = path.read_bytes()[: MAX_FILE_BYTES + 1]
        if len(raw) > MAX_FILE_BYTES:
            raise RobotFileError(path, "", f"{len(raw)}+ bytes", f"at most {MAX_FILE_BYTES} bytes")
        data = tomllib.loads(raw.decode("utf-8"))
    except OSError as exc:
        raise RobotFileError(path, "", str(path.absolute()), f"a readable file ({exc.strerror})",
                             name="path") from exc  # fmt: skip
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise RobotFileError(path, "", "not TOML", f"UTF-8 TOML ({exc})", name="text") from exc
    table = data.get("robot")
    extra = sorted(set(data) - {"robot"})
    if not isinstance(table, dict) or extra:
        close = did_you_mean(extra[0], ["robot"]) if extra else ""
        raise RobotFileError(path, "", sorted(data), f"one [robot] table{close}", name="tables")
    unknown = sorted(set(table) - set(KEYS))
    if unknown:
        valid = f"one of {', '.join(KEYS)}{did_you_mean(unknown[0], KEYS)}"
        raise RobotFileError(path, unknown[0], unknown[0], valid, name="[robot] key")
    return table


def model_path(spec: RobotSpec) -> Path:
    """The model file: package://example-robot-data/..., absolute, or relative to the file."""
    from rcmplan.robot.library import PACKAGE_URI, package_file

    if spec.model.startswith("package://"):
        if not spec.model.startswith(PACKAGE_URI):
            raise spec.error(spec.model_kind, spec.model, f"{PACKAGE_URI}<path>, a path")
        path = package_file(spec.model)
    else:
        path = Path(spec.model).expanduser()
        path = path if path.is_absolute() else spec.path.parent / path
    if not path.is_file():
        raise spec.error(spec.model_kind, spec.model, f"an existing file (no file at {path})")
    return path


def model_chain(spec: RobotSpec) -> JointChain:
    """The chain from the model's root to the flange, errors named after the robot file."""
    from rcmplan.robot.mjcf import load_mjcf
    from rcmplan.robot.urdf import load_urdf

    path = model_path(spec)
    try:
        if spec.model_kind == "urdf":
            return load_urdf(path, spec.flange, name=spec.name)
        chain = load_mjcf(path, spec.flange)
        return JointChain(chain.joints, chain.tip, chain.base, spec.name)
    except ModelFileError as exc:
        valid = f"a {spec.model_kind.upper()} file that loads ({exc.reason})"
        raise spec.error(spec.model_kind, str(path), valid) from exc
    except UnknownFrameError as exc:
        valid = f"a frame of {path.name}: one of " + ", ".join(exc.frames)
        valid += did_you_mean(spec.flange, exc.frames)
        raise spec.error("flange", spec.flange, valid) from exc
    except InvalidInputError as exc:
        raise spec.error("flange", spec.flange, f"{exc.name} = {exc.value}: {exc.valid}") from exc


def load_robot_file(path: str | Path, search: HomeSearch | None = None) -> LoadedRobot:
    """The arm a robot file describes, checked before any motion (see module docstring)."""
    if search is not None:
        instance("search", search, HomeSearch, "a HomeSearch or None (the default search)")
    spec = read_robot_file(file_path("path", path))
    chain = model_chain(spec)
    try:
        mount = needle_mount(spec.needle_axis, spec.needle_offset, spec.needle_bend)
    except InvalidInputError as exc:
        raise spec.error(exc.name, exc.value, exc.valid) from exc
    _check_needle_leaves_the_arm(spec, chain, mount)
    needle = StraightNeedle(spec.needle_length, mount)
    roll = roll_joint(chain, needle)
    moving = [n for i, n in enumerate(chain.joint_names) if i != roll]
    if len(moving) < MIN_MOVING_JOINTS:
        valid = (f"a frame with at least {MIN_MOVING_JOINTS} joints moving the needle above it "
                 f"({len(moving)} do: {', '.join(moving) or 'none'})")  # fmt: skip
        raise spec.error("flange", spec.flange, valid)
    home, searched = _chosen_home(spec, chain, needle, roll, search or HomeSearch())
    try:
        placed = place_arm(chain, needle, home)
        arm = SerialArm(placed, needle, home, spec.name, roll, SINGULAR_THRESHOLD)
    except InvalidInputError as exc:
        why = exc.valid if exc.name == "home" else f"{exc.valid} ({exc.name}: {exc.value})"
        raise spec.error("home", home.tolist(), why) from exc
    return LoadedRobot(arm, spec, searched, arm.singularity_measure(arm.home))


def _check_needle_leaves_the_arm(spec: RobotSpec, chain: JointChain, mount: FloatArray) -> None:
    """Refuse a needle, mounted at the flange's origin, that points back along the last link:
    `BACKWARD_DEG` or more from the link's outward direction (from the last joint's origin to
    the flange), so that it runs back alongside the link, its tip within half its length of the
    link's line (sin 30 degrees). The angle does not depend on the pose. Not checked for a
    flange at the last joint's origin (no link direction) or a needle mounted away from the
    flange's origin (`needle_offset_mm`: the user placed it)."""
    outward = link_outward(chain)
    if outward is None or np.any(mount[:3, 3] != 0.0):
        return
    angle = float(np.degrees(np.arccos(np.clip(mount[:3, 2] @ outward, -1.0, 1.0))))
    if angle >= BACKWARD_DEG:
        k = int(np.argmax(np.abs(outward)))
        named = ("+" if outward[k] > 0 else "-") + "xyz"[k]
        last = chain.joints[-1].name
        valid = (f"a direction less than {BACKWARD_DEG:.0f} degrees from the last link's outward "
                 f"direction, from joint {last} to the flange: ({outward[0]:.3f}, "
                 f"{outward[1]:.3f}, {outward[2]:.3f}) in the flange frame, nearest {named!r}; "
                 f"this needle is {angle:.0f} degrees from it and runs back into the link "
                 f"(needle_offset_mm mounts it away from the flange's origin)")  # fmt: skip
        raise spec.error("needle_axis", spec.needle_axis, valid)


def _chosen_home(
    spec: RobotSpec, chain: JointChain, needle: StraightNeedle, roll: int | None,
    search: HomeSearch,
) -> tuple[FloatArray, bool]:  # fmt: skip
    """The file's home, checked against the limits, or the searched one."""
    if spec.home is not None:
        return _checked_home(spec, spec.home, chain), False
    key = _search_key(spec, chain, search)
    q, kappa, tried = _searched(key, chain, needle, roll, search)
    if q is None:
        best = f"best manipulability {kappa:.3g}" if kappa > 0 else "none met the conditions"
        raise NoHomeFoundError(
            spec.path, "home", "absent",
            f"a home given in the file: the search found no pose within the joint limits "
            f"({search.margin:.0%} of each travel kept clear) with the needle horizontal, "
            f"pointing away from the arm, the tip above its base and manipulability >= "
            f"{search.min_measure:g} ({tried[0]} samples, {tried[1]} refined; {best})",
        )  # fmt: skip
    return np.array(q), True


def _checked_home(spec: RobotSpec, home: tuple[float, ...], chain: JointChain) -> FloatArray:
    """The file's home (n,), each joint within its limits."""
    if len(home) != chain.n:
        names = ", ".join(chain.joint_names)
        valid = f"{chain.n} values, one per joint moving the flange ({names})"
        raise spec.error("home", f"{len(home)} values", valid)
    for i, (v, name) in enumerate(zip(home, chain.joint_names, strict=True)):
        lo, hi = float(chain.lower[i]), float(chain.upper[i])
        if not lo <= v <= hi:
            unit = "m" if chain.prismatic[i] else "rad"
            raise spec.error(f"home[{i}] (joint {name!r})", v,
                             f"within the joint's limits [{lo:.6g}, {hi:.6g}] {unit}")  # fmt: skip
    return np.array(home)


def _search_key(spec: RobotSpec, chain: JointChain, search: HomeSearch) -> tuple[Any, ...]:
    """What a searched home depends on: the chain's numbers, the needle, the settings."""
    arrays = (chain.base, chain.origins, chain.axes, chain.tip, chain.lower, chain.upper,
              chain.prismatic)  # fmt: skip
    numbers = np.concatenate([np.ravel(a) for a in arrays])
    return (numbers.tobytes(), spec.needle_axis, spec.needle_offset, spec.needle_length,
            spec.needle_bend, search)  # fmt: skip


# A search's result: (home or None, its singularity measure, (samples, refined))
_Found = tuple[tuple[float, ...] | None, float, tuple[int, int]]
_SEARCHED: dict[tuple[Any, ...], _Found] = {}


def _searched(
    key: tuple[Any, ...], chain: JointChain, needle: StraightNeedle, roll: int | None,
    search: HomeSearch,
) -> _Found:  # fmt: skip
    """search_home, remembered per key in the process (a command loads a robot file more than
    once) and between processes in the user's cache folder (a search costs up to a second;
    `rcmplan._paths`), keyed with the robot models' sources (the search and the kinematics it
    runs on) and the numpy and scipy it ran with."""
    if key not in _SEARCHED:
        if len(_SEARCHED) >= 16:
            _SEARCHED.clear()
        versions = f"{np.__version__} {metadata.version('scipy')} {key[1:]!r}".encode()
        here = Path(home_search.__file__).parent
        sources = [p.read_bytes() for p in [*sorted(here.glob("*.py")), here.parent / "linalg.py"]]
        file = kept_file("home", key[0], versions, *sources)
        kept = _kept_home(read_kept(file), chain.n)
        if kept is None:
            found = search_home(chain, needle, roll, search)
            q = None if found.q is None else tuple(float(v) for v in found.q)
            kept = (q, float(found.measure), (int(found.tried[0]), int(found.tried[1])))
            keep(file, {"q": q, "measure": kept[1], "tried": kept[2]})
        _SEARCHED[key] = kept
    return _SEARCHED[key]


def _kept_home(value: Any, n: int) -> _Found | None:
    """A search's result as `keep` wrote it ({"q": n floats or None, "measure", "tried"}), or
    None for anything else."""
    try:
        q, measure, tried = value["q"], value["measure"], value["tried"]
        ok = q is None or (len(q) == n and all(type(v) is float for v in q))
        if ok and type(measure) is float and len(tried) == 2 and all(type(t) is int for t in tried):
            return (None if q is None else tuple(q)), measure, (tried[0], tried[1])
    except (KeyError, TypeError):
        pass
    return None
