"""Serial chains from URDF files, parsed with yourdfpy (no meshes are loaded).

The chain runs from a root link to a tip link. Each revolute, continuous or prismatic joint on
the path becomes a `ChainJoint` with its URDF origin, axis, limits and velocity; fixed joints
fold into the next moving joint's origin, or into the chain's `tip` after the last one.
A continuous joint gets the travel [-pi, pi] rad (one full turn; `ChainJoint` needs finite
limits) and, without a <limit> tag, the `ChainJoint` default velocity. Mimic, floating and
planar joints on the path raise `UnsupportedJointError`. Lengths in m, angles in rad.

Importing the parser costs most of a second (yourdfpy imports trimesh), a quarter to a third of
a short arm command's process, so a chain read once is kept as JSON in the user's cache folder
(`$XDG_CACHE_HOME/rcmplan/urdf/`, default `~/.cache`), keyed by the file's bytes, the frames
and name asked for, the parser's version and this module's source: the same request on an
unchanged file returns the same chain without the parser. The cache holds what the parser
read, not the chain built from it, so a chain from the cache equals a parsed one bit for bit.
A cache that cannot be read or written is passed over.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from importlib import metadata
from os import PathLike
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

import numpy as np

from rcmplan._paths import keep, kept_file, read_kept
from rcmplan._validate import FloatArray, file_path, text
from rcmplan.exceptions import (
    InvalidInputError,
    ModelFileError,
    RcmplanError,
    UnknownFrameError,
    UnsupportedJointError,
    require_extra,
)
from rcmplan.robot.chain import ChainJoint, JointChain
from rcmplan.robot.dh import JointType

MOVING: dict[str, JointType] = {
    "revolute": "revolute",
    "continuous": "revolute",
    "prismatic": "prismatic",
}


def load_urdf(
    path: str | PathLike[str],
    tip_frame: str,
    root_frame: str | None = None,
    name: str | None = None,
) -> JointChain:
    """The serial chain of a URDF from `root_frame` to `tip_frame` (link names).

    Args:
        path: The URDF file.
        tip_frame: The link whose frame is the chain's end frame.
        root_frame: The link whose frame is the chain's root (default: the top of the tree
            that holds `tip_frame`). The chain's `base` is its pose in the URDF root's frame
            with every joint above it at 0.
        name: The chain's name (default: the URDF robot name).

    Raises:
        ModelFileError: The file is missing or the parser rejects it.
        UnknownFrameError: A frame is not a link of the model (the message lists the links).
        UnsupportedJointError: A mimic, floating or planar joint lies on the path.
        InvalidInputError: path is not a path, or a frame or the name is not a string.
    """
    path = file_path("path", path)
    text("tip_frame", tip_frame)
    if root_frame is not None:
        text("root_frame", root_frame)
    if name is not None:
        text("name", name)
    key = _cache_file(path, tip_frame, root_frame, name)
    chain = _cached(key)
    if chain is None:
        spec = _read_chain(path, tip_frame, root_frame, name)
        chain = _chain(spec)
        if key is not None:
            keep(key, spec)
    return chain


def _chain(spec: dict[str, Any]) -> JointChain:
    """The chain of `_read_chain`'s result."""
    joints = [ChainJoint(**j) for j in spec["joints"]]
    return JointChain(joints, np.array(spec["tip"]), np.array(spec["base"]), spec["name"])


def _read_chain(path: Path, tip_frame: str, root_frame: str | None,
                name: str | None) -> dict[str, Any]:  # fmt: skip
    """What `load_urdf` builds its chain from, read by the parser: the chain's name, tip and
    base (lists), and each moving joint's `ChainJoint` arguments."""
    robot = _read(path)
    links = [link.name for link in robot.links]
    by_child = {j.child: j for j in robot.joints}
    for label, frame in (("tip_frame", tip_frame), ("root_frame", root_frame)):
        if frame is not None and frame not in links:
            raise UnknownFrameError(f"{label} of {Path(path).name}", frame, links)
    above = _path_up(by_child, tip_frame)
    top = above[-1].parent if above else tip_frame
    root = top if root_frame is None else root_frame
    path_joints = _path_down(by_child, above, root, tip_frame)
    joints, tip = _chain_joints(path_joints)
    if not joints:
        valid = f"a link below {root!r} with at least one moving joint on the way"
        raise InvalidInputError("tip_frame", tip_frame, valid)
    base = _product(_origin(j) for j in reversed(_path_up(by_child, root)))
    return {"name": name or robot.name, "tip": tip.tolist(), "base": base.tolist(),
            "joints": joints}  # fmt: skip


def _cache_file(path: Path, tip_frame: str, root_frame: str | None,
                name: str | None) -> Path | None:  # fmt: skip
    """The cache file of this request, or None when the file cannot be read (the parser then
    says why)."""
    try:
        data = Path(path).read_bytes()
        parser = metadata.version("yourdfpy")
    except (OSError, metadata.PackageNotFoundError):
        return None
    request = json.dumps([parser, tip_frame, root_frame, name]).encode()
    return kept_file("urdf", data, Path(__file__).read_bytes(), request)


def _cached(file: Path | None) -> JointChain | None:
    """The chain kept in file, or None if there is none it can build (no file, or not one
    `keep` wrote whole)."""
    spec = None if file is None else read_kept(file)
    try:
        return None if spec is None else _chain(spec)
    except (KeyError, TypeError, ValueError, RcmplanError):
        return None


def _read(path: str | PathLike[str]) -> Any:
    """The yourdfpy Robot of a file, or ModelFileError naming the file and the reason."""
    yourdfpy = require_extra("yourdfpy", "robots")
    if not Path(path).is_file():
        raise ModelFileError(path, "no such file")
    try:  # yourdfpy recovers from broken XML with a partial model: refuse that first
        ElementTree.parse(path)
    except ElementTree.ParseError as exc:
        raise ModelFileError(path, f"malformed XML: {exc}") from exc
    try:
        urdf = yourdfpy.URDF.load(
            str(path),
            build_scene_graph=False,
            build_collision_scene_graph=False,
            load_meshes=False,
            load_collision_meshes=False,
        )
    except Exception as exc:  # yourdfpy raises anything from lxml, KeyError, ValueError...
        raise ModelFileError(path, f"{type(exc).__name__}: {exc}") from exc
    if urdf.robot is None or not urdf.robot.links:
        raise ModelFileError(path, "no <robot> with links in the file")
    return urdf.robot


def _path_up(by_child: dict[str, Any], link: str) -> list[Any]:
    """The joints from `link` up to the top of its tree, nearest first."""
    out: list[Any] = []
    while link in by_child:
        out.append(by_child[link])
        link = out[-1].parent
        if len(out) > len(by_child):
            raise InvalidInputError("URDF tree", link, "a tree without joint loops")
    return out


def _path_down(by_child: dict[str, Any], above: list[Any], root: str, tip: str) -> list[Any]:
    """The joints from `root` down to `tip`, or raise naming the links on tip's path."""
    if root == tip:
        return []
    for k, joint in enumerate(above):
        if joint.parent == root:
            return list(reversed(above[: k + 1]))
    ancestors = [j.parent for j in above]
    raise UnknownFrameError(f"root_frame (an ancestor of {tip!r})", root, ancestors)


def _chain_joints(path_joints: Sequence[Any]) -> tuple[list[dict[str, Any]], FloatArray]:
    """The `ChainJoint` arguments of the moving joints of a path, and the fixed remainder (the
    tip)."""
    joints: list[dict[str, Any]] = []
    pending = np.eye(4)
    for j in path_joints:
        pending = pending @ _origin(j)
        if j.type == "fixed":
            continue
        if j.type not in MOVING or j.mimic is not None:
            raise UnsupportedJointError(j.name, "mimic" if j.mimic is not None else str(j.type))
        joints.append(_joint(j, pending))
        pending = np.eye(4)
    return joints, pending


def _joint(j: Any, origin: FloatArray) -> dict[str, Any]:
    """One ChainJoint's arguments from a yourdfpy Joint (checked by building it); limits from
    <limit>, [-pi, pi] if continuous."""
    limit = j.limit
    lower, upper = -math.pi, math.pi
    if j.type != "continuous":
        lower = 0.0 if limit is None or limit.lower is None else float(limit.lower)
        upper = 0.0 if limit is None or limit.upper is None else float(limit.upper)
    velocity = 1.0 if limit is None or limit.velocity is None else float(limit.velocity)
    axis = np.array([1.0, 0.0, 0.0]) if j.axis is None else np.asarray(j.axis, dtype=float)
    spec = {
        "name": j.name,
        "kind": MOVING[j.type],
        "origin": origin.tolist(),
        "axis": axis.tolist(),
        "lower": lower,
        "upper": upper,
        "velocity": velocity,
    }
    ChainJoint(**spec)  # raises now if the file's values are invalid
    return spec


def _origin(j: Any) -> FloatArray:
    """A joint's origin (4, 4), identity when the URDF omits it."""
    return np.eye(4) if j.origin is None else np.asarray(j.origin, dtype=float)


def _product(transforms: Any) -> FloatArray:
    """The product of (4, 4) transforms in order."""
    T = np.eye(4)
    for M in transforms:
        T = T @ M
    return T
