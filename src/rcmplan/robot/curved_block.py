"""The curved needle's work block and J_c from the needle base frame's Jacobian, for any robot
(the implementation of `rcmplan.robot.curved.CurvedTipRobot`'s task rows; its solves are
`rcmplan.control.curved_step`'s).

The robot-specific kernels (`curved_iramis`, `curved_arm`) put the needle base frame's
geometric Jacobian over the active joints into a work block and call `assemble`:

    J_tip = J_v - [p_tip - o]x J_w,   J_rcm = J_v - [p - o]x J_w (+ l_s a for lambda),
    J_rho = a^T J_w - a_y J_phi,      J_phi = (a_z da_x - a_x da_z) / (a_x^2 + a_z^2),
    da = J_w x a,

with o the needle base, a the shaft axis and p the RCM point p(lambda) (the needle base for the
whole-pose task); rho is the needle roll (`rcmplan.robot.needle.roll_of`). The roll row: the
frame (e1, e2, a) of the needle angles turns about a at a_y d phi, the needle at a . omega, so
d rho = a . omega - a_y d phi. Imports numba.

The work block: rows c.. of a float64 array C at least max(7, m + 1) wide (`BLOCK_ROWS` rows):
G (6 rows: J_v, then J_w, over the m active joints), J (7 rows: J_c over theta_ext), S (7 rows:
the scratch of the solves), then vector rows B (right-hand side and solution) and Z (the
null-space posture step of a redundant robot). Steps d = (dq[active], dlambda), (m + 1,).
"""

from __future__ import annotations

import math

from rcmplan._jit import njit
from rcmplan._validate import FloatArray

G, J, S, B, Z = 0, 6, 13, 20, 21  # row offsets in the work block
BLOCK_ROWS = 22
WIDTH = 7  # X_c = (p_tip (3), rho, p_rcm (3))
ROLL = 3  # the roll's row in X_c


@njit(cache=True, inline="always")
def wrap(x: float) -> float:
    """x wrapped to [-pi, pi): (x + pi) mod 2 pi - pi (the modulo only where it changes
    x + pi)."""
    y = x + math.pi
    if 0.0 <= y < 2.0 * math.pi:
        return y - math.pi
    return y % (2.0 * math.pi) - math.pi


@njit(cache=True, borrows=True)
def assemble(C: FloatArray, c: int, m: int, o: tuple, tip: tuple, p: tuple, a: tuple,
             shaft: float, pose: bool) -> None:  # fmt: skip
    """J_c (7, m + 1) into rows c + J.. from the base frame's Jacobian in rows c + G..: the
    tip rows, the roll row and the rows of p (the RCM point p(lambda), whose lambda column is
    shaft * a; or, with `pose`, the needle base, lambda column 0)."""
    ax, ay, az = a
    h2 = ax * ax + az * az
    tx, ty, tz = tip[0] - o[0], tip[1] - o[1], tip[2] - o[2]
    px, py, pz = p[0] - o[0], p[1] - o[1], p[2] - o[2]
    r = c + J
    for j in range(m):
        vx, vy, vz = C[c + G, j], C[c + G + 1, j], C[c + G + 2, j]
        wx, wy, wz = C[c + G + 3, j], C[c + G + 4, j], C[c + G + 5, j]
        C[r, j] = vx - (ty * wz - tz * wy)  # J_v - (p_tip - o) x J_w
        C[r + 1, j] = vy - (tz * wx - tx * wz)
        C[r + 2, j] = vz - (tx * wy - ty * wx)
        dax, daz = wy * az - wz * ay, wx * ay - wy * ax  # (J_w x a)_x, _z
        C[r + 3, j] = ax * wx + ay * wy + az * wz - ay * ((az * dax - ax * daz) / h2)
        C[r + 4, j] = vx - (py * wz - pz * wy)
        C[r + 5, j] = vy - (pz * wx - px * wz)
        C[r + 6, j] = vz - (px * wy - py * wx)
    lam = 0.0 if pose else shaft
    for i in range(4):
        C[r + i, m] = 0.0
    C[r + 4, m], C[r + 5, m], C[r + 6, m] = lam * ax, lam * ay, lam * az
