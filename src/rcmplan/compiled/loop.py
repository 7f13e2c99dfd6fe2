"""Algorithm 1's iteration on iRAM!S, compiled: `iterate`, as `Controller.converge` does it.

Each iteration does what the reference loop does, in the same order: joints from the sliders
through the PCJMs, drift correction (lambda of the needle point closest to the trocar), task
error, record (from the second iteration on), per-component tolerance check, iteration cap,
singularity check, step, sliders from joints and travel check. The loop over a phase's targets,
reading and commanding the plant, is `algorithm.run_targets` (one loop for every robot and
every plant; a plant stepping in Python gets one iteration per call, `phase.run_phase_per_period`).

The kernel stops with a status code instead of raising; `rcmplan.compiled.runner` turns the code
into the reference exception. Records go to preallocated arrays: `rec` (cap, 35) with columns
`REC_COLUMNS` (`rcmplan.compiled.records`), `irec` (cap, 2) with (step, iteration).

The QP controller (method QP) takes the same loop: its error (J x* / K) and step come from one
solve (`qp_kernels.iteration_error`, planned from the plant's last command when the plant is
the QP's servo) in place of the error and step kernels, the step then bounded from the RCM
tolerance (`qp_step`); `qpa` carries what the solve reads (`qp_kernels.loop_qp`), and a solve
DAQP does not finish optimally stops the loop with QP_FAILED (DAQP's exit flag in info[2]).
The QP's free-space step (TIP_LIMITED, `LimitedTipSolver`) is the TIP step scaled in actuator
space to hold each actuator's speed and travel less the margin (`limit_step`); K then carries
those bounds (`records.iramis_method`).

A curved needle (`CurvedTipRobot` on iRAM!S, method codes from CURVED on) takes the same loop:
its error and step come from `curved_step`, its tip from `curved_iramis` (P then carries the
arc, `curved_iramis.params`), the roll q5 moves with the other joints, records have the roll
error column (`record_width(6, roll=True)`) and `fail` holds a 7-row error (`records.FAIL_WIDTH`).
"""

from __future__ import annotations

import math

import numpy as np

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.compiled.kernels import jacobian_a, solve_augmented, task
from rcmplan.compiled.packed import mat, vec
from rcmplan.compiled.qp_kernels import X, iteration_error, step_joints
from rcmplan.compiled.qp_rows import N_BUFFERS, views
from rcmplan.compiled.rcm_bound import bound_step, hold_box
from rcmplan.compiled.records import (
    BAD_JOINTS,
    CURVED,
    CURVED_POSE,
    CURVED_POSE_LIMITED,
    CURVED_QP,
    DLS,
    DONE,
    NO_CONVERGENCE,
    PINV_THESIS,
    QP,
    QP_FAILED,
    SINGULAR,
    SLIDER_LIMIT,
    STEPPED,
    TIP,
    TIP_LIMITED,
)
from rcmplan.control import curved_step
from rcmplan.control.dls_task import dls_error, is_pivot
from rcmplan.control.limited_tip import step_fraction, tip_fraction
from rcmplan.linalg import damped
from rcmplan.robot import curved_iramis
from rcmplan.robot.curved_block import B, S
from rcmplan.robot.iramis_kernels import (
    actuators_from_joints,
    first_beyond_travel,
    joints_from_actuators,
    point,
    point_jacobian,
    pose_joints,
    singular_measure,
    tip_jacobian,
    trig,
)
from rcmplan.robot.needle import axis_into, closest_point, target_tip_into, x_ext_tip


@njit(cache=True, borrows=True)
def put(dst: FloatArray, i: int, src: FloatArray, j: int, n: int) -> None:
    """dst[i:i+n] = src[j:j+n] (explicit: slice assignment is slow to compile)."""
    for k in range(n):
        dst[i + k] = src[j + k]


@njit(cache=True, inline="always")
def holds_rcm(method: int) -> bool:
    """True for a method with RCM targets (False: the free-space tip and whole-pose solvers)."""
    return method not in (TIP, TIP_LIMITED, CURVED_POSE, CURVED_POSE_LIMITED)


@njit(cache=True, inline="always")
def tip_only(method: int) -> bool:
    """True for the free-space tip steps (error and step on the tip position alone)."""
    return method in (TIP, TIP_LIMITED)


@njit(cache=True, borrows=True)
def closest_lambda(
    P: FloatArray, q: FloatArray, tr: tuple, trocar: FloatArray, w: FloatArray
) -> float:
    """lambda in [0, 1] of the needle point closest to the trocar; w (6,) is scratch."""
    point(P, q, tr, 0.0, w[:3])
    point(P, q, tr, 1.0, w[3:])
    return closest_point(w[:3], w[3:], trocar)[0]


@njit(cache=True, borrows=True)
def task_error(
    P: FloatArray, method: int, q: FloatArray, tr: tuple, lam: float, target: FloatArray,
    tip_t: FloatArray, pivot: bool, e: FloatArray, w: FloatArray,
) -> int:  # fmt: skip
    """The solver's task error into e; returns its length (6, or 3 for the tip solver)."""
    if method <= PINV_THESIS:
        task(P, q, tr, lam, e)
        for i in range(6):
            e[i] = target[i] - e[i]
        return 6
    point(P, q, tr, 1.0, w[:3])
    if tip_only(method):
        for i in range(3):
            e[i] = target[i] - w[i]
        return 3
    if pivot:  # the target's axis
        axis_into(target[1], target[2], w[3:])
    p = (w[0], w[1], w[2])  # the tip
    point(P, q, tr, 0.0 if pivot else lam, w[:3])
    dls_error(tip_t, w[3:], pivot, P[5], target, p, w[:3], e)
    return 6


@njit(cache=True, borrows=True)
def solve_step(
    P: FloatArray, method: int, K: FloatArray, damping: float, q: FloatArray, tr: tuple,
    lam: float, pivot: bool, e: FloatArray, J: FloatArray, d: FloatArray,
) -> None:  # fmt: skip
    """The solver's step (dq0..dq4, dlambda) into d; J is the work block (`curved_block`:
    the Jacobian in rows 0.., the solves' scratch in rows S.. and B)."""
    if method <= PINV_THESIS:
        jacobian_a(P, q, tr, lam, method == PINV_THESIS, J)
        for i in range(6):
            J[B, i] = K[i] * e[i]
        solve_augmented(J, J[B], d)
        return
    tip_jacobian(P, q, tr, J, 0)
    rows = 6 if method == DLS else 3
    if method == DLS:
        point_jacobian(P, q, tr, 0.0 if pivot else lam, J, 3)
        if pivot:
            J[3, 5], J[4, 5], J[5, 5] = 0.0, 0.0, 0.0
    for i in range(rows):
        J[B, i] = e[i]
    damped(J, 0, rows, rows if method == DLS else 5, damping, S, B, d)
    if method != DLS:
        d[5] = 0.0


@njit(cache=True, borrows=True)
def record(
    P: FloatArray, row: FloatArray, t: float, s: FloatArray, q: FloatArray, tr: tuple, lam: float,
    trocar: FloatArray, tip_t: FloatArray, e: FloatArray, m: int,
) -> None:  # fmt: skip
    """One log record (see REC_COLUMNS) into row (35,)."""
    row[0] = t
    put(row, 1, s, 0, 6)
    put(row, 7, q, 0, 6)
    row[13] = lam
    point(P, q, tr, 1.0, row[14:17])
    point(P, q, tr, lam, row[17:20])
    put(row, 20, trocar, 0, 3)
    point(P, q, tr, 0.0, row[23:26])
    put(row, 26, tip_t, 0, 3)
    for i in range(29 + m, 35):
        row[i] = np.nan
    put(row, 29, e, 0, m)


@njit(cache=True, borrows=True)
def record_curved(
    P: FloatArray, row: FloatArray, t: float, s: FloatArray, q: FloatArray, tr: tuple, lam: float,
    trocar: FloatArray, tip_t: FloatArray, e: FloatArray,
) -> None:  # fmt: skip
    """A curved needle's record into row (36,): `record`'s fields with the arc's tip, the six
    position errors (tip, RCM) and the roll error last."""
    record(P, row, t, s, q, tr, lam, trocar, tip_t, e, 6)
    a, b = curved_iramis.axes(q, tr)
    row[14], row[15], row[16] = curved_iramis.tip_of(P, (row[23], row[24], row[25]), a, b)
    put(row, 32, e, 4, 3)
    row[35] = e[3]


@njit(cache=True, borrows=True)
def converged(e: FloatArray, tol: FloatArray, m: int) -> bool:
    """Every |e_i| within tol_i (False for NaN)."""
    for i in range(m):  # noqa: SIM110 (a plain loop compiles best)
        if not abs(e[i]) <= tol[i]:
            return False
    return True


@njit(cache=True, inline="always")
def iterate(
    P: FloatArray, method: int, K: FloatArray, damping: float, tol: FloatArray, max_it: int,
    drift: bool, bounds: FloatArray, qpa: tuple | None, C: FloatArray | None,
    target: FloatArray, pivot: bool, tip_t: FloatArray, trocar: FloatArray, s: FloatArray,
    state: FloatArray, it: int, row: FloatArray, fail: FloatArray, info: np.ndarray,
    w: FloatArray, d: FloatArray, f: FloatArray, J: FloatArray,
) -> int:  # fmt: skip
    """One iteration of Algorithm 1 from sliders s, as `Controller.converge` does it.

    Returns DONE (every error within tolerance), STEPPED (the next command is in fail[12:18])
    or a stop code. state = (lambda, time [s], dt [s]); lambda is updated. From the second
    iteration on the record goes to row (35,). fail (`records.FAIL_WIDTH`,) holds (q, q_new,
    s_new, error); a curved needle's rows and error have one more entry (the roll's), the QP's
    the actuators it was built at and its scratch after the error. J: the straight needle's
    work block (`curved_block`'s shape).

    qpa: the QP's arrays (`qp_kernels.loop_qp`) for the QP's methods only, else None; C: a
    curved needle's work block (`curved_block`) for its methods only, else None (checked). Each
    branch is picked by these arrays alone, and numba decides `is None` on an argument while it
    compiles: a loop without the QP or the curved needle compiles without their code (a first
    default run: `docs/benchmarks.md`, the cold compile row), and one with them without the
    other methods' code.
    """
    qp = method in (QP, CURVED_QP)
    if qp == (qpa is None) or (method >= CURVED) == (C is None):
        raise ValueError(
            "loop.iterate: QP methods need qpa, a curved needle's methods C, and no "
            "other method takes them"
        )
    q, qn, sn, e = fail[0:6], fail[6:12], fail[12:18], fail[18:]
    cm = CURVED_POSE if method == CURVED_POSE_LIMITED else method  # the curved step's method
    joints_from_actuators(P, s, q)
    tr = trig(q)
    if holds_rcm(method) and drift:
        state[0] = closest_lambda(P, q, tr, trocar, w)
    if qpa is not None:  # error and step from one solve
        info[2] = iteration_error(P, K, q, tr, state[0], target, fail, qpa, C)
        if info[2] != 1:
            return QP_FAILED
        m = 6 if C is None else 7
    elif C is not None:  # error and step: `curved_iramis`
        m = curved_step.iramis_task_error(P, cm, q, tr, state[0], target, e, w)
    else:
        m = task_error(P, method, q, tr, state[0], target, tip_t, pivot, e, w)
    if it > 0:
        if C is not None:
            record_curved(P, row, state[1], s, q, tr, state[0], trocar, tip_t, e)
        else:
            record(P, row, state[1], s, q, tr, state[0], trocar, tip_t, e, m)
    if converged(e, tol, m):
        return DONE
    if it == max_it:
        return NO_CONVERGENCE
    if singular_measure(tr[0], tr[2]) < bounds[0]:
        return SINGULAR
    if qpa is not None:  # a curved needle's QP moves the roll q5 too
        moved = 5 if C is None else 6
        return qp_step(P, K, q, target, trocar, moved, bounds, state, fail, qpa, C, info, w, d)
    moved = 5
    if C is not None:
        curved_step.iramis_step(P, cm, K, damping, q, tr, state[0], e, C, d, f)
        moved = 6  # a curved needle's roll q5 is active
    else:
        solve_step(P, method, K, damping, q, tr, state[0], pivot, e, J, d)
    if method == TIP_LIMITED:
        limit_step(P, K, q, d, moved, sn, qn, w, J)
    elif C is not None and method == CURVED_POSE_LIMITED:  # K: the gains (7,), the bounds
        limit_step(P, K[7:], q, d, moved, sn, qn, w, J)
    elif holds_rcm(method):
        bound_step(P, None, q, d, 0, moved, trocar, math.nan, bounds[1], qn, w)
    for i in range(6):
        qn[i] = q[i] + d[i] if i < moved else q[i]
    state[0] += d[moved]
    return command_status(P, qn, sn, info)


@njit(cache=True, borrows=True)
def limit_step(
    P: FloatArray,
    K: FloatArray,
    q: FloatArray,
    d: FloatArray,
    moved: int,
    s: FloatArray,
    x: FloatArray,
    ds: FloatArray,
    J: FloatArray,
) -> None:
    """`LimitedTipSolver.step` on the tip step d (dq0..dq4, moved = 5), or
    `LimitedPoseSolver.step` on the whole-pose step (dq0..dq5, moved = 6): the actuator
    increment ds of the step, from s = actuators(q), scaled by the largest f in [0, 1] keeping
    every actuator within its move per period K[i] and inside its travel less the margin K[6]
    (one outside that band may only move back), and with a tip speed bound K[7] > 0 (tip speed
    x dt) each component of the tip's first-order step J[:3, :5] d within it (J: the tip
    Jacobian the step left); d becomes joints(s + f ds) - q (`limited_tip.step_fraction`,
    `tip_fraction`). s, x, ds (6,) are scratch. A step no sliders realise is left as it is
    (the travel check then stops the loop)."""
    for i in range(6):
        x[i] = q[i] + d[i] if i < moved else q[i]
    if not actuators_from_joints(P, q, s) or not actuators_from_joints(P, x, ds):
        return
    for i in range(6):
        ds[i] -= s[i]
    f = step_fraction(s, ds, K[:6], P[7:13], P[13:19], K[6], tip_fraction(J, 0, d, moved, K[7]))
    for i in range(6):
        s[i] += f * ds[i]
    joints_from_actuators(P, s, x)
    for i in range(moved):
        d[i] = x[i] - q[i]


@njit(cache=True, borrows=True)
def period_step(P: FloatArray, K: FloatArray, q: FloatArray, lam: float, target: FloatArray,
                fail: FloatArray, qpa: tuple, w: FloatArray, d: FloatArray) -> int:  # fmt: skip
    """`QpSolver.step` at joints q, lambda towards the X_ext target (6,) as the loop takes it
    (`iteration_error`, `rcm_bound.hold_box`), for a caller that steps one period at a time
    (`qp_period.period_step`); returns DAQP's exit flag, the step in d (6,) when 1. fail
    (`records.FAIL_WIDTH`,) and w (6,) are scratch."""
    for i in range(6):
        fail[i] = q[i]
    flag = iteration_error(P, K, fail[0:6], trig(q), lam, target, fail, qpa, None)
    if flag == 1:
        hold_box(P, None, K, fail[0:6], lam, target, target[3:6], math.nan, 0, 5, fail, qpa,
                 qpa[0], None, d, d, fail[6:12], w)  # fmt: skip
    return flag


# Inlined into period_packed, as `arm_qp_kernels.step_arrays` into the arm's step.
@njit(cache=True, inline="always")
def period_arrays(F: FloatArray, Z: np.ndarray) -> tuple:
    """Views of the arrays `packed.pack` holds in F and Z, in `qp_period.period_buffers`'
    order: (P, K, fail, qpa, w, d), qpa as `qp_kernels.loop_qp` makes it."""
    end = 7 + N_BUFFERS  # the solve's buffers from array 7 on, then the servo's two
    qpa = (vec(F, Z, 5), mat(F, Z, 6), views(F, Z, 7), vec(F, Z, end), vec(F, Z, end + 1))
    return vec(F, Z, 0), vec(F, Z, 1), vec(F, Z, 2), qpa, vec(F, Z, 3), vec(F, Z, 4)


@njit(cache=True, borrows=True)
def period_packed(F: FloatArray, Z: np.ndarray, q: FloatArray, lam: float,
                  target: FloatArray) -> int:  # fmt: skip
    """`period_step` on the arrays packed in F and Z (`period_arrays`): a call from Python
    passes two buffers instead of some thirty arrays (`packed`)."""
    P, K, fail, qpa, w, d = period_arrays(F, Z)
    return period_step(P, K, q, lam, target, fail, qpa, w, d)


@njit(cache=True, borrows=True)
def qp_step(
    P: FloatArray, K: FloatArray, q: FloatArray, target: FloatArray, trocar: FloatArray,
    moved: int, bounds: FloatArray, state: FloatArray, fail: FloatArray, qpa: tuple,
    C: FloatArray | None, info: np.ndarray, w: FloatArray, d: FloatArray,
) -> int:  # fmt: skip
    """The loop's QP step from joints q after its solve, moving joints 0..moved-1: the RCM box
    held on the true kinematics (`rcm_bound.hold_box`), then shortened from the loop's RCM
    tolerance (`rcm_bound.bound_step`); lambda moved in state[0], the joints and sliders
    commanded in fail[6:12] and fail[12:18]; returns STEPPED or a stop code
    (`command_status`)."""
    qn, sn, s_qp = fail[6:12], fail[12:18], fail[19 + moved : 25 + moved]
    f, _ = hold_box(P, None, K, q, state[0], target, trocar, math.nan, 0, moved, fail, qpa,
                    qpa[0], C, d, d, qn, w)  # fmt: skip
    if f * bound_step(P, None, q, d, 0, moved, trocar, math.nan, bounds[1], qn, w) != 1.0:
        for i in range(moved):
            qn[i] = q[i] + d[i]
    else:
        step_joints(P, q, s_qp, qpa[2][X], qn, w)  # qn as the QP's step left it
    state[0] += d[moved]
    return command_status(P, qn, sn, info)


@njit(cache=True, borrows=True)
def command_status(P: FloatArray, qn: FloatArray, sn: FloatArray, info: np.ndarray) -> int:
    """The sliders sn of the stepped joints qn, and the iteration's status: BAD_JOINTS if no
    sliders realise qn, SLIDER_LIMIT (the slider in info[2]) beyond travel, else STEPPED."""
    if not actuators_from_joints(P, qn, sn):
        return BAD_JOINTS
    info[2] = first_beyond_travel(P, sn)
    if info[2] >= 0:
        return SLIDER_LIMIT
    return STEPPED


@njit(cache=True, borrows=True)
def keep_record(status: int, k: int, it: int, n: int, irec: np.ndarray, info: np.ndarray) -> int:
    """Keep the record of iteration it of target k, written in row n: from the second
    iteration on and unless the solve failed (QP_FAILED, no record), its (target, iteration)
    go to irec[n]. Returns the records written, also in info[0]."""
    if it > 0 and status != QP_FAILED:
        irec[n, 0], irec[n, 1] = k, it
        n += 1
        info[0] = n
    return n


@njit(cache=True, borrows=True)
def target_frame(target: FloatArray, rcm: bool, w: FloatArray, tip_t: FloatArray,
                 trocar: FloatArray) -> int:  # fmt: skip
    """Fill the target's tip point and trocar (NaN in free space); returns 1 for a pivot
    target, 0 otherwise, and -1 (NO_TIP) when X_ext fixes no tip. A curved needle's target
    X_c (7,) states its tip (its first three entries) and ends with the trocar."""
    if not rcm:
        put(tip_t, 0, target, 0, 3)
        return 0
    put(trocar, 0, target, target.shape[0] - 3, 3)
    if not target_tip_into(target, w, tip_t):
        return -1
    return 1 if target.shape[0] == 6 and is_pivot(tip_t, target) else 0


@njit(cache=True, borrows=True)
def pose_clear(
    P: FloatArray, thr: float, x: FloatArray, a: FloatArray, tip: FloatArray, q: FloatArray,
    s: FloatArray,
) -> bool:  # fmt: skip
    """True if `solve_pose` surely accepts X_ext x: the same formulas, with a small margin."""
    margin = 1e-12
    for i in range(6):
        if not math.isfinite(x[i]):
            return False
    phi, psi = x[1], x[2]
    if singular_measure(math.cos(phi), math.cos(psi)) < thr + margin:
        return False
    if not x_ext_tip(x, a, tip) or abs(a[0]) < 2e-12:
        return False
    depth = 0.0
    for i in range(3):
        depth += (tip[i] - x[3 + i]) * a[i]
    lam = 1.0 - depth / P[5]
    if lam < -1e-9 + margin or lam > 1.0 + 1e-9 - margin:
        return False
    pose_joints(P, phi, psi, tip, q)
    if not actuators_from_joints(P, q, s):
        return False
    for i in range(6):  # noqa: SIM110
        if s[i] < P[7 + i] + margin or s[i] > P[13 + i] - margin:
            return False
    return True


@njit(cache=True)
def screen_targets(P: FloatArray, thr: float, targets: FloatArray, flags: np.ndarray) -> None:
    """flags[k] = True where X_ext target k may fail `solve_pose` (it must be checked there)."""
    a, tip, q, s = np.empty(3), np.empty(3), np.empty(6), np.empty(6)
    for k in range(targets.shape[0]):
        flags[k] = not pose_clear(P, thr, targets[k], a, tip, q, s)
