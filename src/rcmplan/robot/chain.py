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
from rcmplan.robot import chain_kinematics as kin
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
        # the chain kernels' arrays: every joint active, a needle of length 0 on the end frame
        self._A, self._ix = kin.pack(self, np.eye(4), 0.0, np.zeros(self.n), range(self.n))

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
        """Frames 0..n (joint frames after motion, then the end frame), (n + 1, 4, 4), world:
        the chain kernels' frames (`chain_kinematics.frames`)."""
        q = vector("q", q, self.n)
        W = np.empty(kin.work_shape(self.n, self.n))
        kin.frames(self._A, self._ix, q, W)
        return W[: 4 * (self.n + 1), :4].reshape(self.n + 1, 4, 4)

    def forward_kinematics(self, q: Sequence[float] | FloatArray) -> FloatArray:
        """The end frame (4, 4) in the world."""
        return self.frames(q)[-1]

    def jacobian(
        self, q: Sequence[float] | FloatArray, point: Sequence[float] | FloatArray | None = None
    ) -> FloatArray:
        """Geometric Jacobian (6, n) of a point fixed to the end frame, world frame.

        Rows are (linear velocity, angular velocity) of the point (eqs. 2.9-2.11), from the
        chain kernels (`chain_kinematics.point_jacobian`, `angular_jacobian`) with the point as
        a needle's base on every joint.

        Args:
            point: The point in end-frame coordinates in [m] (default its origin).
        """
        q = vector("q", q, self.n)
        A = self._A
        if point is not None:
            A = A.copy()
            A[4 * (self.n + 2) : 4 * (self.n + 2) + 3, 3] = vector("point", point, 3)
        W = np.empty(kin.work_shape(self.n, self.n))
        kin.frames(A, self._ix, q, W)
        J = np.empty((6, self.n + 1))
        kin.point_jacobian(A, self._ix, W, 0.0, J, 0)
        kin.angular_jacobian(A, self._ix, W, J, 3)
        return J[:, : self.n].copy()

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
