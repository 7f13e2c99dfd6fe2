"""Serial arms holding a needle, placed in the world frame of rcmplan's scenes.

rcmplan's scenes (`rcmplan.scene.eye`) place the eye in front of the needle tip at home, with
the needle pointing along the world's -x axis at home (as iRAM!S's does). `place_arm` turns an
arm about the world z axis (vertical stays vertical) so that its needle's horizontal direction
at home is -x; the shipped arms hold the needle horizontally at home, so it points along -x.
Arms from robot files (`rcmplan.robot.robot_file`, the shipped ones in `rcmplan/robots/`) are
placed the same way.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from rcmplan._validate import FloatArray, instance, vector
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.chain import JointChain
from rcmplan.robot.model import SerialArm
from rcmplan.robot.needle import StraightNeedle

NEEDLE_LENGTH = 60e-3  # [m], a 60 mm straight needle on the flange (assumed)
NEEDLE_AXES = ("+x", "-x", "+y", "-y", "+z", "-z")  # a needle's direction in its flange frame


def place_arm(
    chain: JointChain, needle: StraightNeedle, home: Sequence[float] | FloatArray
) -> JointChain:
    """The chain turned about the world z axis so that the needle points along -x at home
    (its horizontal part; raises if the needle is vertical at home)."""
    T = chain.forward_kinematics(vector("home", home, chain.n))
    a = T[:3, :3] @ needle.axis_local()
    if math.hypot(a[0], a[1]) < 0.1:
        raise InvalidInputError("home", list(home), "a pose whose needle is not vertical")
    turn = math.pi - math.atan2(a[1], a[0])  # rotate (a_x, a_y) onto (-|a_xy|, 0)
    c, s = math.cos(turn), math.sin(turn)
    R = np.eye(4)
    R[:2, :2] = [[c, -s], [s, c]]
    return chain.placed(R @ chain.base)


def needle_arm(
    chain: JointChain,
    home: Sequence[float],
    name: str,
    needle: StraightNeedle | None = None,
    singular_threshold: float = 0.01,
) -> SerialArm:
    """A SerialArm with a straight needle along its flange z axis (rolled by the last joint),
    placed by `place_arm`."""
    instance("chain", chain, JointChain, "a JointChain (from DH, URDF or MJCF)")
    needle = StraightNeedle(NEEDLE_LENGTH) if needle is None else needle
    instance("needle", needle, StraightNeedle, "a StraightNeedle or None (60 mm)")
    placed = place_arm(chain, needle, home)
    return SerialArm(placed, needle, home, name=name, roll_joint=chain.n - 1,
                     singular_threshold=singular_threshold)  # fmt: skip


def needle_mount(
    axis: str | Sequence[float],
    offset: Sequence[float] = (0.0, 0.0, 0.0),
    bend: str | Sequence[float] | None = None,
) -> FloatArray:
    """The (4, 4) needle mount in the flange frame: its origin (the needle base) at `offset`
    (3,) [m], its z axis (the needle) along `axis`, one of NEEDLE_AXES or a direction (3,) (made
    unit). Its x axis (a curved needle's bend) is `bend` made normal to the needle (one of
    NEEDLE_AXES or a direction (3,), at least 25 degrees from the needle's line); without
    `bend`, the flange's z made normal to the needle, or the flange's x for a needle within 25
    degrees of the flange's z (for the named axes: the flange's z for +-x and +-y, its x for
    +-z)."""
    z = _direction("needle_axis", axis)
    if bend is None:
        x = np.array([0.0, 0.0, 1.0]) if abs(z[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    else:
        x = _direction("needle_bend", bend)
        if abs(float(x @ z)) >= 0.9:
            valid = f"a direction at least 25 degrees from the needle's line {z.tolist()}"
            raise InvalidInputError("needle_bend", bend, valid)
    x = x - (x @ z) * z
    x /= np.linalg.norm(x)
    M = np.eye(4)
    M[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    M[:3, 3] = vector("needle_offset", offset, 3)
    return M


def _direction(name: str, value: str | Sequence[float]) -> FloatArray:
    """A unit direction (3,) in the flange frame from one of NEEDLE_AXES or a vector (3,)."""
    if isinstance(value, str):
        if value not in NEEDLE_AXES:
            raise InvalidInputError(name, value, "one of " + " ".join(NEEDLE_AXES))
        out = np.zeros(3)
        out["xyz".index(value[1])] = 1.0 if value[0] == "+" else -1.0
        return out
    out = vector(name, value, 3)
    norm = float(np.linalg.norm(out))
    if not norm > 1e-9:
        raise InvalidInputError(name, value, "a non-zero direction (3,)")
    return out / norm


BACKWARD_DEG = 150.0  # a needle this far from its last link's outward direction runs into it


def link_outward(chain: JointChain) -> FloatArray | None:
    """The last link's outward direction in the flange frame: from the last joint's origin to
    the flange (unit, the same at every pose), or None for a flange within 1 mm of it."""
    link = chain.tip[:3, :3].T @ chain.tip[:3, 3]
    norm = float(np.linalg.norm(link))
    return None if norm < 1e-3 else link / norm


def roll_joint(chain: JointChain, needle: StraightNeedle) -> int | None:
    """The last joint if it turns the needle about its own axis (a revolute joint whose axis
    holds the needle's base and tip), else None."""
    k = chain.n - 1
    if chain.prismatic[k]:
        return None
    ends = [chain.tip[:3, :3] @ needle.point_local(lam) + chain.tip[:3, 3] for lam in (0.0, 1.0)]
    on_axis = all(np.linalg.norm(np.cross(chain.axes[k], p)) < 1e-9 for p in ends)
    return k if on_axis else None
