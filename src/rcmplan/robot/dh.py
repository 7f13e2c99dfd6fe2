"""Serial chains in standard Denavit-Hartenberg convention (thesis eqs. 2.5, 2.6, 2.9-2.11).

Link i moves frame i-1 to frame i by T = Rz(theta) Tz(d) Tx(a) Rx(alpha). For a revolute joint
theta = theta_offset + q_i and d = d_offset; for a prismatic joint d = d_offset + q_i and
theta = theta_offset. Lengths in m, angles in rad.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Literal, NamedTuple

import numpy as np

from rcmplan._validate import WORKSPACE_M, FloatArray, integer, pose, scalar, vector
from rcmplan.exceptions import InvalidInputError, UnknownJointTypeError

JointType = Literal["revolute", "prismatic"]
JOINT_TYPES: tuple[str, ...] = ("revolute", "prismatic")


class _DHFields(NamedTuple):
    joint: JointType
    theta: float = 0.0
    d: float = 0.0
    a: float = 0.0
    alpha: float = 0.0


class DHLink(_DHFields):
    """One standard-DH link, checked when made (InvalidInputError naming the field).

    Attributes:
        joint: "revolute" or "prismatic".
        theta: Constant offset of theta in [rad], within [-2 pi, 2 pi].
        d: Constant offset of d in [m], within +-WORKSPACE_M.
        a: Link length a in [m], within +-WORKSPACE_M.
        alpha: Link twist alpha in [rad], within [-2 pi, 2 pi].
    """

    __slots__ = ()

    def __new__(
        cls, joint: JointType, theta: float = 0.0, d: float = 0.0, a: float = 0.0,
        alpha: float = 0.0,
    ) -> DHLink:  # fmt: skip
        if not isinstance(joint, str) or joint not in JOINT_TYPES:
            raise UnknownJointTypeError("link.joint", joint, f"one of {JOINT_TYPES}")
        turn, reach = 2.0 * math.pi, WORKSPACE_M
        theta, alpha = (
            scalar("link.theta", theta, -turn, turn),
            scalar("link.alpha", alpha, -turn, turn),
        )
        d, a = scalar("link.d", d, -reach, reach), scalar("link.a", a, -reach, reach)
        return super().__new__(cls, joint, theta, d, a, alpha)


def dh_transform(theta: float, d: float, a: float, alpha: float) -> FloatArray:
    """Homogeneous transform of one standard-DH link (eq. 2.5)."""
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = np.cos(alpha), np.sin(alpha)
    return np.array(
        [
            [ct, -st * ca, st * sa, a * ct],
            [st, ct * ca, -ct * sa, a * st],
            [0.0, sa, ca, d],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


class DHChain:
    """Any serial chain given by a standard-DH table.

    Args:
        links: The links from base to end, each a DHLink (or a tuple in its field order).
        base: Optional (4, 4) transform of frame 0 in the world frame.
    """

    def __init__(self, links: Sequence[DHLink | tuple], base: FloatArray | None = None) -> None:
        if not isinstance(links, list | tuple) or len(links) == 0:
            raise InvalidInputError("links", links, "a list of DH links (at least one)")
        self.links: tuple[DHLink, ...] = tuple(_link(i, link) for i, link in enumerate(links))
        self.base = np.eye(4) if base is None else pose("base", base)
        self._revolute = np.array([lk.joint == "revolute" for lk in self.links])

    @property
    def n(self) -> int:
        """Number of joints."""
        return len(self.links)

    def frames(self, q: Sequence[float] | FloatArray) -> FloatArray:
        """All frames T_0^i for i = 0..n as an (n+1, 4, 4) array (eq. 2.6)."""
        q = vector("q", q, self.n)
        out = np.empty((self.n + 1, 4, 4))
        out[0] = self.base
        for i, (lk, qi) in enumerate(zip(self.links, q, strict=True)):
            rev = lk.joint == "revolute"
            theta = lk.theta + (qi if rev else 0.0)
            d = lk.d + (0.0 if rev else qi)
            out[i + 1] = out[i] @ dh_transform(theta, d, lk.a, lk.alpha)
        return out

    def forward_kinematics(self, q: Sequence[float] | FloatArray) -> FloatArray:
        """The end pose T_0^n as a (4, 4) array."""
        return self.frames(q)[-1]

    def jacobian(
        self,
        q: Sequence[float] | FloatArray,
        link: int | None = None,
        point: Sequence[float] | None = None,
    ) -> FloatArray:
        """Geometric Jacobian (6, n) of a point fixed to a link, in the base frame (eqs. 2.9-2.11).

        Rows are (linear velocity, angular velocity) of the point.

        Args:
            q: Joint vector (m for prismatic, rad for revolute).
            link: Frame index 0..n the point is fixed to (default n, the end frame).
            point: Coordinates of the point in that frame in [m] (default its origin).
        """
        n = self.n if link is None else integer("link", link, 0, self.n)
        T = self.frames(q)
        p_local = np.zeros(3) if point is None else vector("point", point, 3)
        p = T[n, :3, :3] @ p_local + T[n, :3, 3]
        J = np.zeros((6, self.n))
        for i in range(n):
            z = T[i, :3, 2]
            if self._revolute[i]:
                J[:3, i] = np.cross(z, p - T[i, :3, 3])  # eq. 2.10
                J[3:, i] = z
            else:
                J[:3, i] = z  # eq. 2.11
        return J


def _link(i: int, link: Any) -> DHLink:
    """links[i] as a DHLink (a DHLink, or a tuple in its field order), or InvalidInputError."""
    if isinstance(link, DHLink):
        return link
    if not isinstance(link, tuple | list) or not 1 <= len(link) <= 5:
        raise InvalidInputError(
            f"links[{i}]", link, "a DHLink or a tuple (joint, theta, d, a, alpha)"
        )
    try:
        return DHLink(*link)
    except InvalidInputError as exc:
        raise type(exc)(f"links[{i}] {exc.name}", exc.value, exc.valid) from exc
