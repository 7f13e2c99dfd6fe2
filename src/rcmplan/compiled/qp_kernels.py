"""The QP controller's step for iRAM!S in compiled code: the same QP as `build_step`, solved by
DAQP's C function (`daqp_c`), and the step read from its solution.

Every row repeats the reference arithmetic (`control/qp_problem.py`, `control/limits/*.py`)
in the same order, so the assembled QP equals the reference's to rounding (tests check 1e-12
relative): variables x = (ds[L1..L5], l dlambda) / SCALE; the cost of the weighted X_ext error
plus damping; actuator travel, speed over dt and lambda in [0, 1] as bounds; then the rows G x
<= h of the RCM box, the retina barrier, the singular margin and a workspace box (or the RCM
as an equality A x = b when its tolerance is 0), in the order DAQP receives them from
`qp_backends`.

Settings travel as one float64 vector Q (`qp_params`), the robot as the kernels' P
(`kernels.PARAMS`), retina contact points as a (k, 3) array, and the buffers of one solve as
the tuple `qp` of `buffers()`. Functions take the arrays they write one by one: every array
passed costs numba a reference count update, which on a 15-array tuple per call tripled the
assembly's time.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from rcmplan._validate import FloatArray
from rcmplan.compiled.daqp_c import (
    EQUALITY,
    INF,
    PROBLEM_WORDS,
    RESULT_WORDS,
    default_settings,
    quadprog,
)
from rcmplan.compiled.kernels import (
    actuators_from_joints,
    joints_from_actuators,
    point_jacobian,
    task,
)
from rcmplan.compiled.qp_params import (
    ANGLE_WEIGHT,
    BOX_GAIN,
    BOX_LOWER,
    BOX_ORIGIN,
    BOX_R,
    BOX_UPPER,
    CENTER,
    CONTACT_TOL,
    DAMPING,
    DT,
    EYE_GAIN,
    HAS_BOX,
    HAS_EYE,
    PORT,
    PORT_ZONE,
    RCM_TOL,
    RCM_WEIGHT,
    RETINA_MARGIN,
    RETINA_RADIUS,
    SINGULAR_FLOOR,
    SINGULAR_GAIN,
    SPEED,
    TRAVEL_MARGIN,
)
from rcmplan.control.limits.base import RECOVERY, SCALE, SPEED_ACTIVE

N_VAR = 6  # L1..L5 and l dlambda
N_BOUNDS = 6
MAX_ROWS = 13  # RCM box 4, retina 1, singular 2, workspace box 6


X = 10  # index of the solution x in `buffers()`


def buffers() -> tuple:
    """The arrays one step's solve works in: the QP (H, f, A, upper, lower, sense), the task
    Jacobian d X_ext / d x, T, the Jacobians J, scratch w; DAQP's x, duals, problem, result
    and settings (`daqp_c.quadprog`)."""
    rows = N_BOUNDS + MAX_ROWS
    return (np.empty((N_VAR, N_VAR)), np.empty(N_VAR), np.zeros((MAX_ROWS, N_VAR)),
            np.empty(rows), np.empty(rows), np.zeros(rows, dtype=np.int32),
            np.empty((6, N_VAR)), np.zeros((N_VAR, N_VAR)), np.empty((6, N_VAR)), np.empty(6),
            np.empty(N_VAR), np.empty(rows), np.zeros(PROBLEM_WORDS, dtype=np.int64),
            np.zeros(RESULT_WORDS, dtype=np.int64), default_settings())  # fmt: skip


@njit(cache=True)
def variable_map(P: FloatArray, tr: tuple, T: FloatArray) -> None:
    """T = d(q0..q4, lambda) / d(L1..L5, l lambda) (`limits.base.variable_map`) into T (6, 6),
    whose other entries stay zero: the PCJM rates (`Iramis.joint_rates`) and 1 / l6."""
    for i in (0, 2):
        g = tr[i] ** 2 / P[6]
        T[i, i] = T[i, i + 1] = 0.5
        T[i + 1, i], T[i + 1, i + 1] = -g, g
    T[4, 4] = 1.0
    T[5, 5] = 1.0 / P[5]


@njit(cache=True)
def times_map(J: FloatArray, r: int, T: FloatArray, out: FloatArray, o: int) -> None:
    """out[o] = J[r] @ T for one row."""
    for j in range(N_VAR):
        acc = 0.0
        for k in range(N_VAR):
            acc += J[r, k] * T[k, j]
        out[o, j] = acc


@njit(cache=True)
def step_task(P: FloatArray, q: FloatArray, tr: tuple, lam: float, T: FloatArray,
              J: FloatArray, task_: FloatArray) -> None:  # fmt: skip
    """task = d X_ext / d x (`qp_problem.task_jacobian`): J_a T with the exact angle rows; J
    holds the tip Jacobian (rows 0-2) and the RCM point's (rows 3-5) afterwards."""
    variable_map(P, tr, T)
    point_jacobian(P, q, tr, 1.0, J, 0)
    J[0, 5] = J[1, 5] = J[2, 5] = 0.0  # the tip does not move with lambda
    point_jacobian(P, q, tr, lam, J, 3)
    times_map(J, 0, T, task_, 0)
    for j in range(N_VAR):  # e_q1 T and e_q3 T (Iramis.needle_angles_jacobian)
        task_[1, j] = T[1, j]
        task_[2, j] = T[3, j]
    for i in range(3):
        times_map(J, 3 + i, T, task_, 3 + i)


@njit(cache=True)
def cost(Q: FloatArray, K: FloatArray, e: FloatArray, task_: FloatArray, H: FloatArray,
         f: FloatArray, w: FloatArray) -> None:  # fmt: skip
    """H and f of 1/2 |W (task x SCALE - K e)|^2 / SCALE^2 + 1/2 D^2 |x|^2 (`qp_problem.cost`);
    w (>= 6) is scratch."""
    aw, rw = Q[ANGLE_WEIGHT], Q[RCM_WEIGHT]
    weights = (1.0, aw, aw, rw, rw, rw)
    for i in range(6):
        w[i] = weights[i] * K[i] * e[i] / SCALE  # bw
    for j in range(N_VAR):
        for k in range(N_VAR):
            acc = 0.0
            for i in range(6):
                acc += (weights[i] * task_[i, j]) * (weights[i] * task_[i, k])
            H[j, k] = acc
        H[j, j] += Q[DAMPING] ** 2
        acc = 0.0
        for i in range(6):
            acc += (weights[i] * task_[i, j]) * w[i]
        f[j] = -acc


@njit(cache=True)
def bounds(P: FloatArray, Q: FloatArray, s: FloatArray, lam: float, upper: FloatArray,
           lower: FloatArray, sense: np.ndarray) -> None:  # fmt: skip
    """Travel less the margin and speed x dt for L1..L5, lambda in [0, 1] (`ActuatorLimit`)."""
    margin = Q[TRAVEL_MARGIN]
    for i in range(5):
        lo = P[7 + i] + margin - s[i]
        hi = P[13 + i] - margin - s[i]
        step = Q[SPEED + i] * Q[DT]
        lower[i] = min(max(lo, -step), 0.0) / SCALE
        upper[i] = max(min(hi, step), 0.0) / SCALE
    lower[5] = -lam * P[5] / SCALE
    upper[5] = (1.0 - lam) * P[5] / SCALE
    for i in range(N_BOUNDS):
        sense[i] = 0


@njit(cache=True)
def cross(a: tuple, b: tuple) -> tuple:
    """a x b of 3-tuples."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(cache=True)
def normal_basis(axis: tuple) -> tuple:
    """Two unit normals of a unit axis (`limits.rcm.normal_basis`: the first smallest |axis_i|
    picks the helper axis)."""
    k = 0
    for i in range(1, 3):
        if abs(axis[i]) < abs(axis[k]):
            k = i
    helper = (1.0 if k == 0 else 0.0, 1.0 if k == 1 else 0.0, 1.0 if k == 2 else 0.0)
    n1 = cross(axis, helper)
    norm = math.sqrt(n1[0] * n1[0] + n1[1] * n1[1] + n1[2] * n1[2])
    n1 = (n1[0] / norm, n1[1] / norm, n1[2] / norm)
    return n1, cross(axis, n1)


@njit(cache=True)
def rcm_rows(P: FloatArray, Q: FloatArray, q: FloatArray, tr: tuple, lam: float,
             target: FloatArray, r: int, A: FloatArray, upper: FloatArray, lower: FloatArray,
             sense: np.ndarray, T: FloatArray, J: FloatArray) -> int:  # fmt: skip
    """The RCM's rows from row r (`RcmLimit`): the box (4 rows) or, with tolerance 0, the
    equality (2 rows, sense EQUALITY); returns the next row. J: `step_task`'s."""
    c1, s1, c3, s3 = tr
    n1, n2 = normal_basis((-c1 * c3, -s3, s1 * c3))
    w = q[4] + lam * P[5]  # p(lambda) as `kernels.point`
    rcm = (P[1] * s1 - c1 * c3 * w - P[4] * c1 * s3, P[2] + P[3] + q[2] - s3 * w + P[4] * c3,
           P[0] + q[0] + P[1] * c1 + s1 * c3 * w + P[4] * s1 * s3)  # fmt: skip
    tol = Q[RCM_TOL]
    box = tol / math.sqrt(2.0)
    for a in range(2):
        n = n1 if a == 0 else n2
        dev = 0.0
        for i in range(3):
            dev += n[i] * (rcm[i] - target[3 + i])
        for j in range(N_VAR):
            acc = 0.0
            for k in range(N_VAR):  # (N J_rcm)[a, k] T[k, j]
                acc += (n[0] * J[3, k] + n[1] * J[4, k] + n[2] * J[5, k]) * T[k, j]
            A[r + a, j] = acc
            if tol > 0.0:
                A[r + 2 + a, j] = -acc
        b = N_BOUNDS + r + a
        if tol == 0.0:
            upper[b] = lower[b] = -dev / SCALE
            sense[b] = EQUALITY
        else:
            upper[b], lower[b], sense[b] = (box - dev) / SCALE, -INF, 0
            upper[b + 2], lower[b + 2], sense[b + 2] = (box + dev) / SCALE, -INF, 0
    return r + (4 if tol > 0.0 else 2)


@njit(cache=True)
def damper_row(value: float, floor: float, gain: float, b: int, upper: FloatArray,
               lower: FloatArray, sense: np.ndarray) -> None:  # fmt: skip
    """h of constraint b for value + grad x SCALE >= floor (`limits.base.damper_row`); the
    row's G = -grad must be in A."""
    gap = value - floor
    need = -gain * gap if gap >= 0.0 else min(-gain * gap, RECOVERY)
    upper[b] = -need / SCALE
    lower[b] = -INF
    sense[b] = 0


@njit(cache=True)
def distance_to_retina(Q: FloatArray, p: tuple) -> float:
    """Signed distance of p from the retina sphere, positive inside (`Eye.distance_to_retina`)."""
    acc = 0.0
    for i in range(3):
        acc += (p[i] - Q[CENTER + i]) ** 2
    return Q[RETINA_RADIUS] - math.sqrt(acc)


@njit(cache=True)
def is_contact(Q: FloatArray, contacts: FloatArray, tip_t: tuple) -> bool:
    """The target tip on the retina or on a listed contact point (`limits.retina.is_contact`)."""
    tol = Q[CONTACT_TOL]
    if abs(distance_to_retina(Q, tip_t)) <= tol:
        return True
    for c in range(contacts.shape[0]):
        acc = 0.0
        for i in range(3):
            acc += (tip_t[i] - contacts[c, i]) ** 2
        if math.sqrt(acc) <= tol:
            return True
    return False


@njit(cache=True)
def target_tip(target: FloatArray) -> tuple:
    """The tip X_ext implies (`targets.tip_of_target`); the loop has refused targets that fix
    none (`loop.target_frame`)."""
    phi, psi = target[1], target[2]
    a = (-math.cos(phi) * math.cos(psi), -math.sin(psi), math.sin(phi) * math.cos(psi))
    t = (target[0] - target[3]) / a[0]
    return (target[3] + t * a[0], target[4] + t * a[1], target[5] + t * a[2])


@njit(cache=True)
def tip_point(P: FloatArray, q: FloatArray, tr: tuple) -> tuple:
    """The needle tip p(1) (`kernels.point`)."""
    c1, s1, c3, s3 = tr
    w = q[4] + P[5]
    return (P[1] * s1 - c1 * c3 * w - P[4] * c1 * s3, P[2] + P[3] + q[2] - s3 * w + P[4] * c3,
            P[0] + q[0] + P[1] * c1 + s1 * c3 * w + P[4] * s1 * s3)  # fmt: skip


@njit(cache=True)
def retina_row(P: FloatArray, Q: FloatArray, contacts: FloatArray, q: FloatArray, tr: tuple,
               target: FloatArray, r: int, A: FloatArray, upper: FloatArray, lower: FloatArray,
               sense: np.ndarray, T: FloatArray, J: FloatArray) -> int:  # fmt: skip
    """The retina barrier's row at r (`RetinaBarrier`), or none; returns the next row."""
    if Q[HAS_EYE] == 0.0:
        return r
    tip = tip_point(P, q, tr)
    acc = 0.0
    for i in range(3):
        acc += (tip[i] - Q[PORT + i]) ** 2
    if math.sqrt(acc) <= Q[PORT_ZONE]:
        return r
    acc = 0.0
    for i in range(3):
        acc += (tip[i] - Q[CENTER + i]) ** 2
    norm = math.sqrt(acc)
    u = ((tip[0] - Q[CENTER]) / norm, (tip[1] - Q[CENTER + 1]) / norm,
         (tip[2] - Q[CENTER + 2]) / norm)  # fmt: skip
    for j in range(N_VAR):
        acc = 0.0
        for k in range(N_VAR):  # (u @ J_tip)[k] T[k, j]: G = -grad, grad = -(u @ J_tip) @ T
            acc += (u[0] * J[0, k] + u[1] * J[1, k] + u[2] * J[2, k]) * T[k, j]
        A[r, j] = acc
    floor = Q[RETINA_MARGIN]
    tip_t = target_tip(target)
    if is_contact(Q, contacts, tip_t):
        floor = min(floor, max(distance_to_retina(Q, tip_t), 0.0))
    damper_row(distance_to_retina(Q, tip), floor, Q[EYE_GAIN], N_BOUNDS + r, upper, lower, sense)
    return r + 1


@njit(cache=True)
def singular_rows(Q: FloatArray, q: FloatArray, tr: tuple, r: int, A: FloatArray,
                  upper: FloatArray, lower: FloatArray, sense: np.ndarray,
                  T: FloatArray) -> int:  # fmt: skip
    """cos q1 and cos q3 kept above the floor (`SingularMargin`); returns the next row."""
    for a in range(2):
        j_q = 1 + 2 * a
        grad = -math.sin(q[j_q])
        for j in range(N_VAR):
            A[r + a, j] = -(grad * T[j_q, j])
        damper_row(tr[2 * a], Q[SINGULAR_FLOOR], Q[SINGULAR_GAIN], N_BOUNDS + r + a, upper,
                   lower, sense)  # fmt: skip
    return r + 2


@njit(cache=True)
def workspace_rows(P: FloatArray, Q: FloatArray, q: FloatArray, tr: tuple, r: int, A: FloatArray,
                   upper: FloatArray, lower: FloatArray, sense: np.ndarray, T: FloatArray,
                   J: FloatArray) -> int:  # fmt: skip
    """The workspace box's rows from r (`WorkspaceBound`: per box axis i the lower then the
    upper face, each a damper on the tip's box coordinate c_i = (R^T (tip - origin))_i), or
    none; returns the next row."""
    if Q[HAS_BOX] == 0.0:
        return r
    tip = tip_point(P, q, tr)
    for i in range(3):
        c = 0.0
        for m in range(3):
            c += Q[BOX_R + 3 * m + i] * (tip[m] - Q[BOX_ORIGIN + m])
        for j in range(N_VAR):
            acc = 0.0
            for k in range(N_VAR):  # (R^T J_tip)[i, k] T[k, j]
                rj = 0.0
                for m in range(3):
                    rj += Q[BOX_R + 3 * m + i] * J[m, k]
                acc += rj * T[k, j]
            A[r, j] = -acc  # G = -grad for the lower face, grad = d c_i / dx
            A[r + 1, j] = acc  # and for the upper face, grad = -d c_i / dx
        damper_row(c - Q[BOX_LOWER + i], 0.0, Q[BOX_GAIN], N_BOUNDS + r, upper, lower, sense)
        damper_row(Q[BOX_UPPER + i] - c, 0.0, Q[BOX_GAIN], N_BOUNDS + r + 1, upper, lower,
                   sense)  # fmt: skip
        r += 2
    return r


@njit(cache=True)
def build_step(P: FloatArray, Q: FloatArray, contacts: FloatArray, K: FloatArray,
               q: FloatArray, tr: tuple, lam: float, target: FloatArray, s: FloatArray,
               e: FloatArray, qp: tuple) -> int:  # fmt: skip
    """The QP of one step at joints q, lambda (`qp_problem.build_step`) into the buffers;
    also the actuators s (6,) and the X_ext error e (6,). Returns the number of rows of A
    (inequalities first; an RCM equality last, marked in `sense`)."""
    H, f, A, upper, lower, sense, task_, T, J, w = qp[:10]
    actuators_from_joints(P, q, s)
    task(P, q, tr, lam, e)
    for i in range(6):
        e[i] = target[i] - e[i]
    step_task(P, q, tr, lam, T, J, task_)
    cost(Q, K, e, task_, H, f, w)
    bounds(P, Q, s, lam, upper, lower, sense)
    eq = Q[RCM_TOL] == 0.0
    r = 0 if eq else rcm_rows(P, Q, q, tr, lam, target, 0, A, upper, lower, sense, T, J)
    r = retina_row(P, Q, contacts, q, tr, target, r, A, upper, lower, sense, T, J)
    r = singular_rows(Q, q, tr, r, A, upper, lower, sense, T)
    r = workspace_rows(P, Q, q, tr, r, A, upper, lower, sense, T, J)
    if eq:
        r = rcm_rows(P, Q, q, tr, lam, target, r, A, upper, lower, sense, T, J)
    return r


@njit(cache=True)
def solve_step(P: FloatArray, Q: FloatArray, contacts: FloatArray, K: FloatArray,
               q: FloatArray, tr: tuple, lam: float, target: FloatArray, s: FloatArray,
               e: FloatArray, qp: tuple) -> int:  # fmt: skip
    """Build and solve the step's QP; returns DAQP's exit flag (1: optimal). The solution is
    in qp[X]; e (6,) holds the error a feasible step removes, J x* / K, or the plain X_ext
    error when an actuator moves at full speed (`QpSolver.error`)."""
    rows = build_step(P, Q, contacts, K, q, tr, lam, target, s, e, qp)
    H, f, A, upper, lower, sense, task_ = qp[:7]
    x, lam_d, problem, result, settings = qp[10:]
    flag = quadprog(H, f, A, upper, lower, sense, N_BOUNDS, rows, x, lam_d, problem, result,
                    settings)  # fmt: skip
    if flag != 1:
        return flag
    for j in range(5):  # a step at full speed leaves the plain error (`QpSolver.speed_limited`)
        if abs(x[j]) >= (1.0 - SPEED_ACTIVE) * (Q[SPEED + j] * Q[DT] / SCALE):
            return flag
    for i in range(6):
        acc = 0.0
        for j in range(N_VAR):
            acc += (task_[i, j] * SCALE) * x[j]
        e[i] = acc / K[i]
    return flag


@njit(cache=True)
def step_joints(P: FloatArray, q: FloatArray, s: FloatArray, x: FloatArray, qn: FloatArray,
                w: FloatArray) -> float:  # fmt: skip
    """The step of a solution x (`QpSolver.step`): joints q + (q(s + x SCALE) - q) into qn,
    with the actuators s the QP was built at; returns d lambda. w (>= 6) is scratch."""
    for i in range(6):
        w[i] = s[i] + x[i] * SCALE if i < 5 else s[i]
    joints_from_actuators(P, w, qn)
    for i in range(6):
        qn[i] = q[i] + (qn[i] - q[i]) if i < 5 else q[i]
    return x[5] * SCALE / P[5]
