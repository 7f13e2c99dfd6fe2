"""The QP of one control step from a state's kinematics, in compiled code: what every robot's
compiled QP step shares once its kinematics are computed (iRAM!S: `qp_kernels`, a serial arm:
`arm_qp_kernels`), and the solve with DAQP's C function (`daqp_c`).

`assemble` writes the QP of `qp_problem.build_step` with the code the Python QP calls: the cost
`cost.weighted_cost` on the task Jacobian the caller leaves in the buffers (d X_ext / d x,
`cost.x_ext_jacobian`; a curved needle's d X_c / d x, 7 rows), the actuator bounds
(`actuator_bounds`: travel, speed over dt, lambda in [0, 1]), then the rows G x <= h of the RCM
box (`rcm_rows`), the retina barrier (`sphere_row`, `contact_floor`), the singular margin
(`damper_rows`), the tip's speed (`speed_rows`) and the extra limits in the solver's order
(`box_rows`, `sphere_row`), or the RCM as an equality A x = b when its tolerance is 0, last: the
order DAQP receives them from `qp_backends`. Variables x = (ds[active], l dlambda) / SCALE, w of
them; the kinematics arrive as JT (8, w) = (J_tip T, J_rcm T, the needle angles' rows times T)
and the points (5, 3): tip, RCM point, needle axis (rows 3, 4 are scratch). A target is X_ext
(6,) or a curved needle's X_c (7,): its tip `needle.target_tip_into`'s, its trocar its last
three.

Settings travel as one float64 vector Q (`qp_params`), retina contact points as a (k, 3)
array, and the buffers of one solve as the tuple `qp` of `buffers(w)`.
"""

from __future__ import annotations

import math

import numpy as np

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.compiled.daqp_c import (
    EQUALITY,
    INF,
    PROBLEM_WORDS,
    RESULT_WORDS,
    default_settings,
    quadprog,
)
from rcmplan.compiled.packed import int32s, ints, mat, vec
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
from rcmplan.control.cost import synchronise, weighted_cost
from rcmplan.control.limits.actuators import actuator_bounds
from rcmplan.control.limits.base import SCALE, SPEED_ACTIVE
from rcmplan.control.limits.rcm import rcm_rows
from rcmplan.control.limits.retina import contact_floor
from rcmplan.control.limits.rows import damper_rows, radial_gap, sphere_row
from rcmplan.control.limits.tip_speed import speed_rows
from rcmplan.control.limits.workspace import box_rows
from rcmplan.robot.needle import target_tip_into

MAX_SINGULAR = 2  # singular terms of a robot (iRAM!S: cos q1, cos q3; an arm: its measure)
MAX_ROWS = 4 + 1 + MAX_SINGULAR + 6 + 6 * MAX_EXTRA  # RCM box, retina, singular, tip, extras

X = 10  # index of the solution x in `buffers()`
POINTS = 16  # index of the points (tip, RCM, axis, target tip, scratch) in `buffers()`
N_BUFFERS = 20  # the arrays of `buffers()`


def buffers(w: int, k: int = 6) -> tuple:
    """The arrays one solve with w variables works in: the QP (H, f, A, upper, lower, sense),
    the task Jacobian (k, w) d X / d x (X_ext: k = 6; X_c: 7), T (w, w), the Jacobians J (6, w),
    scratch (6,); DAQP's x,
    duals, problem, result and settings (`daqp_c.quadprog`); JT (8, w): J T's tip rows, RCM
    rows and the angle rows; the points (5, 3): tip, RCM, needle axis, target tip, the target's
    axis; N (2, 3) and the singular terms' gradients (MAX_SINGULAR, w), scratch of the rows;
    M (w + 1, w), the scratch of `cost.synchronise`."""
    rows = w + MAX_ROWS
    return (np.empty((w, w)), np.empty(w), np.zeros((MAX_ROWS, w)), np.empty(rows),
            np.empty(rows), np.zeros(rows, dtype=np.int32), np.empty((k, w)), np.zeros((w, w)),
            np.empty((6, w)), np.empty(6), np.empty(w), np.empty(rows),
            np.zeros(PROBLEM_WORDS, dtype=np.int64), np.zeros(RESULT_WORDS, dtype=np.int64),
            default_settings(), np.empty((8, w)), np.empty((5, 3)), np.empty((2, 3)),
            np.empty((MAX_SINGULAR, w)), np.empty((w + 1, w)))  # fmt: skip


@njit(cache=True, inline="always")
def views(F: FloatArray, Z: np.ndarray, k: int) -> tuple:
    """`buffers`' arrays as views of the buffers `packed.pack` made, from its array k on."""
    return (mat(F, Z, k), vec(F, Z, k + 1), mat(F, Z, k + 2), vec(F, Z, k + 3),
            vec(F, Z, k + 4), int32s(Z, k + 5), mat(F, Z, k + 6), mat(F, Z, k + 7),
            mat(F, Z, k + 8), vec(F, Z, k + 9), vec(F, Z, k + 10), vec(F, Z, k + 11),
            ints(Z, k + 12), ints(Z, k + 13), vec(F, Z, k + 14), mat(F, Z, k + 15),
            mat(F, Z, k + 16), mat(F, Z, k + 17), mat(F, Z, k + 18),
            mat(F, Z, k + 19))  # fmt: skip


@njit(cache=True, borrows=True)
def retina_floor(Q: FloatArray, contacts: FloatArray, target: FloatArray, tip: FloatArray,
                 a: FloatArray, tip_t: FloatArray) -> float:  # fmt: skip
    """`RetinaBarrier.floor`: the retina gap [m] a step from the tip (3,) keeps towards the
    target; NaN without an eye or while the tip is in the port zone. a and tip_t (3,) are
    scratch; tip_t then holds the target's tip."""
    if Q[HAS_EYE] == 0.0 or radial_gap(Q[PORT : PORT + 3], Q[PORT_ZONE], tip) >= 0.0:
        return math.nan
    target_tip_into(target, a, tip_t)  # the loop has refused targets that fix no tip
    return contact_floor(Q[RETINA_MARGIN], radial_gap(Q[CENTER : CENTER + 3], Q[RETINA_RADIUS],
                         tip_t), tip_t, contacts, Q[CONTACT_TOL])  # fmt: skip


@njit(cache=True, borrows=True)
def retina_row(Q: FloatArray, contacts: FloatArray, pts: FloatArray, JT: FloatArray,
               target: FloatArray, A: FloatArray, h: FloatArray, r: int) -> int:  # fmt: skip
    """The retina barrier's row at r (`RetinaBarrier`), or none; returns the next row."""
    tip = pts[0]
    floor = retina_floor(Q, contacts, target, tip, pts[4], pts[3])
    if math.isnan(floor):
        return r
    center = Q[CENTER : CENTER + 3]
    return sphere_row(JT[:3], tip, center, radial_gap(center, Q[RETINA_RADIUS], tip), floor,
                      Q[EYE_GAIN], Q[RETINA_RECOVERY], A, h, r)  # fmt: skip


@njit(cache=True, borrows=True)
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


@njit(cache=True, borrows=True)
def assemble(Q: FloatArray, contacts: FloatArray, K: FloatArray, lam: float,
             target: FloatArray, e: FloatArray, s: FloatArray, lower: FloatArray,
             upper: FloatArray, length: float, values: FloatArray, qp: tuple) -> int:  # fmt: skip
    """The step's QP into the buffers (see the module docstring), from the task's error e (k,)
    and its Jacobian d X / d (x SCALE) in qp's task rows (k, w) (X_ext: 6; X_c: 7), the active
    actuators s (w - 1,) with their travel [lower, upper], the needle length l [m],
    the singular terms' values (k,) with their gradients d value / d (x SCALE) in qp's
    gradient rows, and the kinematics in qp's JT and points. Returns the number of rows of A
    (inequalities first; an RCM equality last, marked in `sense`)."""
    H, f, A, up, lo, sense, task_ = qp[:7]
    JT, pts, N, grads = qp[15:19]
    nb, k = H.shape[0], task_.shape[0]
    weighted_cost(task_, Q[WEIGHTS : WEIGHTS + k], K, e, Q[DAMPING], H, f)
    actuator_bounds(s, lower, upper, Q[SPEED : SPEED + nb - 1], Q[TRAVEL_MARGIN], Q[DT], lam,
                    length, lo[:nb], up[:nb])  # fmt: skip
    h = up[nb:]
    tol = Q[RCM_TOL]
    trocar = target[target.shape[0] - 3 :]
    r = 0 if tol == 0.0 else rcm_rows(JT[3:6], pts[1], trocar, pts[2], tol, N, A, h, 0)
    r = retina_row(Q, contacts, pts, JT, target, A, h, r)
    r = damper_rows(grads[: values.shape[0]], values, Q[SINGULAR_FLOOR], Q[SINGULAR_GAIN], A,
                    h, r)  # fmt: skip
    if Q[TIP_STEP] > 0.0:
        r = speed_rows(JT[:3], Q[TIP_STEP], A, h, r)
    r = extra_rows(Q, pts, JT, A, h, r)
    for i in range(nb + r):
        sense[i] = 0
        if i >= nb:
            lo[i] = -INF
    if tol == 0.0:
        end = rcm_rows(JT[3:6], pts[1], trocar, pts[2], 0.0, N, A, h, r)
        for i in range(nb + r, nb + end):
            lo[i], sense[i] = up[i], EQUALITY
        r = end
    return r


@njit(cache=True, borrows=True)
def full_speed(Q: FloatArray, x: FloatArray) -> bool:
    """True if an active actuator moves at its full speed over dt in the solution x (w,), the
    last variable lambda's (`QpSolver.speed_limited`)."""
    for j in range(x.shape[0] - 1):
        if abs(x[j]) >= (1.0 - SPEED_ACTIVE) * (Q[SPEED + j] * Q[DT] / SCALE):
            return True
    return False


@njit(cache=True, borrows=True)
def solve_assembled(Q: FloatArray, K: FloatArray, rows: int, e: FloatArray, qp: tuple) -> int:
    """Solve the QP `assemble` left in the buffers; returns DAQP's exit flag (1: optimal). The
    solution is in qp[X]; e (k,), the task's error on entry, becomes the error a feasible step
    removes, J x* / K, unless an actuator moves at full speed (`QpSolver.error`)."""
    H, f, A, up, lo, sense, task_ = qp[:7]
    x, lam_d, problem, result, settings = qp[10:15]
    nb = H.shape[0]
    flag = quadprog(H, f, A, up, lo, sense, nb, rows, x, lam_d, problem, result, settings)
    if flag != 1 or full_speed(Q, x):  # a step at full speed leaves the plain error
        return flag
    for i in range(task_.shape[0]):
        acc = 0.0
        for j in range(nb):
            acc += (task_[i, j] * SCALE) * x[j]
        e[i] = acc / K[i]
    return flag


@njit(cache=True, borrows=True)
def solve_planned(Q: FloatArray, K: FloatArray, rows: int, e: FloatArray, e_plan: FloatArray,
                  qp: tuple) -> int:  # fmt: skip
    """`solve_assembled` for a step built at a servo's planned command (`QpSolver`'s `servo`):
    e (k,), the task's error at the plan (X_ext's or X_c's), kept in e_plan (k,), the cost
    synchronised to the actuators' speed window (`cost.synchronise`, `qp.synchronised_step`);
    returns DAQP's exit flag."""
    for i in range(e.shape[0]):
        e_plan[i] = e[i]
    nb = qp[0].shape[0]
    synchronise(qp[0], qp[1], Q[SPEED : SPEED + nb - 1], Q[DT], qp[19])
    return solve_assembled(Q, K, rows, e, qp)


@njit(cache=True, borrows=True)
def lead_error(Q: FloatArray, x: FloatArray, now: FloatArray, e_plan: FloatArray,
               e: FloatArray) -> None:  # fmt: skip
    """`QpSolver.error` with a servo, from a `solve_planned` solution x: e (k,) plus the
    command's lead (the task's error at the measured joints, now (k,), less the one at the
    plan, e_plan), or that error itself when an actuator moves at full speed."""
    limited = full_speed(Q, x)
    for i in range(e.shape[0]):
        e[i] = now[i] if limited else e[i] + (now[i] - e_plan[i])
