"""Task functions of the iRAM!S needle and their exact Jacobians.

Every Jacobian is with respect to the extended variables theta_ext = (q0, q1, q2, q3, q4, lambda)
(eq. 3.11); the needle roll q5 moves no point of a straight needle and is left out.

Needle angles. The needle axis of iRAM!S is a(q) = (-cos q1 cos q3, -sin q3, sin q1 cos q3).
rcmplan defines the two needle angles from any unit axis a as

    phi = atan2(a_z, -a_x)                   (rotation about the base y axis, towards +z)
    psi = atan2(-a_y, sqrt(a_x^2 + a_z^2))   (elevation towards -y)

so that axis_from_angles(phi, psi) inverts them, and on iRAM!S phi = q1 and psi = q3 whenever
|q3| < pi/2. Their exact derivatives are therefore the unit rows e_q1 and e_q3.
"""

from __future__ import annotations

import math

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.robot.iramis import Iramis


def angles_from_axis(axis: FloatArray) -> tuple[float, float]:
    """(phi, psi) in [rad] of a needle axis (see module docstring)."""
    ax, ay, az = float(axis[0]), float(axis[1]), float(axis[2])
    return math.atan2(az, -ax), math.atan2(-ay, math.hypot(ax, az))


def axis_from_angles(phi: float, psi: float) -> FloatArray:
    """The unit needle axis with needle angles (phi, psi); inverse of angles_from_axis."""
    return np.array([-math.cos(phi) * math.cos(psi), -math.sin(psi), math.sin(phi) * math.cos(psi)])


def needle_angles(robot: Iramis, q: FloatArray) -> tuple[float, float]:
    """(phi, psi) of the needle at q."""
    return angles_from_axis(robot.needle_axis(q))


def needle_angles_jacobian() -> FloatArray:
    """d(phi, psi)/d theta_ext: exactly the rows e_q1 and e_q3 on iRAM!S, a (2, 6) array."""
    J = np.zeros((2, 6))
    J[0, 1] = 1.0
    J[1, 3] = 1.0
    return J


def needle_angles_jacobian_thesis(q: FloatArray) -> FloatArray:
    """The thesis's angle rows (eq. 6.1): geometric omega_y = dq1, omega_z = cos q1 dq3."""
    J = np.zeros((2, 6))
    J[0, 1] = 1.0
    J[1, 3] = math.cos(q[1])
    return J


def tip_position_jacobian(robot: Iramis, q: FloatArray) -> FloatArray:
    """d p_tip / d theta_ext, a (3, 6) array with a zero lambda column (rows 1-3 of eq. 2.13)."""
    J = robot.needle_point_jacobian(q, 1.0)
    J[:, 5] = 0.0
    return J


def rcm_point(robot: Iramis, q: FloatArray, lam: float) -> FloatArray:
    """The RCM point p(lambda) on the needle in [m] (eq. 3.7)."""
    return robot.needle_point(q, lam)


def rcm_jacobian(robot: Iramis, q: FloatArray, lam: float) -> FloatArray:
    """J_c = d p(lambda) / d theta_ext, a (3, 6) array (eq. 3.10)."""
    return robot.needle_point_jacobian(q, lam)
