"""Algorithm 1's iteration on a serial arm, compiled: `arm_iterate`.

An iteration does what `Controller.converge` does between reading the plant and commanding it,
in the same order, from the joints q = s (an arm's actuators are its joints): frames (once),
drift correction (lambda of the needle point closest to the trocar), the solver's task error,
the record (from the second iteration on), the per-component tolerance check, the iteration
cap, the singularity check (`chain_kernels.is_singular`) and the solver's step, every quantity
read from the frames of that one pass; `command_status` then checks the command (finite,
within travel) as the plant would. The loop over a phase's targets, on every plant, is
`algorithm.run_targets` (one loop for every robot; a plant stepping in Python gets one
iteration per call, `phase.run_phase_per_period`). Imports numba.

Records go to preallocated rows in the `records.record_columns(n)` layout: time [s],
sliders (n,), joints (n,), lambda, tip, rcm, trocar, base, target tip (3 each) [m], error (6,)
NaN-padded. Stops return the status codes of `rcmplan.compiled.records`.

The QP controller (method QP, a `QpSolver` that `arm_qp.arm_qp_applies` accepts) takes the same
loop: its error (J x* / K) and step come from one solve (`arm_qp_kernels.solve_arm_step`) in place
of the error and step kernels (with a servo, planned from the plant's last command);
`qpa` carries what the solve reads (`arm_phase.qp_arrays`), and a solve
DAQP does not finish optimally stops the loop with QP_FAILED (DAQP's exit flag in qpa[5]).
A curved needle (method codes from CURVED on, the arrays of `rcmplan.compiled.curved`) takes the
same loop: its error, step and tip come from `curved_arm`, the roll joint moves with the others
(the curved needle's active joints), its rows have the roll error column
(`record_columns(n, roll=True)`) and `fail` a 7-row error. Its QP (CURVED_QP) solves on X_c's
rows (`arm_qp_kernels.solve_arm_step` given its work array), its QP's free-space step
(CURVED_POSE_LIMITED) is the whole-pose step limited as TIP_LIMITED limits the tip step
(`limit_step`).
"""

from __future__ import annotations

import math

import numpy as np

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.compiled.arm_qp_kernels import (
    step_arrays,
)
from rcmplan.compiled.chain_kernels import (
    ROWS,
    IntArray,
    dls_solve_at,
    frames,
    gram_solve,
    holds_frames,
    is_singular,
    jacobian_at,
    needle_axis,
    needle_point,
    pinv_solve,
)
from rcmplan.compiled.loop import converged, holds_rcm, tip_only
from rcmplan.compiled.rcm_bound import (
    arm_qp_solve,
    bound_step,
    closest_on_needle,
    hold_box,
    stepped,
)
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
    TIP_LIMITED,
)
from rcmplan.control import curved_step
from rcmplan.control.dls_task import dls_error
from rcmplan.control.limited_tip import step_fraction, tip_fraction
from rcmplan.robot import curved_arm
from rcmplan.robot.needle import axis_angles, axis_into


@njit(cache=True, borrows=True)
def task_error(A: FloatArray, ix: IntArray, W: FloatArray, method: int, lam: float,
               target: FloatArray, tip_t: FloatArray, pivot: bool,
               e: FloatArray) -> int:  # fmt: skip
    """The solver's error at the frames in W into e; returns its length (6, or 3 for the tip
    steps)."""
    n = ix[0]
    p_tip = needle_point(A, n, W, 1.0)
    if tip_only(method):
        for i in range(3):
            e[i] = target[i] - p_tip[i]
        return 3
    if method == DLS:
        a = W[4 * (n + 1) + 2 * ROWS]  # a vector row of W as scratch
        axis_into(target[1], target[2], a)
        p = needle_point(A, n, W, 0.0 if pivot else lam)
        dls_error(tip_t, a, pivot, A[5 * n + 12, 0], target, p_tip, p, e)
        return 6
    phi, psi = axis_angles(*needle_axis(A, n, W))
    p = needle_point(A, n, W, lam)
    x = (p_tip[0], phi, psi, p[0], p[1], p[2])
    for i in range(6):
        e[i] = target[i] - x[i]
    return 6


@njit(cache=True, borrows=True)
def record(A: FloatArray, n: int, W: FloatArray, row: FloatArray, t: float, s: FloatArray,
           lam: float, trocar: FloatArray, tip_t: FloatArray, e: FloatArray,
           ne: int) -> None:  # fmt: skip
    """One record into row (`record_width(n)`,); see the module docstring."""
    base, tip = needle_point(A, n, W, 0.0), needle_point(A, n, W, 1.0)
    row[0] = t
    for i in range(n):
        row[1 + i], row[1 + n + i] = s[i], s[i]
    o = 2 * n + 1
    row[o] = lam
    for i in range(3):
        row[o + 1 + i] = tip[i]
        row[o + 4 + i] = base[i] + lam * (tip[i] - base[i])
        row[o + 7 + i], row[o + 10 + i], row[o + 13 + i] = trocar[i], base[i], tip_t[i]
    for i in range(6):
        row[o + 16 + i] = e[i] if i < ne else np.nan


@njit(cache=True, borrows=True)
def record_curved(A: FloatArray, n: int, W: FloatArray, row: FloatArray, t: float,
                  s: FloatArray, lam: float, trocar: FloatArray, tip_t: FloatArray,
                  e: FloatArray) -> None:  # fmt: skip
    """A curved needle's record into row (`record_width(n, roll=True)`,): `record`'s fields
    with the arc's tip, the six position errors (tip, RCM) and the roll error last."""
    record(A, n, W, row, t, s, lam, trocar, tip_t, e, 6)
    o = 2 * n + 1
    row[o + 1], row[o + 2], row[o + 3] = curved_arm.tip(A, n, W)
    for i in range(3):
        row[o + 19 + i] = e[4 + i]
    row[o + 22] = e[3]


@njit(cache=True, borrows=True)
def step(A: FloatArray, ix: IntArray, W: FloatArray, method: int, K: FloatArray, gain: float,
         damping: float, s: FloatArray, lam: float, pivot: bool, e: FloatArray,
         d: FloatArray) -> None:  # fmt: skip
    """The solver's step d = (dq[active], dlambda) at joints s from its error e, at the frames
    in W (`PinvSolver`, `DlsSolver`, `TipSolver`), after the singularity check, which leaves
    d p(1) / d theta_ext in W's J rows 0..2."""
    n, m = ix[0], ix[1]
    o = 4 * (n + 1)
    if tip_only(method):
        gram_solve(W, o, 3, m, damping, e, d)
        d[m] = 0.0
    elif method == DLS:
        dls_solve_at(A, ix, W, lam, pivot, e, damping, d, True)
    else:
        jacobian_at(A, ix, W, lam, method == PINV_THESIS, W, o, True)
        pinv_solve(A, ix, W, s, K, gain, e, d)


@njit(cache=True, inline="always")  # inlined into `algorithm.run_targets`: a call costs ~0.2 us
def arm_iterate(
    A: FloatArray, ix: IntArray, method: int, K: FloatArray, gain: float, damping: float,
    tol: FloatArray, max_it: int, drift: bool, bounds: FloatArray, qpa: tuple | None,
    C: FloatArray | None, target: FloatArray, pivot: bool, tip_t: FloatArray,
    trocar: FloatArray, s: FloatArray, state: FloatArray, it: int, row: FloatArray,
    fail: FloatArray, W: FloatArray, d: FloatArray,
) -> int:  # fmt: skip
    """One iteration from joints s (n,). Returns DONE, STEPPED (the next joints in fail[n:2n]),
    NO_CONVERGENCE, SINGULAR or QP_FAILED. state = (lambda, time [s], ...); lambda is updated.
    fail holds (q (n,), q_new (n,), error (6,), or (7,) for a curved needle). qpa: the QP's
    arrays (`arm_phase.qp_arrays`) for the QP's methods only, else None; C: for a curved
    needle's methods only, its work array (W itself), else None (each picks its branches alone,
    so that numba leaves out the other methods' code: `loop.iterate`). The frames of s are
    computed unless W holds them (`holds_frames`: the last iteration's, or its step's RCM
    bound's when the plant reached that step exactly)."""
    qp = method in (QP, CURVED_QP)
    if qp == (qpa is None) or (method >= CURVED) == (C is None):
        raise ValueError(
            "arm_loop.arm_iterate: QP methods need qpa, a curved needle's methods "
            "C, and no other method takes them"
        )
    n, m = ix[0], ix[1]
    first = 2 + n  # the moving joints: the arm's active ones
    if C is not None:  # or the curved needle's (with the roll joint)
        first, m = curved_arm.active_span(ix)
    cm = CURVED_POSE if method == CURVED_POSE_LIMITED else method  # the curved step's method
    e = fail[2 * n :]
    for i in range(n):
        fail[i] = s[i]
    if not holds_frames(ix, s, W):
        frames(A, ix, s, W)
    now = 0.0  # the needle's distance to the trocar [m]
    if holds_rcm(method):
        lam, now = closest_on_needle(A, n, W, trocar)
        if drift:
            state[0] = lam
    if qpa is not None:  # error and step from one solve (`ArmQpStep`)
        ne = 6 if C is None else 7
        if arm_qp_solve(A, ix, W, C, qpa, K, s, state[0], target, e, d) != 1:
            return QP_FAILED
    elif C is not None:
        ne = curved_step.arm_task_error(A, ix, C, cm, state[0], target, e)
    else:
        ne = task_error(A, ix, W, method, state[0], target, tip_t, pivot, e)
    if it > 0:
        if C is not None:
            record_curved(A, n, C, row, state[1], s, state[0], trocar, tip_t, e)
        else:
            record(A, n, W, row, state[1], s, state[0], trocar, tip_t, e, ne)
    if converged(e, tol, ne):
        return DONE
    if it == max_it:
        return NO_CONVERGENCE
    if is_singular(A, ix, W, bounds[0]):
        return SINGULAR
    if qpa is not None:  # the solve's step, the RCM box held on the true kinematics
        hold_box(None, (A, ix, W), K, s, state[0], target, trocar, now, first, m, fail, qpa, qpa[1],
                 C, e, d, fail[n : 2 * n], d)  # fmt: skip
    elif C is not None:
        curved_step.arm_step(A, ix, C, cm, K, gain, damping, s, state[0], e, d)
    else:
        step(A, ix, W, method, K, gain, damping, s, state[0], pivot, e, d)
    if qpa is None and method == TIP_LIMITED:
        limit_step(K, ix, W, s, d, first, m, fail[n : 2 * n])
    elif C is not None and method == CURVED_POSE_LIMITED:  # K: the gains (7,), the bounds
        limit_step(K[7:], ix, W, s, d, first, m, fail[n : 2 * n])
    if holds_rcm(method):
        bound_step(None, (A, ix, W), s, d, first, m, trocar, now, bounds[1], fail[n : 2 * n], d)
    stepped(n, ix, first, m, s, d, fail[n : 2 * n])
    state[0] += d[m]
    return STEPPED


@njit(cache=True)
def held_packed(F: FloatArray, Z: IntArray, q: FloatArray, lam: float, target: FloatArray,
                fail: FloatArray, flag: IntArray) -> bool:  # fmt: skip
    """`rcm_bound.hold_box` on the solve `arm_qp_kernels.solve_packed` left in the buffers
    packed in F and Z at (q, lambda, target) (`ArmQpStep.step`); fail (2n,) and flag (1,) are
    scratch. Returns True if the step in the buffers changed (they then hold another solve,
    or a shorter step)."""
    A, ix, W, travel, Q, contacts, K, s, e, d, servo, qp = step_arrays(F, Z)
    n, m = ix[0], ix[1]
    qpa = (travel, Q, contacts, qp, s, flag, servo)
    f, narrower = hold_box(None, (A, ix, W), K, q, lam, target, target[3:6], math.nan, 2 + n, m,
                           fail, qpa, Q, None, e, d, fail[n : 2 * n], d)  # fmt: skip
    return f != 1.0 or narrower


@njit(cache=True, borrows=True)
def limit_step(K: FloatArray, ix: IntArray, W: FloatArray, s: FloatArray, d: FloatArray,
               first: int, m: int, x: FloatArray) -> None:  # fmt: skip
    """`LimitedTipSolver.step` on an arm (its actuators are its joints s), or
    `LimitedPoseSolver.step` on a curved needle's whole-pose step: the step d of the m moving
    joints ix[first:first + m] scaled by the largest f in [0, 1] that keeps each one's move
    within K[j] (speed x dt) and inside its travel [K[m + j], K[2m + j]] less the margin K[3m]
    (a joint outside that band may only move back), and with a tip speed bound K[3m + 1] > 0
    (tip speed x dt) each component of the tip's first-order step J_tip d (W's J rows, left
    by the tip step) within it; d becomes (s + f ds) - s, ds = (s + d) - s
    (`limited_tip.step_fraction`, `tip_fraction`). x (>= m,) is scratch."""
    n = ix[0]
    f = tip_fraction(W, 4 * (n + 1), d, m, K[3 * m + 1])
    s_active = x[:m]
    for j in range(m):
        k = ix[first + j]
        s_active[j] = s[k]
        d[j] = (s[k] + d[j]) - s[k]
    f = step_fraction(s_active, d[:m], K[:m], K[m : 2 * m], K[2 * m : 3 * m], K[3 * m], f)
    for j in range(m):
        k = ix[first + j]
        d[j] = (s[k] + f * d[j]) - s[k]


@njit(cache=True, borrows=True)
def command_status(fail: FloatArray, n: int, lower: FloatArray, upper: FloatArray,
                   info: IntArray) -> int:  # fmt: skip
    """STEPPED if the command q_new = fail[n:2n] is finite and within [lower, upper] (what the
    kinematic plant checks), else BAD_JOINTS, or SLIDER_LIMIT with the first joint beyond
    travel in info[2]."""
    for i in range(n):
        if not math.isfinite(fail[n + i]):
            return BAD_JOINTS
    for i in range(n):
        if fail[n + i] < lower[i] or fail[n + i] > upper[i]:
            info[2] = i
            return SLIDER_LIMIT
    return STEPPED
