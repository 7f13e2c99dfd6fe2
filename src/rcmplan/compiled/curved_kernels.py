"""Compiled task rows and steps of a curved needle, for any robot: the roll, J_c from the needle
base frame's Jacobian, and the pinv, DLS and whole-pose steps (`rcmplan.control.curved`).

The robot-specific kernels (`curved_iramis`, `curved_arm`) put the needle base frame's
geometric Jacobian over the active joints into a work block and call `assemble`; everything
after that is here. The maths is the reference's (`rcmplan.robot.curved`,
`rcmplan.robot.needle.roll_from_axes` and `roll_jacobian`, `rcmplan.control.solvers`), so
results agree to rounding:

    J_tip = J_v - [p_tip - o]x J_w,   J_rcm = J_v - [p - o]x J_w (+ l_s a for lambda),
    J_rho = a^T J_w - a_y J_phi,      J_phi = (a_z da_x - a_x da_z) / (a_x^2 + a_z^2),
    da = J_w x a,

with o the needle base, a the shaft axis and p the RCM point p(lambda) (the needle base for the
whole-pose task). Imports numba.

The work block: rows c.. of a float64 array C at least max(7, m + 1) wide (`BLOCK_ROWS` rows):
G (6 rows: J_v, then J_w, over the m active joints), J (7 rows: J_c over theta_ext), S (7 rows:
the scratch of the solves), then vector rows B (right-hand side and solution) and Z (the
null-space posture step of a redundant robot). Steps d = (dq[active], dlambda), (m + 1,).
The small kernels are inlined into their callers (`inline="always"`).
"""

from __future__ import annotations

import math

from numba import njit

from rcmplan._validate import FloatArray
from rcmplan.compiled.chain_solve import lu_solve
from rcmplan.compiled.records import CURVED_DLS, CURVED_PINV

G, J, S, B, Z = 0, 6, 13, 20, 21  # row offsets in the work block
BLOCK_ROWS = 22
WIDTH = 7  # X_c = (p_tip (3), rho, p_rcm (3))
ROLL = 3  # the roll's row in X_c


@njit(cache=True, inline="always")
def wrap(x: float) -> float:
    """x wrapped to [-pi, pi) as the reference does it, (x + pi) mod 2 pi - pi (the modulo
    only where it changes x + pi)."""
    y = x + math.pi
    if 0.0 <= y < 2.0 * math.pi:
        return y - math.pi
    return y % (2.0 * math.pi) - math.pi


@njit(cache=True)
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


@njit(cache=True, inline="always")
def error(x: FloatArray, target: FloatArray, e: FloatArray) -> None:
    """e = target - x (7,), the roll error wrapped to [-pi, pi)."""
    for i in range(WIDTH):
        e[i] = target[i] - x[i]
    e[ROLL] = wrap(e[ROLL])


@njit(cache=True)
def gram(C: FloatArray, c: int, cols: int, damping: float) -> None:
    """S = J J^T + D^2 I (7, 7) over J's first `cols` columns, into rows c + S.."""
    for i in range(WIDTH):
        for k in range(i + 1):
            acc = 0.0
            for col in range(cols):
                acc += C[c + J + i, col] * C[c + J + k, col]
            C[c + S + i, k], C[c + S + k, i] = acc, acc
        C[c + S + i, i] += damping * damping


@njit(cache=True)
def back(C: FloatArray, c: int, cols: int, d: FloatArray) -> None:
    """d[:cols] = J^T f for f in row c + B (after `gram` and `lu_solve`)."""
    for col in range(cols):
        acc = 0.0
        for i in range(WIDTH):
            acc += C[c + J + i, col] * C[c + B, i]
        d[col] = acc


@njit(cache=True)
def square(C: FloatArray, c: int, d: FloatArray) -> None:
    """d = J^-1 (row c + B) for a square J (7, 7) (`np.linalg.solve`)."""
    for i in range(WIDTH):
        for k in range(WIDTH):
            C[c + S + i, k] = C[c + J + i, k]
    lu_solve(C, c + S, WIDTH, c + B)
    for i in range(WIDTH):
        d[i] = C[c + B, i]


@njit(cache=True)
def normal(C: FloatArray, c: int, cols: int, d: FloatArray) -> None:
    """The least-squares d[:cols] of J[:, :cols] d = (row c + B) for a tall J (cols < 7):
    (J^T J) d = J^T b."""
    for i in range(cols):
        for k in range(i + 1):
            acc = 0.0
            for r in range(WIDTH):
                acc += C[c + J + r, i] * C[c + J + r, k]
            C[c + S + i, k], C[c + S + k, i] = acc, acc
    for i in range(cols):
        acc = 0.0
        for r in range(WIDTH):
            acc += C[c + J + r, i] * C[c + B, r]
        d[i] = acc
    for i in range(cols):
        C[c + B, i] = d[i]
    lu_solve(C, c + S, cols, c + B)
    for i in range(cols):
        d[i] = C[c + B, i]


@njit(cache=True)
def step(C: FloatArray, c: int, method: int, m: int, K: FloatArray, damping: float,
         shaft: float, e: FloatArray, d: FloatArray) -> None:  # fmt: skip
    """The solver's step d (m + 1,) from J_c in rows c + J.. and the error e (7,):

    - CURVED_PINV: J_c d = K e when J_c is square (m = 6), else the minimum-norm step plus the
      null-space posture z (row c + Z, filled by the caller): d = J^+ (K e - J z) + z;
    - CURVED_DLS: d = J^T (J J^T + D^2 I)^-1 e with the roll row and error times l_s (`shaft`);
    - CURVED_POSE: the least-squares (or minimum-norm) step of J_c without its lambda column
      for K e; dlambda = 0.
    """
    b = c + B
    if method == CURVED_DLS:
        for j in range(m + 1):
            C[c + J + ROLL, j] *= shaft
        for i in range(WIDTH):
            C[b, i] = e[i] * shaft if i == ROLL else e[i]
        gram(C, c, m + 1, damping)
        lu_solve(C, c + S, WIDTH, b)
        back(C, c, m + 1, d)
        return
    cols = m + 1 if method == CURVED_PINV else m
    wide = method == CURVED_PINV and cols > WIDTH
    for i in range(WIDTH):
        acc = K[i] * e[i]
        if wide:  # K e - J z
            for j in range(cols):
                acc -= C[c + J + i, j] * C[c + Z, j]
        C[b, i] = acc
    if cols == WIDTH:
        square(C, c, d)
    elif cols < WIDTH:
        normal(C, c, cols, d)
    else:
        gram(C, c, cols, 0.0)
        lu_solve(C, c + S, WIDTH, b)
        back(C, c, cols, d)
    if wide:
        for j in range(cols):
            d[j] += C[c + Z, j]
    if method != CURVED_PINV:
        d[m] = 0.0
