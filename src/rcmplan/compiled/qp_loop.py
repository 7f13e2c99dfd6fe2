"""Algorithm 1 with the QP controller on the kinematic plant, compiled: a phase in one call.

Each iteration does what `Controller.converge` does with a `QpSolver` and a `KinematicPlant`,
in the same order: read sliders, joints through the PCJMs, drift correction, the QP built and
solved at this state (its solution gives the error, J x* / K, and the step), record (from the
second iteration on), per-component tolerance check, iteration cap, singularity check, the
step through the actuator map, travel check, command and advance. The record helpers and the
record layout are the compiled loop's (`loop.py`, `records.REC_COLUMNS`).

A solve that DAQP does not finish optimally stops the loop with QP_FAILED and DAQP's exit flag
in info[2]; `qp_phase` repeats that solve on the reference path, which raises its QPError.
"""

from __future__ import annotations

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.compiled.kernels import njit
from rcmplan.compiled.loop import (
    bound_rcm_step,
    closest_lambda,
    command_status,
    converged,
    keep_record,
    put,
    record,
    target_frame,
)
from rcmplan.compiled.qp_kernels import X, solve_step, step_joints
from rcmplan.compiled.records import (
    DONE,
    NO_CONVERGENCE,
    NO_TIP,
    PAUSED,
    QP_FAILED,
    SINGULAR,
    STEPPED,
)
from rcmplan.robot.iramis_kernels import joints_from_actuators, trig


@njit(cache=True)
def iterate_qp(
    P: FloatArray, Q: FloatArray, contacts: FloatArray, K: FloatArray, tol: FloatArray,
    max_it: int, drift: bool, bounds: FloatArray, target: FloatArray, tip_t: FloatArray,
    trocar: FloatArray, s: FloatArray, state: FloatArray, it: int, row: FloatArray,
    fail: FloatArray, info: np.ndarray, w: FloatArray, qp: tuple,
) -> int:  # fmt: skip
    """One iteration from sliders s (see the module docstring); returns DONE, STEPPED (the
    next command in fail[12:18]) or a stop code. state = (lambda, time [s], dt [s]); fail
    holds (q, q_new, s_new, error) and fail[24:30] the actuators the QP was built at."""
    q, e, s_qp = fail[0:6], fail[18:24], fail[24:30]
    joints_from_actuators(P, s, q)
    tr = trig(q)
    if drift:
        state[0] = closest_lambda(P, q, tr, trocar, w)
    flag = solve_step(P, Q, contacts, K, q, tr, state[0], target, s_qp, e, qp)
    if flag != 1:
        info[2] = flag
        return QP_FAILED
    return record_and_step(P, tol, max_it, bounds, tip_t, trocar, s, state, it, row, fail,
                           info, w, q, tr, e, s_qp, qp[X])  # fmt: skip


@njit(cache=True)
def record_and_step(
    P: FloatArray, tol: FloatArray, max_it: int, bounds: FloatArray, tip_t: FloatArray,
    trocar: FloatArray, s: FloatArray, state: FloatArray, it: int, row: FloatArray,
    fail: FloatArray, info: np.ndarray, w: FloatArray, q: FloatArray, tr: tuple, e: FloatArray,
    s_qp: FloatArray, x: FloatArray,
) -> int:  # fmt: skip
    """The end of a QP iteration once its error e is known (Algorithm 1, as
    `Controller.converge`): the record (from the second iteration on), the tolerance check, the
    iteration cap, the singularity check, then the step from the actuators s_qp the QP was
    built at (`step_command`)."""
    if it > 0:
        record(P, row, state[1], s, q, tr, state[0], trocar, tip_t, e, 6)
    if converged(e, tol, 6):
        return DONE
    if it == max_it:
        return NO_CONVERGENCE
    if min(abs(tr[0]), abs(tr[2])) < bounds[0]:
        return SINGULAR
    return step_command(P, q, s_qp, x, trocar, bounds, state, fail, info, w)


@njit(cache=True)
def step_command(
    P: FloatArray, q: FloatArray, s_qp: FloatArray, x: FloatArray, trocar: FloatArray,
    bounds: FloatArray, state: FloatArray, fail: FloatArray, info: np.ndarray, w: FloatArray,
) -> int:  # fmt: skip
    """The step of the QP's solution x built at actuators s_qp, from joints q: bounded from
    the RCM tolerance, lambda moved in state[0], the joints and sliders commanded in fail[6:12]
    and fail[12:18]; returns STEPPED or a stop code (`loop.command_status`)."""
    qn, sn = fail[6:12], fail[12:18]
    dlam = step_joints(P, q, s_qp, x, qn, w)
    for i in range(5):  # the step in joints and lambda, bounded from the RCM tolerance
        sn[i] = qn[i] - q[i]
    sn[5] = dlam
    if bound_rcm_step(P, q, sn, 5, trocar, bounds[1], w, qn) != 1.0:
        for i in range(5):
            qn[i] = q[i] + sn[i]
    else:
        step_joints(P, q, s_qp, x, qn, w)  # qn as the QP's step left it
    state[0] += sn[5]
    return command_status(P, qn, sn, info)


@njit(cache=True)
def run_targets_qp(
    P: FloatArray, Q: FloatArray, contacts: FloatArray, K: FloatArray, tol: FloatArray,
    max_it: int, drift: bool, bounds: FloatArray, targets: FloatArray, k0: int, s: FloatArray,
    state: FloatArray, rec: FloatArray, irec: np.ndarray, info: np.ndarray, fail: FloatArray,
    qp: tuple,
) -> int:  # fmt: skip
    """Algorithm 1 with the QP on targets[k0:] from sliders s, on the kinematic plant; returns
    a status, as `loop.run_targets` does (same state, info, records and PAUSED protocol)."""
    w = np.empty(6)
    trocar, tip_t = np.full(3, np.nan), np.empty(3)
    n, cap = 0, rec.shape[0]
    for k in range(k0, targets.shape[0]):
        info[0], info[1] = n, k
        if n + max_it > cap:
            return PAUSED
        if target_frame(targets[k], True, w, tip_t, trocar) < 0:
            return NO_TIP
        for it in range(max_it + 1):
            status = iterate_qp(P, Q, contacts, K, tol, max_it, drift, bounds, targets[k], tip_t,
                                trocar, s, state, it, rec[n], fail, info, w, qp)  # fmt: skip
            n = keep_record(status, k, it, n, irec, info)
            if status == DONE:
                break
            if status != STEPPED:
                return status
            put(s, 0, fail, 12, 6)  # the kinematic plant reaches the command
            state[1] += state[2]
    info[0], info[1] = n, targets.shape[0]
    return DONE
