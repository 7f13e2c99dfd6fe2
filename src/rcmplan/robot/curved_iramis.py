"""Compiled curved-needle kinematics of iRAM!S in closed form: the needle base frame, the tip on
the arc, X_c and J_c (the implementation of `rcmplan.robot.curved.CurvedTipRobot` on `Iramis`;
its steps are `rcmplan.control.curved_step`'s).

Parameters travel as the iRAM!S kernels' vector P (`rcmplan.robot.iramis_kernels.PARAMS`) followed
by the arc's end in the needle base frame (x, z) [m] (`params`: the arc lies in the frame's x-z
plane). The base frame has the tip frame's axes (eq. 2.7) at the needle base p(0): its z is the
shaft axis a, its x the bend direction b. theta_ext = (q0..q5, lambda): the roll q5 joins the
active joints. The base frame's geometric Jacobian: J_v = d p(0) / d(q0..q4) (eq. 3.10) and 0
for q5; J_w = e_y for q1, (sin q1, 0, cos q1) for q3, a for q5 (`Iramis.tool_jacobian`).

On iRAM!S the roll is q5 itself (rho = q5 wrapped to [-pi, pi): the bend direction is the tip
frame's x, `rcmplan.robot.needle.roll_from_axes`). The kernels the loop calls each iteration
are inlined into it (`inline="always"`): a call costs about as much as their bodies. Imports
numba.
"""

from __future__ import annotations

import math

import numpy as np

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.robot import curved_block as ck
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


@njit(cache=True, borrows=True)
def jacobian(P: FloatArray, q: FloatArray, tr: tuple, lam: float, pose: bool, C: FloatArray,
             c: int, w: FloatArray) -> None:  # fmt: skip
    """J_c (7, 7) into the work block at rows c.. of C (`curved_block`)."""
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


@njit(cache=True)
def task_jacobian(P: FloatArray, q: FloatArray, lam: float, pose: bool, x: FloatArray,
                  C: FloatArray) -> None:  # fmt: skip
    """X_c into x (7,) and J_c into rows ck.J.. of the work block C at (q, lambda)."""
    tr, w = trig(q), np.empty(3)
    task(P, q, tr, lam, pose, x, w)
    jacobian(P, q, tr, lam, pose, C, 0, w)


@njit(cache=True)
def needle_frames(P: FloatArray, Q: FloatArray, out: FloatArray) -> None:
    """For each joints row of Q (R, 6): the needle base p(0), the shaft's end p(1), the shaft
    axis a and the bend direction b into out[r] (4, 3), [m] and unit vectors."""
    w = np.empty(3)
    for r in range(Q.shape[0]):
        tr = trig(Q[r])
        o, a, b, _ = frame(P, Q[r], tr, w)
        point(P, Q[r], tr, 1.0, out[r, 1])
        for i in range(3):
            out[r, 0, i], out[r, 2, i], out[r, 3, i] = o[i], a[i], b[i]
