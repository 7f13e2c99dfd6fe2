"""The kinematics of iRAM!S in closed form, as numba kernels: the one definition that the
`Iramis` model calls from Python and the compiled loops call from compiled code.

Parameters travel as one float64 array P (`PARAMS`, built by `Iramis`): link lengths l1..l6
[m], PCJM slider spacing d [m], slider travel lower (6,) and upper (6,) [m, rad for q5]. Joint
vectors q are (q0..q5) [m, rad]; slider vectors s are (L1, L2, L3, L4, L5, q5). Kernels write
into output arrays given to them (no allocation in compiled code).
"""

from __future__ import annotations

import math

from rcmplan._jit import njit
from rcmplan._validate import FloatArray

PARAMS = ("l1", "l2", "l3", "l4", "l5", "l6", "d", "lower[6]", "upper[6]")
LOWER, UPPER = 7, 13
HALF_PI = 0.5 * math.pi


@njit(cache=True, borrows=True)
def pcjm_joints(d: float, L1: float, L2: float) -> tuple[float, float]:
    """(q_lin [m], q_rot [rad]) of one PCJM from its sliders (L1, L2) [m] (eqs. 2.1, 2.2)."""
    return 0.5 * (L1 + L2), math.atan((L2 - L1) / d)


@njit(cache=True, borrows=True)
def pcjm_sliders(d: float, q_lin: float, q_rot: float) -> tuple[float, float]:
    """(L1, L2) [m] of one PCJM from (q_lin [m], q_rot [rad]), |q_rot| < pi/2: eqs. 2.1 and
    2.2 inverted exactly (eq. 2.3 of the thesis has the sign of tan q_rot wrong)."""
    half = 0.5 * d * math.tan(q_rot)
    return q_lin - half, q_lin + half


@njit(cache=True, borrows=True)
def joints_from_actuators(P: FloatArray, s: FloatArray, q: FloatArray) -> None:
    """q from s through both PCJMs (eqs. 2.1, 2.2), written into q (6,)."""
    q[0], q[1] = pcjm_joints(P[6], s[0], s[1])
    q[2], q[3] = pcjm_joints(P[6], s[2], s[3])
    q[4] = s[4]
    q[5] = s[5]


@njit(cache=True, borrows=True)
def actuators_from_joints(P: FloatArray, q: FloatArray, s: FloatArray) -> bool:
    """s from q (inverse PCJM maps) into s (6,); False if q is not finite or |q1|, |q3| >= pi/2."""
    for i in range(6):
        if not math.isfinite(q[i]):
            return False
    if abs(q[1]) >= HALF_PI or abs(q[3]) >= HALF_PI:
        return False
    s[0], s[1] = pcjm_sliders(P[6], q[0], q[1])
    s[2], s[3] = pcjm_sliders(P[6], q[2], q[3])
    s[4] = q[4]
    s[5] = q[5]
    return True


@njit(cache=True, borrows=True)
def first_beyond_travel(P: FloatArray, s: FloatArray) -> int:
    """Index of the first slider outside its travel, or -1."""
    for i in range(6):
        if s[i] < P[LOWER + i] or s[i] > P[UPPER + i]:
            return i
    return -1


@njit(cache=True, borrows=True)
def trig(q: FloatArray) -> tuple[float, float, float, float]:
    """(cos q1, sin q1, cos q3, sin q3): computed once per configuration, passed as `tr`."""
    return math.cos(q[1]), math.sin(q[1]), math.cos(q[3]), math.sin(q[3])


@njit(cache=True, borrows=True)
def point(P: FloatArray, q: FloatArray, tr: tuple, lam: float, out: FloatArray) -> None:
    """p(lambda) in [m], base frame (eqs. 2.7, 3.7), written into out (3,); tr = trig(q)."""
    c1, s1, c3, s3 = tr
    w = q[4] + lam * P[5]
    out[0] = P[1] * s1 - c1 * c3 * w - P[4] * c1 * s3
    out[1] = P[2] + P[3] + q[2] - s3 * w + P[4] * c3
    out[2] = P[0] + q[0] + P[1] * c1 + s1 * c3 * w + P[4] * s1 * s3


@njit(cache=True, borrows=True)
def singular_measure(c1: float, c3: float) -> float:
    """min(|cos q1|, |cos q3|) from c1 = cos q1, c3 = cos q3 (`trig`'s tr[0], tr[2]): zero
    exactly on the singular set of J_a and J_0^5 (NOTES.md)."""
    return min(abs(c1), abs(c3))


@njit(cache=True, borrows=True)
def pose_joints(P: FloatArray, phi: float, psi: float, tip: FloatArray, q: FloatArray) -> None:
    """Joints (q5 = 0) putting the tip at `tip` (3,) [m] with needle angles (phi, psi) [rad]
    into q (6,): phi = q1, psi = q3, then w = q4 + l6 from the x row of eq. 2.7 (`point` at
    lambda = 1), q2 from its y row and q0 from its z row. Needs cos phi cos psi != 0."""
    c1, s1, c3, s3 = math.cos(phi), math.sin(phi), math.cos(psi), math.sin(psi)
    w = (P[1] * s1 - P[4] * c1 * s3 - tip[0]) / (c1 * c3)  # x row
    q[0] = tip[2] - (P[0] + P[1] * c1 + s1 * c3 * w + P[4] * s1 * s3)  # z row
    q[1], q[3], q[4], q[5] = phi, psi, w - P[5], 0.0
    q[2] = tip[1] - (P[2] + P[3] - s3 * w + P[4] * c3)  # y row


@njit(cache=True, borrows=True)
def needle_point(P: FloatArray, q: FloatArray, lam: float, out: FloatArray) -> None:
    """p(lambda) in [m] into out (3,)."""
    point(P, q, trig(q), lam, out)


@njit(cache=True, borrows=True)
def point_jacobian(
    P: FloatArray, q: FloatArray, tr: tuple, lam: float, J: FloatArray, r: int
) -> None:
    """d p(lambda) / d(q0..q4, lambda) (eq. 3.10) into rows r..r+2 of J (n, 6)."""
    c1, s1, c3, s3 = tr
    l2, l5, l6 = P[1], P[4], P[5]
    w = q[4] + lam * l6
    k = s3 * w - l5 * c3
    J[r, 0] = 0.0
    J[r, 1] = l2 * c1 + s1 * c3 * w + l5 * s1 * s3
    J[r, 2] = 0.0
    J[r, 3] = c1 * k
    J[r, 4] = -c1 * c3
    J[r, 5] = -l6 * c1 * c3
    J[r + 1, 0] = 0.0
    J[r + 1, 1] = 0.0
    J[r + 1, 2] = 1.0
    J[r + 1, 3] = -c3 * w - l5 * s3
    J[r + 1, 4] = -s3
    J[r + 1, 5] = -l6 * s3
    J[r + 2, 0] = 1.0
    J[r + 2, 1] = c1 * c3 * w - l2 * s1 + l5 * c1 * s3
    J[r + 2, 2] = 0.0
    J[r + 2, 3] = -s1 * k
    J[r + 2, 4] = s1 * c3
    J[r + 2, 5] = l6 * s1 * c3


@njit(cache=True, borrows=True)
def tip_jacobian(P: FloatArray, q: FloatArray, tr: tuple, J: FloatArray, r: int) -> None:
    """d p_tip / d theta_ext with a zero lambda column into rows r..r+2 of J."""
    point_jacobian(P, q, tr, 1.0, J, r)
    J[r, 5] = 0.0
    J[r + 1, 5] = 0.0
    J[r + 2, 5] = 0.0


@njit(cache=True, borrows=True)
def needle_axis(q: FloatArray, a: FloatArray) -> None:
    """The unit needle axis a(q) = (-cos q1 cos q3, -sin q3, sin q1 cos q3) into a (3,)."""
    c1, s1, c3, s3 = trig(q)
    a[0] = -c1 * c3
    a[1] = -s3
    a[2] = s1 * c3
