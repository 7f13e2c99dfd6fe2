"""A robot holding a curved needle: the third rotation (thesis ch. 5, "inclusion of a third
rotation into the Jacobian matrix").

`CurvedTipRobot` wraps a model that holds the needle's straight shaft (iRAM!S with l6 = l_s, or a
SerialArm with a StraightNeedle of length l_s) and puts the arc of a `CurvedNeedle` after it.
The RCM stays on the shaft, so p(lambda), the needle axis and the needle angles are the shaft's.
The tip is the arc's end: the roll joint (iRAM!S's q5, an arm's last joint) now moves it, so the
roll joins the active joints, theta_ext = (q[active + roll], lambda). Jacobians are exact:

    J_tip = J_v - [p_tip - o]x J_w          (tool-frame Jacobian moved to the tip, eq. 2.11)
    rho   = roll_from_axes(a, b),  J_rho = a^T J_w - a_y J_phi   (`rcmplan.robot.needle`)

with (J_v, J_w) the geometric Jacobian of the needle base frame, a the shaft axis and b the bevel
direction (the mount's +x). With alpha = 0 every quantity is the wrapped model's own: the same
straight needle, the roll held.
"""

from __future__ import annotations

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.curved_needle import CurvedNeedle
from rcmplan.robot.iramis import Iramis
from rcmplan.robot.model import RobotModel, SerialArm
from rcmplan.robot.needle import angles_jacobian, roll_from_axes, roll_jacobian


def skew(v: FloatArray) -> FloatArray:
    """[v]x, the (3, 3) cross-product matrix."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


class CurvedTipRobot:
    """A RobotModel whose needle is `needle` (a CurvedNeedle) on the shaft `base` holds.

    Args:
        base: Iramis or SerialArm holding the shaft (needle length l_s, a roll joint).
        needle: The curved needle; its shaft length must equal the base's needle length.
    """

    def __init__(self, base: Iramis | SerialArm, needle: CurvedNeedle) -> None:
        roll = getattr(base, "roll_joint", None)
        if roll is None:
            raise InvalidInputError("robot", base.name, "a model with a needle roll joint")
        if abs(base.needle_length - needle.shaft_length) > 1e-15:
            raise InvalidInputError(
                "needle.shaft_length", needle.shaft_length,
                f"the length of the shaft the robot holds, {base.needle_length} m",
            )  # fmt: skip
        self.base, self.needle, self.roll_joint = base, needle, int(roll)
        self.name = base.name
        self.joint_names, self.actuator_names = base.joint_names, base.actuator_names
        self.actuator_units = base.actuator_units
        self.lower, self.upper, self.speed = base.lower, base.upper, base.speed
        self.home, self.home_actuators = base.home, base.home_actuators
        self.resolution, self.singular_threshold = base.resolution, base.singular_threshold
        self.needle_kind = needle.name
        self.needle_length = needle.shaft_length
        self.active: tuple[int, ...] = base.active
        if needle.curved:
            self.active = tuple(sorted({*base.active, roll}))
        self._base_cols = [self.active.index(i) for i in base.active]

    # --- actuators and singularities: the base's ---------------------------------------
    def joints_from_actuators(self, s: FloatArray) -> FloatArray:
        return self.base.joints_from_actuators(s)

    def actuators_from_joints(self, q: FloatArray) -> FloatArray:
        return self.base.actuators_from_joints(q)

    def joint_rates(self, q: FloatArray) -> FloatArray:
        return self.base.joint_rates(q)

    def check_actuators(self, s: FloatArray) -> FloatArray:
        return self.base.check_actuators(s)

    def actuator_margin(self, s: FloatArray) -> FloatArray:
        return self.base.actuator_margin(s)

    def singularity_measure(self, q: FloatArray) -> float:
        return self.base.singularity_measure(q)

    def singular_terms(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        return self.base.singular_terms(q)

    def singular_values(self, q: FloatArray) -> FloatArray:
        """The base's singular terms' values, without their gradients."""
        values = getattr(self.base, "singular_values", None)
        return values(q) if values is not None else self.base.singular_terms(q)[0]

    def smallest_singular_values(self, Q: FloatArray) -> FloatArray | None:
        """The base's smallest singular term per row of Q (N, n), None if it has no batch."""
        values = getattr(self.base, "smallest_singular_values", None)
        return values(Q) if values is not None else None

    def check_singularity(self, q: FloatArray, threshold: float | None = None) -> None:
        self.base.check_singularity(q, threshold)

    def needle_pose(
        self, tip: FloatArray, phi: float, psi: float, seed: FloatArray | None = None
    ) -> FloatArray:
        """Joints putting the shaft's end at `tip` with the shaft along (phi, psi)."""
        return self.base.needle_pose(tip, phi, psi, seed)

    # --- the shaft (RCM, needle axis and angles) ----------------------------------------
    def _widen(self, J_base: FloatArray, roll_col: FloatArray) -> FloatArray:
        """A base Jacobian (k, m_base + 1) with the roll's column inserted (k, m + 1)."""
        if not self.needle.curved:
            return J_base
        out = np.zeros((J_base.shape[0], len(self.active) + 1))
        out[:, self._base_cols] = J_base[:, :-1]
        out[:, -1] = J_base[:, -1]
        out[:, self.active.index(self.roll_joint)] = roll_col
        return out

    def _roll_column(self, q: FloatArray, p: FloatArray) -> tuple[FloatArray, FloatArray]:
        """(linear velocity of world point p, angular velocity) per unit roll."""
        J = self.base.tool_jacobian(q)[:, [self.roll_joint]][:, 0]
        o = self.base.tool_pose(q)[:3, 3]
        return J[:3] - skew(p - o) @ J[3:], J[3:]

    def needle_point(self, q: FloatArray, lam: float) -> FloatArray:
        """The shaft point p(lambda) in [m]."""
        return self.base.needle_point(q, lam)

    def needle_axis(self, q: FloatArray) -> FloatArray:
        """The unit shaft axis."""
        return self.base.needle_axis(q)

    def needle_point_jacobian(self, q: FloatArray, lam: float) -> FloatArray:
        """d p(lambda) / d theta_ext, (3, m + 1)."""
        J = self.base.needle_point_jacobian(q, lam)
        if not self.needle.curved:
            return J
        return self._widen(J, self._roll_column(q, self.needle_point(q, lam))[0])

    def needle_angular_jacobian(self, q: FloatArray) -> FloatArray:
        """Angular velocity of the needle per theta_ext, (3, m + 1)."""
        J = self.base.needle_angular_jacobian(q)
        if not self.needle.curved:
            return J
        return self._widen(J, self._roll_column(q, self.needle_point(q, 0.0))[1])

    def needle_angles_jacobian(self, q: FloatArray) -> FloatArray:
        """Exact d(phi, psi) / d theta_ext of the shaft axis, (2, m + 1)."""
        if not self.needle.curved:
            return self.base.needle_angles_jacobian(q)
        return angles_jacobian(self.needle_axis(q), self.needle_angular_jacobian(q))

    # --- the tip ------------------------------------------------------------------------
    def tip(self, q: FloatArray) -> FloatArray:
        """The tip (the arc's end) in [m]."""
        if not self.needle.curved:
            return self.base.tip(q)
        T = self.base.tool_pose(q)
        return T[:3, :3] @ self.needle.tip_local() + T[:3, 3]

    def tip_direction(self, q: FloatArray) -> FloatArray:
        """The unit tip tangent."""
        return self.base.tool_pose(q)[:3, :3] @ self.needle.tip_direction_local()

    def bend_direction(self, q: FloatArray) -> FloatArray:
        """The unit bevel direction b (the mount's +x), normal to the shaft."""
        return self.base.tool_pose(q)[:3, 0].copy()

    def tip_jacobian(self, q: FloatArray) -> FloatArray:
        """d p_tip / d theta_ext, (3, m + 1), zero lambda column."""
        if not self.needle.curved:
            return self.base.tip_jacobian(q)
        J = self.base.tool_jacobian(q)
        o = self.base.tool_pose(q)[:3, 3]
        out = np.zeros((3, len(self.active) + 1))
        out[:, :-1] = (J[:3] - skew(self.tip(q) - o) @ J[3:])[:, list(self.active)]
        return out

    def roll(self, q: FloatArray) -> float:
        """The needle roll rho in [rad] (`rcmplan.robot.needle.roll_from_axes`)."""
        return roll_from_axes(self.needle_axis(q), self.bend_direction(q))

    def roll_jacobian(self, q: FloatArray) -> FloatArray:
        """d rho / d theta_ext, (m + 1,)."""
        return roll_jacobian(self.needle_axis(q), self.needle_angular_jacobian(q))


def curved_robot(base: RobotModel, needle: CurvedNeedle) -> CurvedTipRobot:
    """`base` (Iramis or SerialArm) holding `needle` (checks the base's kind)."""
    if not isinstance(base, Iramis | SerialArm):
        raise InvalidInputError("robot", type(base).__name__, "an Iramis or a SerialArm")
    return CurvedTipRobot(base, needle)
