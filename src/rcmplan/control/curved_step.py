"""Compiled steps of a curved needle, for any robot: the task error and the pinv, DLS and
whole-pose steps on X_c (the implementation of `rcmplan.control.curved`'s solvers, which call
`solve`, and of the compiled loops' curved iterations).

    CURVED_PINV: J_c d = K e when J_c is square (m = 6), else the minimum-norm step plus the
        null-space posture z: d = J^+ (K e - J z) + z;
    CURVED_DLS: d = J^T (J J^T + D^2 I)^-1 e with the roll row and error times l_s, so that every
        row is in [m] (one damping for all);
    CURVED_POSE: the least-squares step of J_c without its lambda column for K e; dlambda = 0.
        With more than six joints J_c (7 rows for a rigid needle's six freedoms) is
        rank-deficient both ways: its minimum-norm least-squares step (`least_norm`, from the
        rows' one dependency).

On iRAM!S J_c has structure, exact in exact arithmetic, that the pinv step uses
(`iramis_pinv_step`, as the straight needle's `kernels.solve_augmented` uses J_a's): the roll
row is e_q5; the prismatic q0, q2, q4 move the tip and the RCM point alike (e_z, e_y, a) and
turn nothing; the roll moves no RCM point; a turn w moves the tip by w x (p_tip - p) more than
the RCM point. The square system then splits into one 3 x 3 system in (dq1, dq3, dlambda) (the
tip rows minus the RCM rows) and substitutions. The work block is `rcmplan.robot.curved_block`'s.
Imports numba.
"""

from __future__ import annotations

import math

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.linalg import damped, lu_solve, pinv
from rcmplan.robot import curved_arm, curved_iramis
from rcmplan.robot.chain_kinematics import IntArray
from rcmplan.robot.curved_block import ROLL, WIDTH, B, J, S, Z, wrap
from rcmplan.robot.iramis_kernels import point, point_jacobian

# A curved needle's method codes (X_c, 7 rows), after the straight needle's
# (`rcmplan.compiled.records`)
CURVED = 16
CURVED_PINV, CURVED_DLS, CURVED_POSE = CURVED, CURVED + 1, CURVED + 2
CURVED_QP = CURVED + 3  # the QP controller on a curved needle (`compiled.qp_kernels`)
# The curved QP's free-space step (`LimitedPoseSolver`): CURVED_POSE's step scaled to hold the
# actuators' speed and travel (the iRAM!S loop's `limit_step`)
CURVED_POSE_LIMITED = CURVED + 4


@njit(cache=True, inline="always")
def error(x: FloatArray, target: FloatArray, e: FloatArray) -> None:
    """e = target - x (7,), the roll error wrapped to [-pi, pi)."""
    for i in range(WIDTH):
        e[i] = target[i] - x[i]
    e[ROLL] = wrap(e[ROLL])


@njit(cache=True, borrows=True)
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


# a degenerate J: NaN (the loop then stops), no exception
@njit(cache=True, borrows=True, error_model="numpy")
def least_norm(C: FloatArray, c: int, cols: int, d: FloatArray) -> None:
    """The minimum-norm least-squares d[:cols] of J[:, :cols] d = b (row c + B) for the
    whole-pose task of seven or more joints, whose seven rows (tip, roll, needle base) have
    rank 6: the tip and the base of a rigid needle keep their distance, so n = (u, 0, -u) / 2^0.5
    with u the unit left null vector of D = J_tip - J_base (3, cols) has n^T J = 0. b is
    projected on J's range (b - n n^T b), the tip row where |u| is largest dropped (the last
    row takes its place), and the six rows left, of full rank, give the minimum-norm step
    d = J6^T (J6 J6^T)^-1 b6 (`linalg.damped` with no damping): J^+ b, with no SVD (whose
    compile, numba's `lstsq`, took 9 s more in a first curved run). J's rows and b are
    overwritten. A J of lower rank (D of rank below 2: no joint turns the tip about the base)
    gives NaN, which the loop stops on (BAD_JOINTS)."""
    r0, rb = c + J, c + B
    m00 = m01 = m02 = m11 = m12 = m22 = 0.0  # D D^T, rank 2: u is normal to its rows
    for j in range(cols):
        x, y, z = (C[r0, j] - C[r0 + 4, j], C[r0 + 1, j] - C[r0 + 5, j],
                   C[r0 + 2, j] - C[r0 + 6, j])  # fmt: skip
        m00, m01, m02 = m00 + x * x, m01 + x * y, m02 + x * z
        m11, m12, m22 = m11 + y * y, m12 + y * z, m22 + z * z
    # u: the largest cross product of two of its rows
    ux, uy, uz = m01 * m12 - m02 * m11, m02 * m01 - m00 * m12, m00 * m11 - m01 * m01
    best = ux * ux + uy * uy + uz * uz
    x, y, z = m01 * m22 - m02 * m12, m02 * m02 - m00 * m22, m00 * m12 - m01 * m02
    if x * x + y * y + z * z > best:
        ux, uy, uz, best = x, y, z, x * x + y * y + z * z
    x, y, z = m11 * m22 - m12 * m12, m12 * m02 - m01 * m22, m01 * m12 - m11 * m02
    if x * x + y * y + z * z > best:
        ux, uy, uz, best = x, y, z, x * x + y * y + z * z
    norm = math.sqrt(2.0 * best)
    n = (ux / norm, uy / norm, uz / norm)  # the tip rows' part of n; the base rows': -n
    t = 0.0
    for i in range(3):
        t += n[i] * (C[rb, i] - C[rb, 4 + i])
    for i in range(3):
        C[rb, i] -= t * n[i]
        C[rb, 4 + i] += t * n[i]
    drop = 0
    for i in range(1, 3):
        if abs(n[i]) > abs(n[drop]):
            drop = i
    for j in range(cols):
        C[r0 + drop, j] = C[r0 + 6, j]
    C[rb, drop] = C[rb, 6]
    damped(C, r0, WIDTH - 1, cols, 0.0, c + S, rb, d)


@njit(cache=True, borrows=True)
def step(C: FloatArray, c: int, method: int, m: int, K: FloatArray, damping: float,
         shaft: float, e: FloatArray, d: FloatArray) -> None:  # fmt: skip
    """The solver's step d (m + 1,) from J_c in rows c + J.. and the error e (7,):

    - CURVED_PINV: J_c d = K e when J_c is square (m = 6), else the minimum-norm step plus the
      null-space posture z (row c + Z, filled by the caller): d = J^+ (K e - J z) + z;
    - CURVED_DLS: d = J^T (J J^T + D^2 I)^-1 e with the roll row and error times l_s (`shaft`);
    - CURVED_POSE: the least-squares step of J_c without its lambda column for K e (with more
      than six joints the minimum-norm one, `least_norm`); dlambda = 0.
    """
    b = c + B
    if method == CURVED_DLS:
        for j in range(m + 1):
            C[c + J + ROLL, j] *= shaft
        for i in range(WIDTH):
            C[b, i] = e[i] * shaft if i == ROLL else e[i]
        damped(C, c + J, WIDTH, m + 1, damping, c + S, b, d)
        return
    cols = m + 1 if method == CURVED_PINV else m
    for i in range(WIDTH):
        C[b, i] = K[i] * e[i]
    if cols < WIDTH:
        normal(C, c, cols, d)
    elif method == CURVED_POSE:  # seven or more joints: J_c has rank 6
        least_norm(C, c, cols, d)
    else:  # CURVED_PINV: square, or wide with the posture
        pinv(C, c + J, WIDTH, cols, c + S, b, c + Z, d)
    if method != CURVED_PINV:
        d[m] = 0.0


@njit(cache=True, inline="always")
def iramis_task_error(P: FloatArray, method: int, q: FloatArray, tr: tuple, lam: float,
               target: FloatArray, e: FloatArray, w: FloatArray) -> int:  # fmt: skip
    """The curved solver's error (7,) into e (the whole-pose task for CURVED_POSE); returns 7."""
    curved_iramis.task(P, q, tr, lam, method == CURVED_POSE, e, w)
    error(e, target, e)
    return WIDTH


@njit(cache=True, inline="always")
def iramis_pinv_step(P: FloatArray, K: FloatArray, q: FloatArray, tr: tuple, lam: float,
              e: FloatArray, d: FloatArray, w: FloatArray, R: FloatArray) -> None:  # fmt: skip
    """d = J_c^-1 K e (7,) by J_c's structure (module docstring): dq5 from the roll row;
    (dq1, dq3, dlambda) from the tip rows minus the RCM rows (Cramer's rule); dq4, dq2, dq0
    from the RCM rows x, y, z, whose q1 and q3 columns are eq. 3.10's (into R, (3, 6))."""
    c1, s1 = tr[0], tr[1]
    o, a, _, tip = curved_iramis.frame(P, q, tr, w)
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
def iramis_step(P: FloatArray, method: int, K: FloatArray, damping: float, q: FloatArray, tr: tuple,
         lam: float, e: FloatArray, C: FloatArray, d: FloatArray,
         w: FloatArray) -> None:  # fmt: skip
    """The curved solver's step d = (dq0..dq5, dlambda) (7,) for its error e; C is the work
    block (rows 0..)."""
    if method == CURVED_PINV:
        iramis_pinv_step(P, K, q, tr, lam, e, d, w, C)
        return
    curved_iramis.jacobian(P, q, tr, lam, method == CURVED_POSE, C, 0, w)
    step(C, 0, method, curved_iramis.ACTIVE, K, damping, P[5], e, d)


@njit(cache=True, inline="always")
def arm_task_error(A: FloatArray, ix: IntArray, W: FloatArray, method: int, lam: float,
               target: FloatArray, e: FloatArray) -> int:  # fmt: skip
    """The curved solver's error (7,) at the frames in W into e: X_c target - X_c, or the
    whole pose's (p_tip, rho, p(0)) for CURVED_POSE; returns 7."""
    curved_arm.task(A, ix[0], W, lam, method == CURVED_POSE, e)
    error(e, target, e)
    return WIDTH


@njit(cache=True, borrows=True)
def arm_step(A: FloatArray, ix: IntArray, W: FloatArray, method: int, K: FloatArray, gain: float,
         damping: float, s: FloatArray, lam: float, e: FloatArray,
         d: FloatArray) -> None:  # fmt: skip
    """The curved solver's step d = (dq[active_c], dlambda) (m_c + 1,) at joints s for its
    error e, at the frames in W; a redundant arm's pinv step adds the null-space posture
    gain (home - q) over the curved needle's active joints."""
    n = ix[0]
    c = curved_arm.block_row(n)
    first, mc = curved_arm.active_span(ix)
    curved_arm.jacobian(A, ix, W, lam, method == CURVED_POSE)
    if method == CURVED_PINV and mc + 1 > WIDTH:
        for j in range(mc):
            k = ix[first + j]
            W[c + Z, j] = gain * (A[4 * (n + 3) + k, 3] - s[k])
        W[c + Z, mc] = 0.0
    step(W, c, method, mc, K, damping, A[5 * n + 12, 0], e, d)
