"""Serial chains as URDF and MJCF state them: each joint a fixed origin in its parent frame,
then a motion along or about a unit axis of that joint frame.

Frame k (k = 0..n-1) is joint k's frame after its motion; frame n is the end frame (`tip`, a
fixed transform of frame n-1). A standard-DH table converts exactly (`JointChain.from_dh`).
Lengths in m, angles in rad; every frame in the world frame (the chain's `base` placed in it).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from rcmplan._validate import FloatArray, instance, pose, scalar, text, vector
from rcmplan.exceptions import InvalidInputError, UnknownJointTypeError
from rcmplan.robot.dh import JOINT_TYPES, DHChain, JointType, dh_transform


@dataclass(frozen=True)
class ChainJoint:
    """One joint of a serial chain.

    Attributes:
        name: Joint name (as in the model file).
        kind: "revolute" or "prismatic".
        origin: (4, 4) pose of the joint frame in the previous joint's frame at q = 0.
        axis: Unit axis (3,) of the motion, in the joint frame.
        lower, upper: Travel in [rad] or [m].
        velocity: Largest speed in [rad/s] or [m/s].
    """

    name: str
    kind: JointType
    origin: FloatArray
    axis: FloatArray
    lower: float = -math.pi
    upper: float = math.pi
    velocity: float = 1.0

    def __post_init__(self) -> None:
        text("joint name", self.name)
        if not isinstance(self.kind, str) or self.kind not in JOINT_TYPES:
            raise UnknownJointTypeError(f"joint {self.name!r} kind", self.kind, str(JOINT_TYPES))
        origin = pose(f"joint {self.name!r} origin", self.origin)
        object.__setattr__(self, "origin", origin)
        axis = vector(f"joint {self.name!r} axis", self.axis, 3)
        norm = float(np.linalg.norm(axis))
        if norm < 1e-9:
            raise InvalidInputError(f"joint {self.name!r} axis", axis.tolist(), "a non-zero axis")
        object.__setattr__(self, "axis", axis / norm)
        lo = scalar(f"joint {self.name!r} lower", self.lower)
        hi = scalar(f"joint {self.name!r} upper", self.upper, lo, np.inf, low_open=True)
        v = scalar(f"joint {self.name!r} velocity", self.velocity, 0.0, np.inf, low_open=True)
        for name, value in (("lower", lo), ("upper", hi), ("velocity", v)):
            object.__setattr__(self, name, value)


def _motion(axis: FloatArray, prismatic: bool, q: float) -> FloatArray:
    """The (4, 4) motion of a joint by q along (prismatic) or about (revolute) a unit axis."""
    M = np.eye(4)
    if prismatic:
        M[:3, 3] = q * axis
        return M
    x, y, z = axis
    c, s = math.cos(q), math.sin(q)
    C = 1.0 - c
    M[:3, :3] = [
        [c + x * x * C, x * y * C - z * s, x * z * C + y * s],
        [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
        [z * x * C - y * s, z * y * C + x * s, c + z * z * C],
    ]  # Rodrigues' formula
    return M


class JointChain:
    """A serial chain of revolute and prismatic joints.

    Args:
        joints: The joints from base to end.
        tip: (4, 4) end frame in the last joint's frame (default identity).
        base: (4, 4) pose of the chain's root frame in the world (default identity).
        name: A name for messages.
    """

    def __init__(
        self,
        joints: Sequence[ChainJoint],
        tip: FloatArray | None = None,
        base: FloatArray | None = None,
        name: str = "chain",
    ) -> None:
        if not isinstance(joints, list | tuple) or len(joints) == 0:
            raise InvalidInputError("joints", joints, "a list of ChainJoint (at least one)")
        for j in joints:
            instance("joints", j, ChainJoint, "a list of ChainJoint")
        self.joints = tuple(joints)
        self.name = text("name", name)
        self.tip = np.eye(4) if tip is None else pose("tip", tip)
        self.base = np.eye(4) if base is None else pose("base", base)
        self.origins = np.array([j.origin for j in self.joints])
        self.axes = np.array([j.axis for j in self.joints])
        self.prismatic = np.array([j.kind == "prismatic" for j in self.joints])
        self.lower = np.array([j.lower for j in self.joints])
        self.upper = np.array([j.upper for j in self.joints])
        self.velocity = np.array([j.velocity for j in self.joints])

    @property
    def n(self) -> int:
        """Number of joints."""
        return len(self.joints)

    @property
    def joint_names(self) -> tuple[str, ...]:
        """The joint names, base to end."""
        return tuple(j.name for j in self.joints)

    def placed(self, base: FloatArray, tip: FloatArray | None = None) -> JointChain:
        """The same joints with another base pose (and end frame, if given)."""
        return JointChain(self.joints, self.tip if tip is None else tip, base, self.name)

    def frames(self, q: Sequence[float] | FloatArray) -> FloatArray:
        """Frames 0..n (joint frames after motion, then the end frame), (n + 1, 4, 4), world."""
        q = vector("q", q, self.n)
        out = np.empty((self.n + 1, 4, 4))
        T = self.base
        for k in range(self.n):
            T = T @ self.origins[k] @ _motion(self.axes[k], bool(self.prismatic[k]), q[k])
            out[k] = T
        out[self.n] = T @ self.tip
        return out

    def forward_kinematics(self, q: Sequence[float] | FloatArray) -> FloatArray:
        """The end frame (4, 4) in the world."""
        return self.frames(q)[-1]

    def jacobian(
        self, q: Sequence[float] | FloatArray, point: Sequence[float] | None = None
    ) -> FloatArray:
        """Geometric Jacobian (6, n) of a point fixed to the end frame, world frame.

        Rows are (linear velocity, angular velocity) of the point (eqs. 2.9-2.11).

        Args:
            point: The point in end-frame coordinates in [m] (default its origin).
        """
        T = self.frames(q)
        local = np.zeros(3) if point is None else vector("point", point, 3)
        return self.point_jacobian(T, T[-1, :3, :3] @ local + T[-1, :3, 3])

    def point_jacobian(self, T: FloatArray, p: FloatArray) -> FloatArray:
        """Geometric Jacobian (6, n) of the world point p (3,) moving with the end frame, given
        the frames T (n + 1, 4, 4) of `frames` (eqs. 2.9-2.11)."""
        n = self.n
        z = np.einsum("kij,kj->ki", T[:n, :3, :3], np.asarray(self.axes))  # joint axes, world
        r = p - T[:n, :3, 3]
        lin = np.empty((n, 3))  # z x r for a revolute joint (eq. 2.10), z for a prismatic one
        lin[:, 0] = z[:, 1] * r[:, 2] - z[:, 2] * r[:, 1]
        lin[:, 1] = z[:, 2] * r[:, 0] - z[:, 0] * r[:, 2]
        lin[:, 2] = z[:, 0] * r[:, 1] - z[:, 1] * r[:, 0]
        prismatic = np.asarray(self.prismatic, dtype=bool)
        lin[prismatic] = z[prismatic]  # eq. 2.11
        J = np.zeros((6, n))
        J[:3] = lin.T
        J[3:] = np.where(prismatic[:, None], 0.0, z).T
        return J

    @classmethod
    def from_dh(cls, chain: DHChain, name: str = "dh") -> JointChain:
        """The exact equivalent of a standard-DH chain (same end frame for every q).

        Link i is Rz(theta) Tz(d) Tx(a) Rx(alpha) with the joint acting on theta or d; joint i's
        frame is the previous link's tail Tz(d) Tx(a) Rx(alpha) (or Tx(a) Rx(alpha)) times
        Rz(theta offset) (and Tz(d offset) for a prismatic joint), its axis z.
        """
        joints, tail = [], np.eye(4)
        for i, lk in enumerate(chain.links):
            prismatic = lk.joint == "prismatic"
            head = dh_transform(lk.theta, lk.d if prismatic else 0.0, 0.0, 0.0)
            travel = 1.0 if prismatic else math.pi  # DH tables carry no limits
            z = np.array([0.0, 0.0, 1.0])
            joints.append(ChainJoint(f"q{i}", lk.joint, tail @ head, z, -travel, travel))
            tail = dh_transform(0.0, 0.0 if prismatic else lk.d, lk.a, lk.alpha)
        return cls(joints, tip=tail, base=chain.base, name=name)
