"""Serial chains from MJCF files (or anything MuJoCo compiles, URDF included).

The compiled model is read at its reference configuration qpos0: body_pos/body_quat place each
body in its parent, and each hinge or slide joint of a body turns or slides it about jnt_axis
through the anchor jnt_pos, in the order MuJoCo applies them. A joint with a nonzero reference
(`ref`) gets that offset folded into its origin, so the chain's q is MuJoCo's qpos. Limits come
from jnt_range; an unlimited hinge gets [-pi, pi] rad and an unlimited slide [-1, 1] m (as
`JointChain.from_dh`). MJCF has no joint speed limit: every joint gets the `ChainJoint` default
velocity. Ball and free joints, and joints coupled by a joint equality, raise
`UnsupportedJointError`. Lengths in m, angles in rad.
"""

from __future__ import annotations

import math
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from rcmplan._validate import FloatArray, file_path, text
from rcmplan.exceptions import (
    ModelFileError,
    UnknownFrameError,
    UnsupportedJointError,
    require_extra,
)
from rcmplan.robot.chain import ChainJoint, JointChain
from rcmplan.robot.dh import JointType

UNSUPPORTED = {0: "free", 1: "ball"}  # mjtJoint values
MOVING: dict[int, JointType] = {2: "prismatic", 3: "revolute"}


def load_mjcf(
    path: str | PathLike[str], tip_frame: str, root_body: str | None = None
) -> JointChain:
    """The serial chain of a MuJoCo model from `root_body` to `tip_frame`.

    Args:
        path: The MJCF (or URDF) file.
        tip_frame: A body or site name (a body first when both exist); the chain's end frame.
        root_body: The body whose frame is the chain's root (default the world body). The
            chain's `base` is its world pose at qpos0.

    Raises:
        ModelFileError: The file is missing or MuJoCo rejects it (MuJoCo's message).
        UnknownFrameError: A body or site is not in the model (the message lists them).
        UnsupportedJointError: A ball, free or equality-coupled joint lies on the path.
        InvalidInputError: path is not a path, or a frame is not a string.
    """
    path = file_path("path", path)
    text("tip_frame", tip_frame)
    if root_body is not None:
        text("root_body", root_body)
    mujoco = require_extra("mujoco", "sim")
    model = _read(mujoco, path)
    tip_body, T_body_tip = _tip(mujoco, model, tip_frame, Path(path).name)
    root = 0 if root_body is None else _body_id(mujoco, model, root_body, Path(path).name)
    bodies = _bodies_between(model, root, tip_body, root_body)
    joints, pending = [], np.eye(4)
    for b in bodies:
        pending = pending @ _pose(mujoco, model.body_pos[b], model.body_quat[b])
        for j in range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b]):
            joints.append(_joint(mujoco, model, j, pending))
            pending = _translation(-model.jnt_pos[j])
    if not joints:
        raise UnknownFrameError("tip_frame (below a moving joint)", tip_frame, _frames(model))
    name = model.names[: model.names.index(b"\0")].decode() or Path(path).stem
    return JointChain(joints, pending @ T_body_tip, _world_pose(mujoco, model, root), name)


def _read(mujoco: Any, path: str | PathLike[str]) -> Any:
    """The compiled MjModel, or ModelFileError naming the file and MuJoCo's reason."""
    if not Path(path).is_file():
        raise ModelFileError(path, "no such file")
    try:
        return mujoco.MjModel.from_xml_path(str(path))
    except ValueError as exc:
        raise ModelFileError(path, str(exc).strip()) from exc


def _frames(model: Any) -> list[str]:
    """Every named body and site."""
    names = [model.body(i).name for i in range(model.nbody)]
    return [n for n in names + [model.site(i).name for i in range(model.nsite)] if n]


def _body_id(mujoco: Any, model: Any, name: str, file: str) -> int:
    """A body's id, or UnknownFrameError listing the bodies."""
    b = int(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name))
    if b < 0:
        names = [model.body(i).name for i in range(model.nbody)]
        raise UnknownFrameError(f"root_body of {file}", name, names)
    return b


def _tip(mujoco: Any, model: Any, name: str, file: str) -> tuple[int, FloatArray]:
    """The body that carries the tip frame, and the tip frame in that body (4, 4)."""
    b = int(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name))
    if b >= 0:
        return b, np.eye(4)
    s = int(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, name))
    if s < 0:
        raise UnknownFrameError(f"tip_frame of {file}", name, _frames(model))
    return int(model.site_bodyid[s]), _pose(mujoco, model.site_pos[s], model.site_quat[s])


def _bodies_between(model: Any, root: int, tip: int, root_name: str | None) -> list[int]:
    """Body ids below `root` down to `tip`, root side first, or raise naming the ancestors."""
    path = [tip]
    while path[-1] not in (root, 0):
        path.append(int(model.body_parentid[path[-1]]))
    if path[-1] != root:
        ancestors = [model.body(b).name for b in path]
        raise UnknownFrameError(
            f"root_body (an ancestor of {model.body(tip).name!r})", str(root_name), ancestors
        )
    return list(reversed(path[:-1]))


def _joint(mujoco: Any, model: Any, j: int, before: FloatArray) -> ChainJoint:
    """One ChainJoint: origin = before . anchor . (motion by -ref), axis jnt_axis."""
    name = model.joint(j).name or f"joint{j}"
    if int(model.jnt_type[j]) in UNSUPPORTED:
        raise UnsupportedJointError(name, UNSUPPORTED[int(model.jnt_type[j])])
    if _coupled(mujoco, model, j):
        raise UnsupportedJointError(name, "coupled by a joint equality")
    kind = MOVING[int(model.jnt_type[j])]
    axis = np.asarray(model.jnt_axis[j], dtype=float)
    ref = float(model.qpos0[model.jnt_qposadr[j]])
    if kind == "revolute":
        offset = np.eye(4)
        offset[:3, :3] = _rotation(mujoco, axis, -ref)
        lower, upper = -math.pi, math.pi
    else:
        offset = _translation(-ref * axis)
        lower, upper = -1.0, 1.0
    if model.jnt_limited[j]:
        lower, upper = (float(v) for v in model.jnt_range[j])
    origin = before @ _translation(model.jnt_pos[j]) @ offset
    return ChainJoint(name, kind, origin, axis, lower, upper)


def _coupled(mujoco: Any, model: Any, j: int) -> bool:
    """Whether an active joint equality ties joint j to another joint (MJCF's mimic)."""
    joint_eq = model.eq_type == mujoco.mjtEq.mjEQ_JOINT
    ends = (model.eq_obj1id == j) | (model.eq_obj2id == j)
    return bool(np.any(joint_eq & model.eq_active0 & ends))


def _pose(mujoco: Any, pos: Any, quat: Any) -> FloatArray:
    """(4, 4) from a position and a MuJoCo quaternion (w, x, y, z)."""
    T = np.eye(4)
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, np.asarray(quat, dtype=float))
    T[:3, :3] = R.reshape(3, 3)
    T[:3, 3] = pos
    return T


def _rotation(mujoco: Any, axis: FloatArray, angle: float) -> FloatArray:
    """(3, 3) rotation by `angle` [rad] about a unit axis, as MuJoCo composes it."""
    quat = np.zeros(4)
    mujoco.mju_axisAngle2Quat(quat, axis, angle)
    return _pose(mujoco, np.zeros(3), quat)[:3, :3]


def _translation(p: Any) -> FloatArray:
    """(4, 4) pure translation by p in [m]."""
    T = np.eye(4)
    T[:3, 3] = p
    return T


def _world_pose(mujoco: Any, model: Any, body: int) -> FloatArray:
    """A body's world pose (4, 4) at qpos0."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    T = np.eye(4)
    T[:3, :3] = data.xmat[body].reshape(3, 3)
    T[:3, 3] = data.xpos[body]
    return T
