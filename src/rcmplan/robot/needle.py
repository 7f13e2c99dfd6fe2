"""Needle geometry: the straight needle on a tool frame, its points, its angles (eqs. 3.7-3.10).

A straight needle is the segment from p_base (lambda = 0) to p_tip (lambda = 1) of length l;
p(lambda) = p_base + lambda l a with a its unit axis.

Needle angles. rcmplan defines two angles of any unit axis a as

    phi = atan2(a_z, -a_x)                   (rotation about the world y axis, towards +z)
    psi = atan2(-a_y, sqrt(a_x^2 + a_z^2))   (elevation towards -y)

so that `axis_from_angles(phi, psi)` inverts them; on iRAM!S phi = q1 and psi = q3 whenever
|q3| < pi/2 (the needle points along -x at home). The pair is singular where a = +-y.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rcmplan._jit import njit
from rcmplan._validate import FloatArray, pose, scalar


@dataclass(frozen=True)
class StraightNeedle:
    """A straight needle fixed to a tool frame.

    Attributes:
        length: Needle length l in [m], base to tip, in (0, 1].
        mount: (4, 4) pose (a rigid transform) of the needle base in the tool frame; the
            needle runs along the mount's +z axis (identity: from the tool frame's origin
            along its z).
    """

    length: float
    mount: FloatArray = field(default_factory=lambda: np.eye(4))

    def __post_init__(self) -> None:
        length = scalar("needle.length", self.length, 0.0, 1.0, low_open=True)
        object.__setattr__(self, "length", length)
        object.__setattr__(self, "mount", pose("needle.mount", self.mount))

    @property
    def name(self) -> str:
        """ "straight"."""
        return "straight"

    def point_local(self, lam: float) -> FloatArray:
        """p(lambda) in tool-frame coordinates in [m]; any finite lambda (0 at the base, 1 at
        the tip, beyond them the needle's line)."""
        if lam.__class__ is not float or not math.isfinite(lam):
            lam = scalar("lam", lam)
        return self.mount[:3, 3] + lam * self.length * self.mount[:3, 2]

    def axis_local(self) -> FloatArray:
        """The unit needle axis in the tool frame."""
        return np.array(self.mount[:3, 2])


def needle_point(p_base: FloatArray, p_tip: FloatArray, lam: float) -> FloatArray:
    """p(lambda) = p_base + lambda (p_tip - p_base) (eq. 3.7), in the frame of the inputs."""
    return p_base + lam * (p_tip - p_base)


@njit(cache=True, borrows=True)
def closest_point(p_base: Any, p_tip: Any, point: Any) -> tuple[float, float]:
    """(lambda in [0, 1], distance [m]) of the needle point closest to `point`: the drift
    correction of thesis chapter 5 and the RCM deviation. Points are (3,) arrays or 3-tuples
    (a kernel: the compiled loops call it too)."""
    num, den = 0.0, 0.0
    for i in range(3):
        axis = p_tip[i] - p_base[i]
        num += (point[i] - p_base[i]) * axis
        den += axis * axis
    lam = min(1.0, max(0.0, num / den))
    dist = 0.0
    for i in range(3):
        dist += (p_base[i] + lam * (p_tip[i] - p_base[i]) - point[i]) ** 2
    return lam, math.sqrt(dist)


def closest_lambda(p_base: FloatArray, p_tip: FloatArray, point: FloatArray) -> float:
    """The lambda in [0, 1] of the needle point closest to `point` (drift correction, ch. 5)."""
    return float(closest_point(p_base, p_tip, point)[0])


def angle_between(a: FloatArray, b: FloatArray) -> float:
    """Angle in [rad], in [0, pi], between two vectors; 0 if either is (near) zero (norm below
    1e-12)."""
    na, nb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
    if na < 1e-12 or nb < 1e-12:
        return 0.0
    return math.acos(min(1.0, max(-1.0, float(np.dot(a, b)) / (na * nb))))


def angles_from_axis(axis: FloatArray) -> tuple[float, float]:
    """(phi, psi) in [rad] of a needle axis (see module docstring; `axis_angles`)."""
    return axis_angles(float(axis[0]), float(axis[1]), float(axis[2]))


@njit(cache=True, borrows=True)
def axis_angles(ax: float, ay: float, az: float) -> tuple[float, float]:
    """(phi, psi) in [rad] of the needle axis (ax, ay, az): the one definition, which Python
    and compiled code call alike (libm's hypot, not CPython's, which differs in the last bit)."""
    return math.atan2(az, -ax), math.atan2(-ay, math.hypot(ax, az))


@njit(cache=True, borrows=True)
def axes_angles(axes: FloatArray, out: FloatArray) -> None:
    """`axis_angles` of each row of axes (N, 3) into the rows of out (N, 2) [rad] (NaN for a
    NaN axis)."""
    for k in range(axes.shape[0]):
        out[k, 0], out[k, 1] = axis_angles(axes[k, 0], axes[k, 1], axes[k, 2])


@njit(cache=True, borrows=True)
def axis_into(phi: float, psi: float, a: FloatArray) -> None:
    """The unit needle axis with needle angles (phi, psi) into a (3,)."""
    a[0] = -math.cos(phi) * math.cos(psi)
    a[1] = -math.sin(psi)
    a[2] = math.sin(phi) * math.cos(psi)


def axis_from_angles(phi: float, psi: float) -> FloatArray:
    """The unit needle axis with needle angles (phi, psi); inverse of angles_from_axis."""
    a = np.empty(3)
    axis_into(float(phi), float(psi), a)
    return a


@njit(cache=True, borrows=True)
def x_ext_tip(x: FloatArray, a: FloatArray, tip: FloatArray) -> bool:
    """The tip point X_ext (6,) implies, on the line through p_rcm along the axis at x = x_tip,
    into tip (3,) (a (3,) receives the axis); False if the axis is perpendicular to x."""
    axis_into(x[1], x[2], a)
    if abs(a[0]) < 1e-12:
        return False
    t = (x[0] - x[3]) / a[0]
    for i in range(3):
        tip[i] = x[3 + i] + t * a[i]
    return True


@njit(cache=True, borrows=True)
def target_tip_into(target: FloatArray, a: FloatArray, tip: FloatArray) -> bool:
    """The tip point an RCM target states into tip (3,): a curved needle's X_c (7,) its first
    three entries, X_ext (6,) the one it implies (`x_ext_tip`, a (3,) receiving the axis);
    False if X_ext's axis is perpendicular to x."""
    if target.shape[0] == 7:
        for i in range(3):
            tip[i] = target[i]
        return True
    return x_ext_tip(target, a, tip)


@njit(cache=True)
def x_ext_tips(X: FloatArray, tips: FloatArray) -> int:
    """x_ext_tip of each row of X (N, 6) into the rows of tips (N, 3); returns the first row
    whose axis is perpendicular to x (its tip left unset), or -1 when every row has a tip."""
    a = np.empty(3)
    for k in range(X.shape[0]):
        if not x_ext_tip(X[k], a, tips[k]):
            return k
    return -1


def roll_from_axes(axis: FloatArray, bend: FloatArray) -> float:
    """The needle roll rho in [rad]: the angle of a direction `bend` normal to the unit `axis`
    about the axis, measured in the frame the needle angles define.

    With (phi, psi) = angles_from_axis(axis), e1 = (sin phi, 0, cos phi) = (d a / d phi) / cos psi
    and e2 = d a / d psi = (cos phi sin psi, -cos psi, -sin phi sin psi) are normal to a, and
    rho = atan2(-b . e1, -b . e2) grows with a right-handed turn about a. On iRAM!S, with b the x
    axis of the tip frame (eq. 2.7), rho = q5.
    """
    a, b = [float(x) for x in axis[:3]], [float(x) for x in bend[:3]]
    return float(roll_of(a[0], a[1], a[2], b[0], b[1], b[2]))


@njit(cache=True, inline="always")  # inlined into the curved needle's compiled task
def roll_of(ax: float, ay: float, az: float, bx: float, by: float, bz: float) -> float:
    """`roll_from_axes` of the axis a and bend direction b given by their components:
    rho = atan2(-b . e1, -b . e2) with e1, e2 scaled by the same positive factor h |a|
    (h = sqrt(a_x^2 + a_z^2)), so that no angle is formed."""
    h2 = ax * ax + az * az
    r = math.sqrt(h2 + ay * ay)
    return math.atan2(-r * (bx * az - bz * ax), -(ay * (bx * ax + bz * az) - by * h2))
