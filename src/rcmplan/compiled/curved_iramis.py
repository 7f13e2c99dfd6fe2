"""Compiled curved-needle kinematics of iRAM!S in closed form: the needle base frame, the tip on
the arc, X_c and J_c, and the step (`rcmplan.robot.curved.CurvedTipRobot` on `Iramis`).

Parameters travel as the iRAM!S kernels' vector P (`rcmplan.compiled.kernels.PARAMS`) followed
by the arc's end in the needle base frame (x, z) [m] (`params`: the arc lies in the frame's x-z
plane). The base frame has the tip frame's axes (eq. 2.7) at the needle base p(0): its z is the
shaft axis a, its x the bend direction b. theta_ext = (q0..q5, lambda): the roll q5 joins the
active joints. The base frame's geometric Jacobian: J_v = d p(0) / d(q0..q4) (eq. 3.10) and 0
for q5; J_w = e_y for q1, (sin q1, 0, cos q1) for q3, a for q5 (`Iramis.tool_jacobian`).

On iRAM!S the roll is q5 itself (rho = q5 wrapped to [-pi, pi): the bend direction is the tip
frame's x, `rcmplan.robot.needle.roll_from_axes`), and J_c has structure, exact in exact
arithmetic, that the pinv step uses (`pinv_step`, as the straight needle's
`kernels.solve_augmented` uses J_a's): the roll row is e_q5; the prismatic q0, q2, q4 move the
tip and the RCM point alike (e_z, e_y, a) and turn nothing; the roll moves no RCM point; a turn
w moves the tip by w x (p_tip - p) more than the RCM point. The square system then splits into
one 3 x 3 system in (dq1, dq3, dlambda) (the tip rows minus the RCM rows) and substitutions.
The kernels the loop calls each iteration are inlined into it (`inline="always"`): a call costs
about as much as their bodies. Imports numba.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from rcmplan._validate import FloatArray
from rcmplan.compiled import curved_kernels as ck
from rcmplan.compiled.records import CURVED_PINV, CURVED_POSE
from rcmplan.robot.iramis_kernels import point, point_jacobian, trig

TIP_X, TIP_Z = 19, 20  # the arc's end (x, z) in the base frame, in P
ACTIVE = 6  # q0..q5


def params(P: FloatArray, tip_local: FloatArray) -> FloatArray:
    """P of the iRAM!S kernels followed by the arc's end (x, z) [m] in the base frame."""
    return np.array([*P, tip_local[0], tip_local[2]], dtype=np.float64)


@njit(cache=True, inline="always")
def axes(q: FloatArray, tr: tuple) -> tuple[tuple, tuple]:
    """(a, b): the shaft axis and the bend direction (columns 2 and 0 of eq. 2.7)."""
    c1, s1, c3, s3 = tr
    c5, s5 = math.cos(q[5]), math.sin(q[5])
    a = (-c1 * c3, -s3, s1 * c3)
    b = (-s1 * s5 - c1 * c5 * s3, c3 * c5, c5 * s1 * s3 - c1 * s5)
    return a, b


@njit(cache=True, inline="always")
def tip_of(P: FloatArray, o: tuple, a: tuple, b: tuple) -> tuple[float, float, float]:
    """The tip o + x b + z a in [m] (the arc's end (x, 0, z) in the base frame)."""
    x, z = P[TIP_X], P[TIP_Z]
    return (x * b[0] + z * a[0] + o[0], x * b[1] + z * a[1] + o[1],
            x * b[2] + z * a[2] + o[2])  # fmt: skip


@njit(cache=True, inline="always")
def frame(P: FloatArray, q: FloatArray, tr: tuple, w: FloatArray) -> tuple[tuple, tuple, tuple,
                                                                           tuple]:  # fmt: skip
    """(o, a, b, tip): the needle base p(0), the shaft axis, the bend direction and the tip;
    w (3,) is scratch."""
    point(P, q, tr, 0.0, w)
    o = (w[0], w[1], w[2])
    a, b = axes(q, tr)
    return o, a, b, tip_of(P, o, a, b)


@njit(cache=True, inline="always")
def task(P: FloatArray, q: FloatArray, tr: tuple, lam: float, pose: bool, x: FloatArray,
         w: FloatArray) -> None:  # fmt: skip
    """X_c = (p_tip, rho, p(lambda)) into x (7,), or with `pose` (p_tip, rho, p(0)); w (3,) is
    scratch."""
    o, _, _, tip = frame(P, q, tr, w)
    x[0], x[1], x[2] = tip
    x[3] = ck.wrap(q[5])
    if not pose:
        point(P, q, tr, lam, w)
        o = (w[0], w[1], w[2])
    x[4], x[5], x[6] = o


@njit(cache=True, inline="always")
def task_error(P: FloatArray, method: int, q: FloatArray, tr: tuple, lam: float,
               target: FloatArray, e: FloatArray, w: FloatArray) -> int:  # fmt: skip
    """The curved solver's error (7,) into e (the whole-pose task for CURVED_POSE); returns 7."""
    task(P, q, tr, lam, method == CURVED_POSE, e, w)
    ck.error(e, target, e)
    return ck.WIDTH


@njit(cache=True)
def jacobian(P: FloatArray, q: FloatArray, tr: tuple, lam: float, pose: bool, C: FloatArray,
             c: int, w: FloatArray) -> None:  # fmt: skip
    """J_c (7, 7) into the work block at rows c.. of C (`curved_kernels`)."""
    c1, s1 = tr[0], tr[1]
    o, a, _, tip = frame(P, q, tr, w)
    point_jacobian(P, q, tr, 0.0, C, c + ck.G)  # J_v over q0..q4 (its lambda column dropped)
    for i in range(3):
        C[c + ck.G + i, 5] = 0.0  # the roll moves no point of the shaft
        for j in range(ACTIVE):
            C[c + ck.G + 3 + i, j] = 0.0
    C[c + ck.G + 4, 1] = 1.0  # J_w: z_1 = e_y, z_3 = (sin q1, 0, cos q1), z_5 = a
    C[c + ck.G + 3, 3], C[c + ck.G + 5, 3] = s1, c1
    C[c + ck.G + 3, 5], C[c + ck.G + 4, 5], C[c + ck.G + 5, 5] = a
    if pose:
        p = o
    else:
        point(P, q, tr, lam, w)
        p = (w[0], w[1], w[2])
    ck.assemble(C, c, ACTIVE, o, tip, p, a, P[5], pose)


@njit(cache=True, inline="always")
def pinv_step(P: FloatArray, K: FloatArray, q: FloatArray, tr: tuple, lam: float,
              e: FloatArray, d: FloatArray, w: FloatArray, R: FloatArray) -> None:  # fmt: skip
    """d = J_c^-1 K e (7,) by J_c's structure (module docstring): dq5 from the roll row;
    (dq1, dq3, dlambda) from the tip rows minus the RCM rows (Cramer's rule); dq4, dq2, dq0
    from the RCM rows x, y, z, whose q1 and q3 columns are eq. 3.10's (into R, (3, 6))."""
    c1, s1 = tr[0], tr[1]
    o, a, _, tip = frame(P, q, tr, w)
    point(P, q, tr, lam, w)
    dx, dy, dz = tip[0] - w[0], tip[1] - w[1], tip[2] - w[2]  # p_tip - p(lambda)
    tx, ty, tz = tip[0] - o[0], tip[1] - o[1], tip[2] - o[2]  # p_tip - p(0)
    point_jacobian(P, q, tr, lam, R, 0)
    l6 = P[5]
    b = (K[0] * e[0], K[1] * e[1], K[2] * e[2], K[3] * e[3], K[4] * e[4], K[5] * e[5],
         K[6] * e[6])  # fmt: skip
    d[5] = b[3]
    # the tip rows minus the RCM rows: u1 dq1 + u3 dq3 + u6 dlambda = v
    u1 = (dz, 0.0, -dx)  # e_y x (p_tip - p)
    u3 = (-c1 * dy, c1 * dx - s1 * dz, s1 * dy)  # (sin q1, 0, cos q1) x (p_tip - p)
    u6 = (-l6 * a[0], -l6 * a[1], -l6 * a[2])
    t5 = (a[1] * tz - a[2] * ty, a[2] * tx - a[0] * tz, a[0] * ty - a[1] * tx)  # a x (p_tip - o)
    v = (b[0] - b[4] - t5[0] * d[5], b[1] - b[5] - t5[1] * d[5], b[2] - b[6] - t5[2] * d[5])
    c36 = (u3[1] * u6[2] - u3[2] * u6[1], u3[2] * u6[0] - u3[0] * u6[2],
           u3[0] * u6[1] - u3[1] * u6[0])  # fmt: skip
    cv6 = (v[1] * u6[2] - v[2] * u6[1], v[2] * u6[0] - v[0] * u6[2], v[0] * u6[1] - v[1] * u6[0])
    c3v = (u3[1] * v[2] - u3[2] * v[1], u3[2] * v[0] - u3[0] * v[2], u3[0] * v[1] - u3[1] * v[0])
    det = u1[0] * c36[0] + u1[1] * c36[1] + u1[2] * c36[2]
    d[1] = (v[0] * c36[0] + v[1] * c36[1] + v[2] * c36[2]) / det
    d[3] = (u1[0] * cv6[0] + u1[1] * cv6[1] + u1[2] * cv6[2]) / det
    d[6] = (u1[0] * c3v[0] + u1[1] * c3v[1] + u1[2] * c3v[2]) / det
    # the RCM rows: eq. 3.10's columns, 1 for q0 (z) and q2 (y), a for q4, l6 a for lambda
    d[4] = (b[4] - R[0, 1] * d[1] - R[0, 3] * d[3]) / R[0, 4] - l6 * d[6]
    d[2] = b[5] - R[1, 1] * d[1] - R[1, 3] * d[3] - R[1, 4] * (d[4] + l6 * d[6])
    d[0] = b[6] - R[2, 1] * d[1] - R[2, 3] * d[3] - R[2, 4] * (d[4] + l6 * d[6])


@njit(cache=True, inline="always")
def step(P: FloatArray, method: int, K: FloatArray, damping: float, q: FloatArray, tr: tuple,
         lam: float, e: FloatArray, C: FloatArray, d: FloatArray,
         w: FloatArray) -> None:  # fmt: skip
    """The curved solver's step d = (dq0..dq5, dlambda) (7,) for its error e; C is the work
    block (rows 0..)."""
    if method == CURVED_PINV:
        pinv_step(P, K, q, tr, lam, e, d, w, C)
        return
    jacobian(P, q, tr, lam, method == CURVED_POSE, C, 0, w)
    ck.step(C, 0, method, ACTIVE, K, damping, P[5], e, d)


@njit(cache=True)
def task_jacobian(P: FloatArray, q: FloatArray, lam: float, pose: bool, x: FloatArray,
                  C: FloatArray) -> None:  # fmt: skip
    """X_c into x (7,) and J_c into rows ck.J.. of the work block C at (q, lambda)."""
    tr, w = trig(q), np.empty(3)
    task(P, q, tr, lam, pose, x, w)
    jacobian(P, q, tr, lam, pose, C, 0, w)
