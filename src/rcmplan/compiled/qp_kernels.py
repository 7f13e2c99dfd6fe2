"""The QP controller's step for iRAM!S in compiled code: the QP of `qp_problem.build_step`,
solved by DAQP's C function (`daqp_c`), and the step read from its solution.

The assembly computes iRAM!S's kinematics with its kernels (`robot/iramis_kernels.py`) and
writes every row with the limits' own kernels (`control/limits/`: `actuator_bounds`,
`rcm_rows`, `sphere_row`, `damper_rows`, `speed_rows`, `box_rows`) and the cost with
`qp_problem.weighted_cost`, the code the Python QP calls: variables x = (ds[L1..L5], l dlambda)
/ SCALE; actuator travel, speed over dt and lambda in [0, 1] as bounds; then the rows G x <= h
of the RCM box, the retina barrier, the singular margin, the tip's speed and the extra limits
in the solver's order (or the RCM as an equality A x = b when its tolerance is 0, last), in the
order DAQP receives them from `qp_backends`.

Settings travel as one float64 vector Q (`qp_params`), the robot as the kernels' P
(`iramis_kernels.PARAMS`), retina contact points as a (k, 3) array, and the buffers of one
solve as the tuple `qp` of `buffers()`.
"""

from __future__ import annotations

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
from rcmplan.compiled.kernels import task
from rcmplan.compiled.qp_params import (
    BOX,
    CENTER,
    CONTACT_TOL,
    DAMPING,
    DEPTH,
    DT,
    EXTRA,
    EXTRA_SLOT,
    EYE_GAIN,
    HAS_EYE,
    MAX_EXTRA,
    N_EXTRA,
    PORT,
    PORT_ZONE,
    RCM_TOL,
    RETINA_MARGIN,
    RETINA_RADIUS,
    RETINA_RECOVERY,
    SINGULAR_FLOOR,
    SINGULAR_GAIN,
    SPEED,
    TIP_STEP,
    TRAVEL_MARGIN,
    WEIGHTS,
)
from rcmplan.control.cost import weighted_cost, x_ext_jacobian
from rcmplan.control.limits.actuators import actuator_bounds
from rcmplan.control.limits.base import SCALE, SPEED_ACTIVE
from rcmplan.control.limits.rcm import rcm_rows
from rcmplan.control.limits.retina import contact_floor
from rcmplan.control.limits.rows import damper_rows, radial_gap, sphere_row, times
from rcmplan.control.limits.tip_speed import speed_rows
from rcmplan.control.limits.workspace import box_rows
from rcmplan.robot.iramis_kernels import (
    actuators_from_joints,
    joints_from_actuators,
    point,
    point_jacobian,
)
from rcmplan.robot.needle import x_ext_tip

N_VAR = 6  # L1..L5 and l dlambda
N_BOUNDS = 6
MAX_ROWS = 4 + 1 + 2 + 6 + 6 * MAX_EXTRA  # RCM box, retina, singular, tip speed, extras

X = 10  # index of the solution x in `buffers()`


def buffers() -> tuple:
    """The arrays one step's solve works in: the QP (H, f, A, upper, lower, sense), the task
    Jacobian d X_ext / d x, T, the Jacobians J, scratch w; DAQP's x, duals, problem, result
    and settings (`daqp_c.quadprog`); JT (8, 6): J T's tip rows, RCM rows and the angle rows;
    the points (5, 3): tip, RCM, needle axis, target tip, the target's axis; N (2, 3) and the
    singular terms' gradients (2, 6), scratch of the rows."""
    rows = N_BOUNDS + MAX_ROWS
    return (np.empty((N_VAR, N_VAR)), np.empty(N_VAR), np.zeros((MAX_ROWS, N_VAR)),
            np.empty(rows), np.empty(rows), np.zeros(rows, dtype=np.int32),
            np.empty((6, N_VAR)), np.zeros((N_VAR, N_VAR)), np.empty((6, N_VAR)), np.empty(6),
            np.empty(N_VAR), np.empty(rows), np.zeros(PROBLEM_WORDS, dtype=np.int64),
            np.zeros(RESULT_WORDS, dtype=np.int64), default_settings(),
            np.empty((8, N_VAR)), np.empty((5, 3)), np.empty((2, 3)),
            np.empty((2, N_VAR)))  # fmt: skip


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
def kinematics(P: FloatArray, q: FloatArray, tr: tuple, lam: float, T: FloatArray,
               J: FloatArray, JT: FloatArray, pts: FloatArray) -> None:  # fmt: skip
    """What the rows read (`limits.base.kinematics`): T; J (6, 6) the tip's and the RCM
    point's Jacobians; JT = (J_tip T, J_rcm T, the angle rows e_q1 T, e_q3 T); the tip, the
    RCM point and the needle axis (rows of pts)."""
    c1, s1, c3, s3 = tr
    variable_map(P, tr, T)
    point_jacobian(P, q, tr, 1.0, J, 0)
    J[0, 5] = J[1, 5] = J[2, 5] = 0.0  # the tip does not move with lambda
    point_jacobian(P, q, tr, lam, J, 3)
    times(J, T, JT[:6])
    for j in range(N_VAR):  # Iramis.needle_angles_jacobian: the rows of q1 and q3
        JT[6, j], JT[7, j] = T[1, j], T[3, j]
    point(P, q, tr, 1.0, pts[0])
    point(P, q, tr, lam, pts[1])
    pts[2, 0], pts[2, 1], pts[2, 2] = -c1 * c3, -s3, s1 * c3


@njit(cache=True)
def retina_row(Q: FloatArray, contacts: FloatArray, pts: FloatArray, JT: FloatArray,
               target: FloatArray, A: FloatArray, h: FloatArray, r: int) -> int:  # fmt: skip
    """The retina barrier's row at r (`RetinaBarrier`), or none; returns the next row."""
    tip, tip_t = pts[0], pts[3]
    center = Q[CENTER : CENTER + 3]
    if Q[HAS_EYE] == 0.0 or radial_gap(Q[PORT : PORT + 3], Q[PORT_ZONE], tip) >= 0.0:
        return r
    x_ext_tip(target, pts[4], tip_t)  # the loop has refused targets that fix no tip
    radius = Q[RETINA_RADIUS]
    floor = contact_floor(Q[RETINA_MARGIN], radial_gap(center, radius, tip_t), tip_t, contacts,
                          Q[CONTACT_TOL])  # fmt: skip
    return sphere_row(JT[:3], tip, center, radial_gap(center, radius, tip), floor,
                      Q[EYE_GAIN], Q[RETINA_RECOVERY], A, h, r)  # fmt: skip


@njit(cache=True)
def extra_rows(Q: FloatArray, pts: FloatArray, JT: FloatArray, A: FloatArray, h: FloatArray,
               r: int) -> int:  # fmt: skip
    """The extra limits' rows from r in the solver's order (`qp_params.EXTRA_KINDS`)."""
    for i in range(int(Q[N_EXTRA])):
        slot = EXTRA + i * EXTRA_SLOT
        p = Q[slot + 1 : slot + EXTRA_SLOT]
        if Q[slot] == BOX:
            r = box_rows(JT[:3], pts[0], p, A, h, r)
        elif Q[slot] == DEPTH:  # TissueDepthLimit: centre, floor radius, gain, recovery
            gap = radial_gap(p[:3], p[3], pts[0])
            r = sphere_row(JT[:3], pts[0], p[:3], gap, 0.0, p[4], p[5], A, h, r)
    return r


@njit(cache=True)
def build_step(P: FloatArray, Q: FloatArray, contacts: FloatArray, K: FloatArray,
               q: FloatArray, tr: tuple, lam: float, target: FloatArray, s: FloatArray,
               e: FloatArray, qp: tuple) -> int:  # fmt: skip
    """The QP of one step at joints q, lambda (`qp_problem.build_step`) into the buffers;
    also the actuators s (6,) and the X_ext error e (6,). Returns the number of rows of A
    (inequalities first; an RCM equality last, marked in `sense`)."""
    H, f, A, upper, lower, sense, task_, T, J = qp[:9]
    JT, pts, N, grads = qp[15:]
    actuators_from_joints(P, q, s)
    task(P, q, tr, lam, e)
    for i in range(6):
        e[i] = target[i] - e[i]
    kinematics(P, q, tr, lam, T, J, JT, pts)
    x_ext_jacobian(JT[:3], JT[6:8], JT[3:6], task_)
    weighted_cost(task_, Q[WEIGHTS : WEIGHTS + 6], K, e, Q[DAMPING], H, f)
    actuator_bounds(s[:5], P[7:12], P[13:18], Q[SPEED : SPEED + 5], Q[TRAVEL_MARGIN], Q[DT],
                    lam, P[5], lower[:N_BOUNDS], upper[:N_BOUNDS])  # fmt: skip
    h = upper[N_BOUNDS:]
    tol = Q[RCM_TOL]
    r = 0 if tol == 0.0 else rcm_rows(JT[3:6], pts[1], target[3:6], pts[2], tol, N, A, h, 0)
    r = retina_row(Q, contacts, pts, JT, target, A, h, r)
    for a in range(2):  # Iramis.singular_terms: cos q1, cos q3 and their gradients times T
        j_q = 1 + 2 * a
        for j in range(N_VAR):
            grads[a, j] = -np.sin(q[j_q]) * T[j_q, j]
    values = qp[9][:2]
    values[0], values[1] = tr[0], tr[2]
    r = damper_rows(grads, values, Q[SINGULAR_FLOOR], Q[SINGULAR_GAIN], A, h, r)
    if Q[TIP_STEP] > 0.0:
        r = speed_rows(JT[:3], Q[TIP_STEP], A, h, r)
    r = extra_rows(Q, pts, JT, A, h, r)
    for i in range(N_BOUNDS + r):
        sense[i] = 0
        if i >= N_BOUNDS:
            lower[i] = -INF
    if tol == 0.0:
        end = rcm_rows(JT[3:6], pts[1], target[3:6], pts[2], 0.0, N, A, h, r)
        for i in range(N_BOUNDS + r, N_BOUNDS + end):
            lower[i], sense[i] = upper[i], EQUALITY
        r = end
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
    x, lam_d, problem, result, settings = qp[10:15]
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
