"""Newton's method on a serial arm's needle pose, compiled: `SerialArm.needle_pose` and the
compiled target screens (`rcmplan.compiled.chain_checks`) call it. The layout of W is
`chain_kinematics`'s."""

from __future__ import annotations

import math

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.linalg import damped, square
from rcmplan.robot.chain_kinematics import (
    ROWS,
    E,
    F,
    IntArray,
    Z,
    angle_rows,
    frames,
    needle_axis,
    needle_point,
    point_jacobian,
)
from rcmplan.robot.needle import axis_angles


@njit(cache=True)
def needle_pose(A: FloatArray, ix: IntArray, W: FloatArray, tip: FloatArray, phi: float,
                psi: float, q: FloatArray, max_it: int, tol: float) -> int:  # fmt: skip
    """Joints q putting the tip at `tip` [m] with needle angles (phi, psi) [rad], from the seed
    q (updated in place): Newton's method with minimum-norm steps on (tip, phi, psi) over the
    active joints (`linalg.square`, `linalg.damped`), angle errors wrapped to [-pi, pi).
    Returns the steps taken when every error is within tol, -1 when max_it checks fail (the
    last error then in W's row E)."""
    n, m = ix[0], ix[1]
    o = 4 * (n + 1)
    J, v = W[o:], o + 2 * ROWS
    err, dq = W[v + E], W[v + Z]
    for it in range(max_it):
        frames(A, ix, q, W)
        px, py, pz = needle_point(A, n, W, 1.0)
        ax, ay, az = needle_axis(A, n, W)
        err[0], err[1], err[2] = tip[0] - px, tip[1] - py, tip[2] - pz
        phi_now, psi_now = axis_angles(ax, ay, az)
        err[3], err[4] = phi - phi_now, psi - psi_now
        within = True  # every |error| <= tol (False for NaN)
        for i in range(5):
            if i >= 3:
                err[i] = (err[i] + math.pi) % (2.0 * math.pi) - math.pi
            within &= abs(err[i]) <= tol
        if within:
            return it
        point_jacobian(A, ix, W, 1.0, J, 0)
        angle_rows(A, ix, W, False, J, 3)
        for i in range(5):  # the right-hand side, err kept
            W[v + F, i] = err[i]
        if m == 5:
            square(W, o, 5, o + ROWS, v + F, dq)
        else:
            damped(W, o, 5, m, 0.0, o + ROWS, v + F, dq)
        for j in range(m):
            q[ix[2 + n + j]] += dq[j]
    return -1
