"""The iRAM!S eye-surgery robot of the reference thesis: Table 2.1 in SI units.

Joint vector q = (q0..q5): q0, q2, q4 prismatic [m], q1, q3, q5 revolute [rad].
Slider vector s = (L1, L2, L3, L4, L5, q5): PCJM 1 drives (q0, q1), PCJM 2 drives (q2, q3),
L5 is q4 and q5 is driven directly.

The needle runs from p_base (frame 5 origin with l6 = 0) to p_tip (frame 6 origin); its axis
is a(q) = (-cos q1 cos q3, -sin q3, sin q1 cos q3) and p_tip - p_base = l6 a(q).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rcmplan._validate import F64, FloatArray, array, instance, scalar, vector, workspace_point
from rcmplan.exceptions import (
    InvalidInputError,
    SingularPoseError,
    SliderLimitError,
    UnreachableTargetError,
)
from rcmplan.robot import iramis_kernels as kernels
from rcmplan.robot.dh import DHChain, DHLink
from rcmplan.robot.iramis_checks import check_finite, checked_parameters, invalid_point, joints
from rcmplan.robot.iramis_checks import lam as checked_lam
from rcmplan.robot.pcjm import Pcjm

SLIDER_NAMES = ("L1", "L2", "L3", "L4", "L5", "q5")
JOINT_NAMES = ("q0", "q1", "q2", "q3", "q4", "q5")
MM = 1e-3


@dataclass(frozen=True)
class Assumption:
    """A model parameter with its value, unit and where it comes from."""

    name: str
    value: str
    unit: str
    source: str


@dataclass(frozen=True)
class IramisParameters:
    """Geometry and limits of the iRAM!S robot, SI units.

    Attributes:
        l1..l6: Link lengths of Table 2.1 in [m].
        pcjm_spacing: Slider spacing d of both PCJMs in [m] (assumed).
        slider_lower, slider_upper: Travel of (L1, L2, L3, L4, L5, q5) in [m] and [rad] (assumed).
        slider_speed: Maximum speed of each slider in [m/s] and [rad/s] (assumed).
        slider_resolution: Smallest slider step in [m] (assumed).
        singular_threshold: Smallest accepted min(|cos q1|, |cos q3|).
    """

    l1: float = 71.0 * MM
    l2: float = 33.5 * MM
    l3: float = -23.0 * MM
    l4: float = 71.0 * MM
    l5: float = 28.0 * MM
    l6: float = 97.0 * MM
    pcjm_spacing: float = 30.0 * MM
    slider_lower: tuple[float, ...] = (-40 * MM, -40 * MM, -40 * MM, -40 * MM, -10 * MM, -math.pi)
    slider_upper: tuple[float, ...] = (40 * MM, 40 * MM, 40 * MM, 40 * MM, 50 * MM, math.pi)
    slider_speed: tuple[float, ...] = (10 * MM, 10 * MM, 10 * MM, 10 * MM, 10 * MM, 1.0)
    slider_resolution: float = 1e-9
    singular_threshold: float = 0.1
    sources: dict[str, str] = field(
        default_factory=lambda: {
            "l1..l6": "thesis Table 2.1 (CAD model)",
            "pcjm_spacing": "assumed",
            "slider travel": "assumed",
            "slider speed": "assumed (piezo stick-slip stages, 1-20 mm/s typical)",
            "slider resolution": "assumed (stick-slip stages resolve nm in scanning mode)",
            "singular_threshold": "assumed (cos 84.3 deg)",
        },
        compare=False,
    )

    def __post_init__(self) -> None:
        for name, value in checked_parameters(self).items():
            object.__setattr__(self, name, value)


class Iramis:
    """The iRAM!S robot: kinematics in closed form (eq. 2.7, 2.12) and as a DH chain.

    A `RobotModel` whose actuators are the sliders s and whose controller moves q0..q4 and
    lambda (the roll q5 moves no point of the straight needle).

    Args:
        params: Geometry and limits; the thesis values and stated assumptions by default.
    """

    name: str = "iramis"
    joint_names: tuple[str, ...] = JOINT_NAMES
    actuator_names: tuple[str, ...] = SLIDER_NAMES
    actuator_units: tuple[str, ...] = ("m", "m", "m", "m", "m", "rad")
    active: tuple[int, ...] = (0, 1, 2, 3, 4)
    roll_joint: int = 5
    needle_kind: str = "straight"

    def __init__(self, params: IramisParameters | None = None) -> None:
        what = "IramisParameters or None (the thesis values)"
        params = IramisParameters() if params is None else params
        self.params: IramisParameters = instance("params", params, IramisParameters, what)
        p = self.params
        self.pcjm = Pcjm(p.pcjm_spacing)
        self.lower = np.array(p.slider_lower, dtype=float)
        self.upper = np.array(p.slider_upper, dtype=float)
        self.speed = np.array(p.slider_speed, dtype=float)
        self.home_actuators = np.zeros(6)
        self.home = np.zeros(6)
        self.needle_length: float = p.l6
        self.resolution: float = p.slider_resolution
        self.singular_threshold: float = p.singular_threshold
        head = [p.l1, p.l2, p.l3, p.l4, p.l5, p.l6, p.pcjm_spacing]  # `kernels.PARAMS`
        self.P = np.array([*head, *p.slider_lower, *p.slider_upper], dtype=np.float64)

    # --- DH tables -------------------------------------------------------------------------
    def dh_links(self, l6: float | None = None) -> list[DHLink]:
        """Table 2.1 as standard-DH links (theta, d offsets, a, alpha); l6 in [0, 1] m (0: the
        needle base's chain)."""
        p = self.params
        l6 = p.l6 if l6 is None else scalar("l6", l6, 0.0, 1.0)
        h = 0.5 * math.pi
        return [
            DHLink("prismatic", 0.0, p.l1, 0.0, -h),
            DHLink("revolute", -h, p.l3, p.l2, 0.0),
            DHLink("prismatic", h, p.l4, 0.0, h),
            DHLink("revolute", h, 0.0, p.l5, -h),
            DHLink("prismatic", 0.0, l6, 0.0, 0.0),
            DHLink("revolute", 0.0, 0.0, 0.0, 0.0),
        ]

    @property
    def chain(self) -> DHChain:
        """The robot as a generic standard-DH chain (tip frame = frame 6)."""
        return DHChain(self.dh_links())

    # --- forward kinematics (closed form) -----------------------------------------------------
    def forward_kinematics(self, q: Sequence[float] | FloatArray) -> FloatArray:
        """T_0^6, the (4, 4) pose of the needle tip frame in the base frame (eq. 2.7)."""
        q = vector("q", q, 6)
        c1, s1, c3, s3 = math.cos(q[1]), math.sin(q[1]), math.cos(q[3]), math.sin(q[3])
        c5, s5 = math.cos(q[5]), math.sin(q[5])
        T = np.eye(4)
        T[:3, :3] = [
            [-s1 * s5 - c1 * c5 * s3, c1 * s3 * s5 - c5 * s1, -c1 * c3],
            [c3 * c5, -c3 * s5, -s3],
            [c5 * s1 * s3 - c1 * s5, -c1 * c5 - s1 * s3 * s5, c3 * s1],
        ]
        T[:3, 3] = self.needle_point(q, 1.0)
        return T

    def needle_axis(self, q: Sequence[float] | FloatArray) -> FloatArray:
        """Unit needle axis a(q) from base to tip, base frame: a(q) = (-cos q1 cos q3, -sin q3,
        sin q1 cos q3).

        Raises InvalidInputError unless q is 6 finite numbers."""
        a = np.empty(3)
        kernels.needle_axis(joints(q), a)
        if not math.isfinite(a[0] + a[1] + a[2]):
            check_finite(a[0] + a[1] + a[2], q)
        return a

    def needle_point(self, q: Sequence[float] | FloatArray, lam: float) -> FloatArray:
        """p(lambda) = p_base + lambda (p_tip - p_base) in [m], base frame (eqs. 2.7, 3.7).

        Any finite lambda is valid: the point on the needle's line, the needle itself for lambda
        in [0, 1] (the RCM search `closest_point` keeps lambda there).

        Raises InvalidInputError unless q is 6 finite numbers and lam a finite number. (The
        check is the result's finiteness: the controller calls this thousands of times.)
        """
        out = np.empty(3)
        try:
            kernels.needle_point(
                self.P, joints(q), lam if lam.__class__ is float else checked_lam(lam), out
            )
            # every input but the roll q5 (a sum would warn where an inf meets a -inf)
            ok = math.isfinite(out[0]) and math.isfinite(out[1]) and math.isfinite(out[2])
        except (TypeError, ValueError, IndexError, OverflowError):
            ok = False
        if not ok:
            invalid_point(q, lam)
        return out

    def tip(self, q: Sequence[float] | FloatArray) -> FloatArray:
        """Needle tip position O_6(q) in [m]."""
        return self.needle_point(q, 1.0)

    def needle_base(self, q: Sequence[float] | FloatArray) -> FloatArray:
        """Needle base position (lambda = 0) in [m]."""
        return self.needle_point(q, 0.0)

    # --- Jacobians ------------------------------------------------------------------------
    def needle_point_jacobian(self, q: Sequence[float] | FloatArray, lam: float) -> FloatArray:
        """d p(lambda) / d(q0, q1, q2, q3, q4, lambda), a (3, 6) array (eq. 3.10 with J_0^5)."""
        J = np.empty((3, 6))
        q_arr = joints(q)
        lam_f = lam if lam.__class__ is float else checked_lam(lam)
        kernels.point_jacobian(self.P, q_arr, kernels.trig(q_arr), lam_f, J, 0)
        if not math.isfinite(J[0, 1]):  # NaN or inf in q1, q3, q4 or lambda reach this entry
            invalid_point(q, lam)
        return J

    def jacobian(self, q: Sequence[float] | FloatArray) -> FloatArray:
        """Geometric Jacobian J_0^6 (6, 6) at the tip, base frame (eq. 2.12)."""
        q = vector("q", q, 6)
        J = np.zeros((6, 6))
        J[:3, :5] = self.needle_point_jacobian(q, 1.0)[:, :5]
        J[3:, 1] = (0.0, 1.0, 0.0)  # z_1 of frame 1
        J[3:, 3] = (math.sin(q[1]), 0.0, math.cos(q[1]))  # z_3
        J[3:, 5] = self.needle_axis(q)  # z_5: the needle axis
        return J

    def tip_jacobian(self, q: Sequence[float] | FloatArray) -> FloatArray:
        """d p_tip / d(q0..q4, lambda), (3, 6), zero lambda column."""
        J = self.needle_point_jacobian(q, 1.0)
        J[:, -1] = 0.0
        return J

    def tool_pose(self, q: Sequence[float] | FloatArray) -> FloatArray:
        """(4, 4) pose of the needle base frame: the tip frame's axes (eq. 2.7) at the base."""
        T = self.forward_kinematics(q)
        T[:3, 3] = self.needle_base(q)
        return T

    def tool_jacobian(self, q: Sequence[float] | FloatArray) -> FloatArray:
        """Geometric Jacobian (6, 6) of the needle base frame over q0..q5 (eq. 2.12 with
        l6 = 0; q5 turns about the needle axis, so it moves no point of it)."""
        J = self.jacobian(q)
        J[:3, :5] = self.needle_point_jacobian(q, 0.0)[:, :5]
        J[:3, 5] = 0.0
        return J

    def needle_angular_jacobian(self, q: Sequence[float] | FloatArray) -> FloatArray:
        """Angular velocity of the needle per (q0..q4, lambda), (3, 6): z_1 dq1 + z_3 dq3."""
        q = joints(q)
        if not math.isfinite(q[1]):
            check_finite(q[1], q)
        J = np.zeros((3, 6))
        J[1, 1] = 1.0  # z_1 of frame 1
        J[0, 3], J[2, 3] = math.sin(q[1]), math.cos(q[1])  # z_3
        return J

    def needle_angles_jacobian(self, q: Sequence[float] | FloatArray) -> FloatArray:
        """d(phi, psi)/d(q0..q4, lambda): exactly the rows e_q1 and e_q3, (2, 6)."""
        J = np.zeros((2, 6))
        J[0, 1] = 1.0
        J[1, 3] = 1.0
        return J

    def jacobian_05(self, q: Sequence[float] | FloatArray) -> FloatArray:
        """J_0^5 (6, 5): the tip Jacobian without the needle roll q5 (eq. 2.13)."""
        return self.jacobian(q)[:, :5]

    def slider_jacobian(self, s: Sequence[float] | FloatArray) -> FloatArray:
        """Geometric tip Jacobian w.r.t. the sliders s, (6, 6): J_0^6(q(s)) dq/ds."""
        s = vector("s", s, 6)
        return self.jacobian(self.joints_from_actuators(s)) @ self.joints_from_actuators_jacobian(s)

    # --- sliders <-> joints -------------------------------------------------------------------
    def joints_from_actuators(self, s: Sequence[float] | FloatArray) -> FloatArray:
        """q = (q0..q5) from s = (L1, L2, L3, L4, L5, q5) (eqs. 2.1, 2.2 for each PCJM)."""
        s = vector("s", s, 6)
        q = np.empty(6)
        kernels.joints_from_actuators(self.P, s, q)
        return q

    def actuators_from_joints(self, q: Sequence[float] | FloatArray) -> FloatArray:
        """s = (L1, L2, L3, L4, L5, q5) from q (inverse of eqs. 2.1, 2.2; see pcjm.py).

        Raises PcjmAngleError when |q1| or |q3| is pi/2 or more (no slider pair realises it)."""
        q = vector("q", q, 6)
        s = np.empty(6)
        if not kernels.actuators_from_joints(self.P, q, s):
            i = 1 if abs(q[1]) >= 0.5 * math.pi else 3
            self.pcjm.sliders(q[i - 1], q[i])  # raises PcjmAngleError naming the pair
        return s

    def joints_from_actuators_jacobian(self, s: Sequence[float] | FloatArray) -> FloatArray:
        """dq/ds, a (6, 6) array."""
        s = joints(s, "s")
        if not math.isfinite(s[0] + s[1] + s[2] + s[3]):
            check_finite(s[0] + s[1] + s[2] + s[3], s, "s")
        D = np.eye(6)
        D[0:2, 0:2] = self.pcjm.joints_jacobian(s[0], s[1])
        D[2:4, 2:4] = self.pcjm.joints_jacobian(s[2], s[3])
        return D

    def joint_rates(self, q: Sequence[float] | FloatArray) -> FloatArray:
        """dq/ds (6, 6) at joints q: d q_rot / d L2 = -d q_rot / d L1 = cos^2(q_rot) / d."""
        q = joints(q)
        if not math.isfinite(q[1] + q[3]):
            check_finite(q[1] + q[3], q)
        D = np.eye(6)
        d = self.params.pcjm_spacing
        for i in (0, 2):
            g = math.cos(q[i + 1]) ** 2 / d
            D[i, i] = D[i, i + 1] = 0.5
            D[i + 1, i], D[i + 1, i + 1] = -g, g
        return D

    def actuators_from_joints_jacobian(self, q: Sequence[float] | FloatArray) -> FloatArray:
        """ds/dq, a (6, 6) array; |q1|, |q3| below pi/2 (PcjmAngleError otherwise)."""
        q = joints(q)
        if not math.isfinite(q[1] + q[3]):
            check_finite(q[1] + q[3], q)
        D = np.eye(6)
        D[0:2, 0:2] = self.pcjm.sliders_jacobian(q[1])
        D[2:4, 2:4] = self.pcjm.sliders_jacobian(q[3])
        return D

    # --- limits and singularities --------------------------------------------------------
    def check_actuators(self, s: Sequence[float] | FloatArray) -> FloatArray:
        """Return s if every slider is within its travel, else raise SliderLimitError (the
        travel rule of the compiled loops: `iramis_kernels.first_beyond_travel`)."""
        s = vector("s", s, 6)
        i = kernels.first_beyond_travel(self.P, s)
        if i >= 0:
            raise SliderLimitError(i, SLIDER_NAMES[i], float(s[i]), self.lower[i], self.upper[i])
        return s

    def actuator_margin(self, s: Sequence[float] | FloatArray) -> FloatArray:
        """Distance of each slider to its nearer travel limit (negative when beyond)."""
        s = vector("s", s, 6)
        return np.minimum(s - self.lower, self.upper - s)

    @staticmethod
    def singularity_measure(q: Sequence[float] | FloatArray) -> float:
        """min(|cos q1|, |cos q3|): zero exactly on the singular set of J_a and J_0^5 (NOTES.md).

        Raises InvalidInputError unless q is 6 finite numbers."""
        q1, q3 = _angles(q)
        return float(kernels.singular_measure(math.cos(q1), math.cos(q3)))

    @staticmethod
    def singular_terms(q: Sequence[float] | FloatArray) -> tuple[FloatArray, FloatArray]:
        """(cos q1, cos q3) and their gradients (2, 6): both stay above the singular floor."""
        q1, q3 = _angles(q)
        grad = np.zeros((2, 6))
        grad[0, 1], grad[1, 3] = -math.sin(q1), -math.sin(q3)
        return np.array([math.cos(q1), math.cos(q3)]), grad

    @staticmethod
    def smallest_singular_values(Q: FloatArray) -> FloatArray:
        """min(cos q1, cos q3) at each row of joints Q (N, 6) (`singular_terms`' values)."""
        Q = array("Q", Q, 2)
        if Q.shape[1] != 6:
            raise InvalidInputError("Q", Q, f"shape (N, 6), got shape {Q.shape}")
        return np.minimum(np.cos(Q[:, 1]), np.cos(Q[:, 3]))

    def check_singularity(
        self, q: Sequence[float] | FloatArray, threshold: float | None = None
    ) -> None:
        """Raise SingularPoseError if the singularity measure is below the threshold."""
        if threshold is None:
            thr = self.params.singular_threshold
        elif threshold.__class__ is float and 0.0 <= threshold < 1.0:
            thr = threshold
        else:
            thr = scalar("threshold", threshold, 0.0, 1.0, high_open=True)
        m = self.singularity_measure(q)
        if m < thr:
            raise SingularPoseError(np.asarray(q), m, thr)

    def needle_pose(
        self, tip: FloatArray, phi: float, psi: float, seed: FloatArray | None = None
    ) -> FloatArray:
        """Joints (q5 = 0) putting the tip at `tip` [m] with needle angles (phi, psi) [rad]:
        phi = q1, psi = q3, then w = q4 + l6 from the x row of eq. 2.7, q2 from its y row and
        q0 from its z row. Raises UnreachableTargetError outside the non-singular angle range;
        travel is not checked. `seed` is not needed (closed form). InvalidInputError unless tip
        is 3 finite numbers within WORKSPACE_M of the base and phi, psi lie in [-pi, pi]."""
        tip = workspace_point("tip", tip)
        phi = scalar("phi", phi, -math.pi, math.pi)
        psi = scalar("psi", psi, -math.pi, math.pi)
        if seed is not None:
            vector("seed", seed, 6)
        thr = self.params.singular_threshold
        if kernels.singular_measure(math.cos(phi), math.cos(psi)) < thr:
            raise UnreachableTargetError(
                f"needle angles (phi, psi) = ({phi:.4g}, {psi:.4g}) rad leave the reach "
                f"|cos phi|, |cos psi| >= {thr:g}"
            )
        q = np.empty(6)
        kernels.pose_joints(self.P, phi, psi, tip, q)
        return q

    def assumptions(self) -> list[Assumption]:
        """Every model parameter with its source, thesis or assumed."""
        p = self.params
        mm = [f"{1e3 * v:g}" for v in (p.l1, p.l2, p.l3, p.l4, p.l5, p.l6)]
        lo, hi = self.lower, self.upper
        travel = ", ".join(
            f"{SLIDER_NAMES[i]} [{1e3 * lo[i]:g}, {1e3 * hi[i]:g}]" for i in range(5)
        )
        return [
            Assumption("l1..l6", ", ".join(mm), "mm", p.sources["l1..l6"]),
            Assumption(
                "PCJM spacing d", f"{1e3 * p.pcjm_spacing:g}", "mm", p.sources["pcjm_spacing"]
            ),
            Assumption("slider travel", travel, "mm", p.sources["slider travel"]),
            Assumption(
                "q5 travel", f"[{lo[5]:.4g}, {hi[5]:.4g}]", "rad", p.sources["slider travel"]
            ),
            Assumption(
                "slider speed", f"{1e3 * self.speed[0]:g}", "mm/s", p.sources["slider speed"]
            ),
            Assumption("q5 speed", f"{self.speed[5]:g}", "rad/s", p.sources["slider speed"]),
            Assumption(
                "slider resolution",
                f"{1e9 * p.slider_resolution:g}",
                "nm",
                p.sources["slider resolution"],
            ),
            Assumption(
                "singular threshold",
                f"{p.singular_threshold:g}",
                "",
                p.sources["singular_threshold"],
            ),
        ]


def _angles(q: Any) -> tuple[float, float]:
    """(q1, q3) of joints q as floats, InvalidInputError unless q is 6 numbers with q1 and q3
    finite (the singularity measure reads only these)."""
    if q.__class__ is not np.ndarray or q.dtype is not F64 or q.shape != (6,):
        q = vector("q", q, 6)
    q1, q3 = float(q[1]), float(q[3])
    if not math.isfinite(q1 + q3):
        check_finite(q1 + q3, q)
    return q1, q3
