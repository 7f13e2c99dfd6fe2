"""A robot holding a curved needle: the third rotation (thesis ch. 5, "inclusion of a third
rotation into the Jacobian matrix").

`CurvedTipRobot` wraps a model that holds the needle's straight shaft (iRAM!S with l6 = l_s, or a
SerialArm with a StraightNeedle of length l_s) and puts the arc of a `CurvedNeedle` after it.
The RCM stays on the shaft, so p(lambda), the needle axis and the needle angles are the shaft's.
The tip is the arc's end: the roll joint (iRAM!S's q5, an arm's last joint) now moves it, so the
roll joins the active joints, theta_ext = (q[active + roll], lambda). The tip, the roll and their
exact Jacobians are the compiled kernels' (`curved_iramis` on iRAM!S, `curved_arm` on an arm,
`curved_block` for J_c):

    J_tip = J_v - [p_tip - o]x J_w          (tool-frame Jacobian moved to the tip, eq. 2.11)
    rho   = roll_of(a, b),  J_rho = a^T J_w - a_y J_phi   (`rcmplan.robot.needle.roll_of`)

with (J_v, J_w) the geometric Jacobian of the needle base frame, a the shaft axis and b the bevel
direction (the mount's +x). With alpha = 0 every quantity is the wrapped model's own: the same
straight needle, the roll held.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray, array, scalar, vector
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot import curved_arm, curved_iramis
from rcmplan.robot.arms import BACKWARD_DEG, link_outward
from rcmplan.robot.curved_block import BLOCK_ROWS, WIDTH, G, J
from rcmplan.robot.curved_needle import CurvedNeedle
from rcmplan.robot.iramis import Iramis
from rcmplan.robot.model import RobotModel, SerialArm

TIP, ROLL, POINT = slice(0, 3), 3, slice(4, 7)  # rows of X_c and J_c


class CurvedArrays(NamedTuple):
    """The kernels' arrays of a curved-needle robot: `P` for iRAM!S (`curved_iramis.params`),
    else (A, ix) of an arm (`curved_arm.pack`); `n` joints, `m` active (with the roll)."""

    P: FloatArray | None
    A: FloatArray | None
    ix: NDArray[np.int64] | None
    n: int
    m: int

    def arm(self) -> tuple[FloatArray, NDArray[np.int64]]:
        """(A, ix) of an arm (InvalidInputError for iRAM!S's arrays)."""
        if self.A is None or self.ix is None:
            raise InvalidInputError("curved-needle arrays", "iRAM!S's P", "an arm's (A, ix)")
        return self.A, self.ix

    def work_shape(self) -> tuple[int, int]:
        """Shape of the work array of the kernels: iRAM!S's block, or an arm's frames and
        block (`curved_arm.work_shape`)."""
        if self.P is not None:
            return BLOCK_ROWS, WIDTH
        return curved_arm.work_shape(self.n, int(self.arm()[1][1]), self.m)

    def block_row(self) -> int:
        """First row of the curved work block in the work array."""
        return 0 if self.P is not None else int(curved_arm.block_row(self.n))


def _arrays(
    base: Iramis | SerialArm, needle: CurvedNeedle, active: tuple[int, ...]
) -> CurvedArrays:
    """The kernels' arrays of `base` holding `needle` with `active` joints moving."""
    tip = needle.tip_local()
    if isinstance(base, Iramis):
        return CurvedArrays(curved_iramis.params(base.P, tip), None, None, 6, 6)
    A, ix = curved_arm.pack(*base.kernel_arrays, tip, active)
    return CurvedArrays(None, A, ix, len(base.home), len(active))


class CurvedTipRobot:
    """A RobotModel whose needle is `needle` (a CurvedNeedle) on the shaft `base` holds.

    Args:
        base: Iramis or SerialArm holding the shaft (needle length l_s, a roll joint).
        needle: The curved needle; its shaft length must equal the base's needle length.
    """

    def __init__(self, base: Iramis | SerialArm, needle: CurvedNeedle) -> None:
        if not isinstance(base, Iramis | SerialArm):
            raise InvalidInputError("robot", type(base).__name__, "an Iramis or a SerialArm")
        roll = getattr(base, "roll_joint", None)
        if roll is None:
            raise InvalidInputError("robot", base.name, _no_roll(base))
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
        self.arrays: CurvedArrays | None = None
        if needle.curved:
            self.active = tuple(sorted({*base.active, roll}))
            self.arrays = _arrays(base, needle, self.active)
            self._x = np.empty(WIDTH)
            self._work = np.empty(self.arrays.work_shape())
            self._key: tuple[bytes, float, bool] | None = None
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

    # --- the kernels ---------------------------------------------------------------------
    def task_and_jacobian(
        self, q: FloatArray, lam: float, pose: bool = False
    ) -> tuple[FloatArray, FloatArray]:
        """X_c (7,) and J_c (7, m + 1) of the curved needle at (q, lambda), from the kernels;
        with `pose` the whole-pose task (p_tip, rho, p(0)). Views of this model's work arrays,
        valid until its next query (InvalidInputError for a straight needle)."""
        arrays = self.arrays
        if arrays is None:
            raise InvalidInputError("robot", self.name, "a robot holding a curved needle")
        q = vector("q", q, arrays.n)
        lam = scalar("lam", lam)
        key = (q.tobytes(), lam, bool(pose))
        if key != self._key:
            if arrays.P is not None:
                curved_iramis.task_jacobian(arrays.P, q, lam, bool(pose), self._x, self._work)
            else:
                A, ix = arrays.arm()
                curved_arm.task_jacobian(A, ix, self._work, q, lam, bool(pose), self._x)
            self._key = key
        c = arrays.block_row()
        return self._x, self._work[c + J : c + J + WIDTH, : arrays.m + 1]

    def needle_frames(self, Q: FloatArray) -> FloatArray:
        """For each joints row of Q (R, n), from the kernels: the needle base p(0), the shaft's
        end p(1), the shaft axis and the bend direction (the mount frame's z and x), (R, 4, 3)
        in [m] (InvalidInputError for a straight needle or joints of another shape)."""
        arrays = self.arrays
        if arrays is None:
            raise InvalidInputError("robot", self.name, "a robot holding a curved needle")
        Q = np.ascontiguousarray(array("Q", Q, 2))
        if Q.shape[1] != arrays.n:
            raise InvalidInputError("Q", f"shape {Q.shape}", f"joints rows (R, {arrays.n})")
        out = np.empty((Q.shape[0], 4, 3))
        if arrays.P is not None:
            curved_iramis.needle_frames(arrays.P, Q, out)
        else:
            A, ix = arrays.arm()
            curved_arm.needle_frames(A, ix, np.empty(arrays.work_shape()), Q, out)
        return out

    def _angular(self, q: FloatArray) -> FloatArray:
        """J_w over the active joints (3, m) from the kernels' work block."""
        assert self.arrays is not None
        self.task_and_jacobian(q, 0.0, True)
        c = self.arrays.block_row() + G
        return self._work[c + 3 : c + 6, : self.arrays.m]

    def _widen(self, J_base: FloatArray) -> FloatArray:
        """A base Jacobian (k, m_base + 1) with a zero column for the roll, (k, m + 1)."""
        out = np.zeros((J_base.shape[0], len(self.active) + 1))
        out[:, self._base_cols] = J_base[:, :-1]
        out[:, -1] = J_base[:, -1]
        return out

    # --- the shaft (RCM, needle axis and angles) ----------------------------------------
    def needle_point(self, q: FloatArray, lam: float) -> FloatArray:
        """The shaft point p(lambda) in [m]."""
        return self.base.needle_point(q, lam)

    def needle_axis(self, q: FloatArray) -> FloatArray:
        """The unit shaft axis."""
        return self.base.needle_axis(q)

    def needle_point_jacobian(self, q: FloatArray, lam: float) -> FloatArray:
        """d p(lambda) / d theta_ext, (3, m + 1)."""
        if self.arrays is None:
            return self.base.needle_point_jacobian(q, lam)
        return self.task_and_jacobian(q, lam)[1][POINT].copy()

    def needle_angular_jacobian(self, q: FloatArray) -> FloatArray:
        """Angular velocity of the needle per theta_ext, (3, m + 1), zero lambda column."""
        if self.arrays is None:
            return self.base.needle_angular_jacobian(q)
        out = np.zeros((3, len(self.active) + 1))
        out[:, :-1] = self._angular(q)
        return out

    def needle_angles_jacobian(self, q: FloatArray) -> FloatArray:
        """Exact d(phi, psi) / d theta_ext of the shaft axis, (2, m + 1): the base's, the roll
        turning about the axis itself (its column zero)."""
        J_base = self.base.needle_angles_jacobian(q)
        return J_base if self.arrays is None else self._widen(J_base)

    # --- the tip ------------------------------------------------------------------------
    def tip(self, q: FloatArray) -> FloatArray:
        """The tip (the arc's end) in [m]."""
        if self.arrays is None:
            return self.base.tip(q)
        return self.task_and_jacobian(q, 0.0, True)[0][TIP].copy()

    def tip_direction(self, q: FloatArray) -> FloatArray:
        """The unit tip tangent."""
        return self.base.tool_pose(q)[:3, :3] @ self.needle.tip_direction_local()

    def tip_jacobian(self, q: FloatArray) -> FloatArray:
        """d p_tip / d theta_ext, (3, m + 1), zero lambda column."""
        if self.arrays is None:
            return self.base.tip_jacobian(q)
        return self.task_and_jacobian(q, 0.0, True)[1][TIP].copy()

    def roll(self, q: FloatArray) -> float:
        """The needle roll rho in [rad] (`rcmplan.robot.needle.roll_of`; q5 on iRAM!S)."""
        return float(self.task_and_jacobian(q, 0.0, True)[0][ROLL])

    def roll_jacobian(self, q: FloatArray) -> FloatArray:
        """d rho / d theta_ext, (m + 1,)."""
        return self.task_and_jacobian(q, 0.0, True)[1][ROLL].copy()


def curved_robot(base: RobotModel, needle: CurvedNeedle) -> CurvedTipRobot:
    """`base` (Iramis or SerialArm) holding `needle` (the constructor checks the base's kind)."""
    return CurvedTipRobot(base, needle)  # type: ignore[arg-type]


def _no_roll(arm: Iramis | SerialArm) -> str:
    """What a curved needle asks of the robot, and on an arm which needle axis gives it."""
    valid = "a model whose last joint rolls the needle about its own axis (a curved needle's bend"
    valid += " turns with it)"
    if not isinstance(arm, SerialArm) or arm.chain.prismatic[-1]:
        return valid
    chain = arm.chain
    axis = chain.tip[:3, :3].T @ chain.axes[-1]  # the last joint's axis, flange frame
    k = int(np.argmax(np.abs(axis)))
    off_axis = np.linalg.norm(np.cross(chain.axes[-1], chain.tip[:3, 3])) > 1e-9
    if abs(axis[k]) < 1.0 - 1e-9 or off_axis:  # not a named axis, or not through the flange
        return valid
    outward = link_outward(chain)  # the sign away from the last link, if it matters
    back = outward is not None and abs(outward[k]) >= -math.cos(math.radians(BACKWARD_DEG))
    signs = ("+" if outward[k] > 0.0 else "-") if outward is not None and back else "+-"
    named = " or ".join(f'needle_axis = "{sign}{"xyz"[k]}"' for sign in signs)
    return (
        f"{valid}; the last joint of {arm.name}, {chain.joint_names[-1]}, turns about the "
        f"flange's {'xyz'[k]} axis: {named} in the robot file mounts the needle on it"
    )
