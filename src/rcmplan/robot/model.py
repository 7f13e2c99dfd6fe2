"""What the controller needs of a robot: `RobotModel`, and `SerialArm`, any serial chain
holding a straight needle.

A model has joints q (n,) and actuators s (n,): a plant reads and commands actuators, tasks live
in joint space. The actuator map is the identity on an arm and the PCJM slider map on iRAM!S.
The controller moves the `active` joints and lambda, theta_ext = (q[active], lambda) (eq. 3.11);
a joint that only rolls a straight needle about its own axis moves no point of it and is held.
Every point and Jacobian is in the world frame in [m]; Jacobians are over theta_ext.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray, array, instance, integer, scalar, text, vector
from rcmplan.exceptions import (
    InvalidInputError,
    SingularPoseError,
    SliderLimitError,
    UnreachableTargetError,
)
from rcmplan.robot import chain_kinematics as kin
from rcmplan.robot import chain_pose
from rcmplan.robot import chain_singular as sing
from rcmplan.robot.chain import JointChain
from rcmplan.robot.needle import StraightNeedle

IK_ITERATIONS = 100  # Newton iterations of `SerialArm.needle_pose`
IK_TOLERANCE = 1e-12  # [m] and [rad]


@runtime_checkable
class RobotModel(Protocol):
    """A robot holding a needle, as the controller, tasks, limits and plants see it.

    Attributes:
        name: Short name ("iramis", "ur5", ...).
        joint_names, actuator_names: Names of q and s; actuator_units: "m" or "rad" each.
        active: Indices of the joints the controller moves.
        lower, upper, speed: Actuator travel and largest speed (n,) in [m], [rad], per s.
        home: Joints at home (n,); home_actuators: the same as actuators.
        needle_length: l in [m]. resolution: Smallest actuator step in [m] or [rad].
        singular_threshold: Smallest accepted singularity measure.
    """

    name: str
    needle_kind: str
    joint_names: tuple[str, ...]
    actuator_names: tuple[str, ...]
    actuator_units: tuple[str, ...]
    active: tuple[int, ...]
    lower: FloatArray
    upper: FloatArray
    speed: FloatArray
    home: FloatArray
    home_actuators: FloatArray
    needle_length: float
    resolution: float
    singular_threshold: float

    def joints_from_actuators(self, s: FloatArray) -> FloatArray: ...
    def actuators_from_joints(self, q: FloatArray) -> FloatArray: ...
    def joint_rates(self, q: FloatArray) -> FloatArray:
        """dq/ds (n, n) at joints q."""
        ...

    def check_actuators(self, s: FloatArray) -> FloatArray: ...
    def actuator_margin(self, s: FloatArray) -> FloatArray: ...
    def needle_point(self, q: FloatArray, lam: float) -> FloatArray: ...
    def needle_axis(self, q: FloatArray) -> FloatArray: ...
    def tip(self, q: FloatArray) -> FloatArray: ...
    def needle_point_jacobian(self, q: FloatArray, lam: float) -> FloatArray:
        """d p(lambda) / d theta_ext, (3, m + 1)."""
        ...

    def tip_jacobian(self, q: FloatArray) -> FloatArray:
        """d p_tip / d theta_ext, (3, m + 1), zero lambda column."""
        ...

    def needle_angular_jacobian(self, q: FloatArray) -> FloatArray:
        """Angular velocity of the needle per theta_ext, (3, m + 1), zero lambda column."""
        ...

    def needle_angles_jacobian(self, q: FloatArray) -> FloatArray:
        """Exact d(phi, psi) / d theta_ext, (2, m + 1)."""
        ...

    def singularity_measure(self, q: FloatArray) -> float: ...
    def singular_terms(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Quantities (k,) to keep above the singular floor and their gradients (k, n)."""
        ...

    def check_singularity(self, q: FloatArray, threshold: float | None = None) -> None: ...
    def needle_pose(
        self, tip: FloatArray, phi: float, psi: float, seed: FloatArray | None = None
    ) -> FloatArray:
        """Joints putting the tip at `tip` with needle angles (phi, psi), travel unchecked;
        UnreachableTargetError if there are none."""
        ...


class SerialArm:
    """Any serial chain with a straight needle on its end frame; actuators are the joints.

    Args:
        chain: The arm's kinematics (from DH, URDF or MJCF), placed in the world.
        needle: The needle on the chain's end frame.
        home: Joints at home (n,), within the chain's limits.
        name: Short name.
        roll_joint: Index of a joint that turns the needle about its own axis (held by the
            controller on a straight needle), or None.
        singular_threshold: Smallest accepted inverse condition number of the needle's
            Jacobian (tip velocity / l and the two needle rotations normal to its axis).
        resolution: Smallest joint step in [rad] or [m].
    """

    def __init__(
        self,
        chain: JointChain,
        needle: StraightNeedle,
        home: Sequence[float] | FloatArray,
        name: str = "arm",
        roll_joint: int | None = None,
        singular_threshold: float = 0.01,
        resolution: float = 1e-9,
    ) -> None:
        instance("chain", chain, JointChain, "a JointChain (from DH, URDF or MJCF)")
        instance("needle", needle, StraightNeedle, "a StraightNeedle")
        text("name", name)
        if roll_joint is not None:
            integer("roll_joint", roll_joint, 0, chain.n - 1)
        self.chain, self.needle, self.name = chain, needle, name
        self.needle_kind = needle.name
        n = chain.n
        self.joint_names = self.actuator_names = chain.joint_names
        self.actuator_units = tuple("m" if p else "rad" for p in chain.prismatic)
        self.lower, self.upper = chain.lower.copy(), chain.upper.copy()
        self.speed = chain.velocity.copy()
        self.needle_length = needle.length
        self.singular_threshold = scalar("singular_threshold", singular_threshold, 0.0, 1.0)
        self.resolution = scalar("resolution", resolution, 0.0, 1e-3, low_open=True)
        if roll_joint is not None and not 0 <= roll_joint < n:
            raise InvalidInputError("roll_joint", roll_joint, f"a joint index in [0, {n - 1}]")
        self.roll_joint = roll_joint
        self.active = tuple(i for i in range(n) if i != roll_joint)
        self.home = self.check_actuators(vector("home", home, n)).copy()
        self.home_actuators = self.home.copy()
        # the chain kernels' arrays and work array (`chain_kinematics`), frames of the last q
        self._A, self._ix = kin.pack(chain, needle.mount, needle.length, self.home, self.active)
        self._W = np.empty(kin.work_shape(n, len(self.active)))
        self._wkey: bytes = b""
        self._check_dofs(roll_joint)

    def _check_dofs(self, roll_joint: int | None) -> None:
        """Refuse a chain that cannot hold an RCM and reach a point (rank 6 over theta_ext)."""
        if roll_joint is not None:
            cols = np.hstack([self._point_jacobian(self.home, 0.0)[:3, [roll_joint]],
                              self._point_jacobian(self.home, 1.0)[:3, [roll_joint]]])  # fmt: skip
            if np.abs(cols).max() > 1e-9:
                raise InvalidInputError(
                    "roll_joint", roll_joint, "a joint turning the needle about its own axis"
                )
        m = len(self.active)
        tip_x = self.needle_point_jacobian(self.home, 1.0)[0:1]
        tip_x[0, -1] = 0.0  # lambda moves no tip
        J = np.vstack([tip_x, self.needle_angles_jacobian(self.home),
                       self.needle_point_jacobian(self.home, 0.5)])  # fmt: skip
        rank = int(np.linalg.matrix_rank(J, tol=1e-9))
        if m < 5 or rank < 6:
            raise InvalidInputError(
                f"robot {self.name!r}",
                f"{m} moving joints, task rank {rank} at home",
                "at least 5 joints that move the needle (task rank 6 with lambda) to hold an "
                "RCM and reach a point",
            )

    # --- actuators (the joints themselves) ---------------------------------------------
    def joints_from_actuators(self, s: FloatArray) -> FloatArray:
        """q = s."""
        return vector("s", s, self.chain.n).copy()

    def actuators_from_joints(self, q: FloatArray) -> FloatArray:
        """s = q."""
        return vector("q", q, self.chain.n).copy()

    def joint_rates(self, q: FloatArray) -> FloatArray:
        """dq/ds = I."""
        return np.eye(self.chain.n)

    def check_actuators(self, s: FloatArray) -> FloatArray:
        """Return s if every joint is within its travel, else raise ActuatorLimitError."""
        s = vector("s", s, self.chain.n)
        bad = (s < self.lower) | (s > self.upper)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise SliderLimitError(i, self.joint_names[i], float(s[i]), self.lower[i],
                                   self.upper[i], "joint", self.actuator_units[i])  # fmt: skip
        return s

    def actuator_margin(self, s: FloatArray) -> FloatArray:
        """Distance of each joint to its nearer limit (negative when beyond)."""
        s = vector("s", s, self.chain.n)
        return np.minimum(s - self.lower, self.upper - s)

    @property
    def kernel_arrays(self) -> tuple[FloatArray, NDArray[np.int64]]:
        """The chain kernels' arrays (A, ix) of this arm (`chain_kinematics.pack`)."""
        return self._A, self._ix

    # --- needle ---------------------------------------------------------------------------
    def _kernel_frames(self, q: FloatArray) -> FloatArray:
        """The chain kernels' work array holding the frames at q (checked: shape (n,), finite),
        computed once for the last q."""
        q = vector("q", q, self.chain.n)
        key = q.tobytes()
        if key != self._wkey:
            kin.frames(self._A, self._ix, q, self._W)
            self._wkey = key
        return self._W

    def needle_point(self, q: FloatArray, lam: float) -> FloatArray:
        """p(lambda) in [m] (eq. 3.7); lambda a finite number (the needle for lambda in [0, 1])."""
        W = self._kernel_frames(q)
        return np.array(kin.needle_point(self._A, self.chain.n, W, scalar("lam", lam)))

    def needle_axis(self, q: FloatArray) -> FloatArray:
        """Unit needle axis, base to tip."""
        return np.array(kin.needle_axis(self._A, self.chain.n, self._kernel_frames(q)))

    def tip(self, q: FloatArray) -> FloatArray:
        """Needle tip in [m]."""
        return self.needle_point(q, 1.0)

    def needle_base(self, q: FloatArray) -> FloatArray:
        """Needle base (lambda = 0) in [m]."""
        return self.needle_point(q, 0.0)

    def _point_jacobian(self, q: FloatArray, lam: float) -> FloatArray:
        """Geometric Jacobian (6, n) of p(lambda) over all joints (eqs. 2.9-2.11)."""
        return self.chain.jacobian(q, self.needle.point_local(scalar("lam", lam)))

    def needle_point_jacobian(self, q: FloatArray, lam: float) -> FloatArray:
        """d p(lambda) / d(q[active], lambda), (3, m + 1) (eq. 3.10)."""
        out = np.empty((3, len(self.active) + 1))
        W = self._kernel_frames(q)
        kin.point_jacobian(self._A, self._ix, W, scalar("lam", lam), out, 0)
        return out

    def tip_jacobian(self, q: FloatArray) -> FloatArray:
        """d p_tip / d(q[active], lambda), (3, m + 1), zero lambda column."""
        J = self.needle_point_jacobian(q, 1.0)
        J[:, -1] = 0.0
        return J

    def tool_pose(self, q: FloatArray) -> FloatArray:
        """(4, 4) pose of the needle base frame (the mount) in the world: the end frame the
        chain kernels computed (`chain_kinematics.frames`) times the mount."""
        W, e = self._kernel_frames(q), 4 * self.chain.n
        end = np.eye(4)
        end[:3, :] = W[e : e + 3, :4]
        out: FloatArray = end @ self.needle.mount
        return out

    def tool_jacobian(self, q: FloatArray) -> FloatArray:
        """Geometric Jacobian (6, n) of the needle base frame over all joints."""
        return self._point_jacobian(q, 0.0)

    def needle_angular_jacobian(self, q: FloatArray) -> FloatArray:
        """Angular velocity of the needle per (q[active], lambda), (3, m + 1)."""
        out = np.empty((3, len(self.active) + 1))
        kin.angular_jacobian(self._A, self._ix, self._kernel_frames(q), out, 0)
        return out

    def needle_angles_jacobian(self, q: FloatArray) -> FloatArray:
        """Exact d(phi, psi) / d(q[active], lambda), (2, m + 1)."""
        out = np.empty((2, len(self.active) + 1))
        kin.angle_rows(self._A, self._ix, self._kernel_frames(q), False, out, 0)
        return out

    # --- singularities --------------------------------------------------------------------
    def singularity_measure(self, q: FloatArray) -> float:
        """Inverse condition number of M = [J_tip / l; N J_omega] over the active joints, in
        [0, 1]: zero exactly where the needle loses a direction of motion (N: the two normals to
        it). The square roots of the extreme eigenvalues of M M^T (`chain_singular`)."""
        W = self._kernel_frames(q)
        return float(sing.singularity_measure(self._A, self._ix, W))

    def singular_values(self, q: FloatArray) -> FloatArray:
        """The singular terms' values (1,) without their gradient (the measure)."""
        return np.array([self.singularity_measure(q)])

    def smallest_singular_values(self, Q: FloatArray) -> FloatArray:
        """The smallest singular term (the measure) at each row of Q (N, n), one compiled call
        (`chain_singular.measures`)."""
        Q = np.ascontiguousarray(array("Q", Q, 2))
        if Q.shape[1] != self.chain.n:
            raise InvalidInputError("Q", Q, f"shape (N, {self.chain.n}), got shape {Q.shape}")
        out = np.empty(len(Q))
        sing.measures(self._A, self._ix, Q, np.empty_like(self._W), out)
        return out

    def singular_terms(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """The measure kappa = s_min / s_max of M = [J_tip / l; N J_omega] (1,) and its exact
        gradient (1, n), zero on held joints (`chain_singular.singular_terms`)."""
        W = self._kernel_frames(q)
        grad = np.zeros((1, self.chain.n))
        g = np.empty(len(self.active))
        kappa = sing.singular_terms(self._A, self._ix, W, g)
        grad[0, list(self.active)] = g
        return np.array([kappa]), grad

    def check_singularity(self, q: FloatArray, threshold: float | None = None) -> None:
        """Raise SingularPoseError if the measure is below the threshold (in [0, 1])."""
        if threshold is not None and (threshold.__class__ is not float or not 0 <= threshold <= 1):
            scalar("threshold", threshold, 0.0, 1.0)
        thr = self.singular_threshold if threshold is None else float(threshold)
        m = self.singularity_measure(q)
        if m < thr:
            raise SingularPoseError(np.asarray(q), m, thr, "inverse condition number")

    def needle_pose(
        self, tip: FloatArray, phi: float, psi: float, seed: FloatArray | None = None
    ) -> FloatArray:
        """Joints putting the tip at `tip` [m] with needle angles (phi, psi) [rad]: Newton's
        method (minimum-norm steps, `chain_pose.needle_pose`) on (tip, phi, psi) over the active
        joints from `seed` (default home), at most IK_ITERATIONS steps; travel is not checked
        here. phi and psi
        lie in [-pi, pi] (InvalidInputError otherwise)."""
        phi = scalar("phi", phi, -np.pi, np.pi)
        psi = scalar("psi", psi, -np.pi, np.pi)
        q = (self.home if seed is None else vector("seed", seed, self.chain.n)).copy()
        goal = np.array([*vector("tip", tip, 3), phi, psi])
        n = self.chain.n
        W = np.empty(kin.work_shape(n, len(self.active)))
        if chain_pose.needle_pose(self._A, self._ix, W, goal[:3], phi, psi, q, IK_ITERATIONS,
                                  IK_TOLERANCE) >= 0:  # fmt: skip
            return q
        err = W[4 * (n + 1) + 2 * kin.ROWS + kin.E, :5]  # the last check's error
        distance = float(np.linalg.norm(goal[:3] - self.chain.base[:3, 3]))
        raise UnreachableTargetError(
            f"no joints of {self.name} put the tip at {np.round(1e3 * goal[:3], 3).tolist()} mm "
            f"with needle angles ({phi:.4g}, {psi:.4g}) rad (Newton residual "
            f"{np.abs(err).max():.3g} after {IK_ITERATIONS} steps; the point lies "
            f"{distance:.3f} m from the arm's base, which reaches at most {self.reach:.3f} m)"
        )

    @property
    def reach(self) -> float:
        """An upper bound in [m] on the distance from the base to the tip: the lengths of the
        joint origins plus the needle's (prismatic travel added)."""
        links = float(np.linalg.norm(self.chain.origins[:, :3, 3], axis=1).sum())
        travel = float(np.abs(np.where(self.chain.prismatic, np.maximum(
            np.abs(self.lower), np.abs(self.upper)), 0.0)).sum())  # fmt: skip
        tip = float(np.linalg.norm(self.chain.tip[:3, 3]))
        return links + travel + tip + float(np.linalg.norm(self.needle.point_local(1.0)))
