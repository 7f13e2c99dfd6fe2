"""Algorithm 1 with the QP controller closed around the dynamic MuJoCo plant, compiled.

Each control period the compiled loop reads the simulated sliders and runs one iteration of
what `Controller.converge` does with a `QpSolver` whose `servo` is the plant (`control/qp.py`'s
module docstring), in the same order: joints through the PCJMs, drift correction, the QP built
at the joints of the plant's last command rounded to the slider resolution, its cost
synchronised to the speed window and solved by DAQP's C function (`qp_kernels.solve_servo_step`,
which the compiled per-period step `qp_period` calls too); the error J x* / K plus the command's
lead X(measured) - X(planned), or the plain X_ext error at the measured joints when an actuator
moves at full speed (`qp_rows.full_speed`); record (from the second iteration on), tolerance
check, iteration cap, singularity check, the step from the planned actuators to the measured
joints (`qp_loop.step_command`), then the plant's period (`sim.mujoco.compiled.advance`: the
physics through MuJoCo's C functions). Python is back only between record blocks.

A solve that DAQP does not finish optimally stops the loop with QP_FAILED and DAQP's exit flag
in info[2]; `qp_mujoco_phase` repeats that solve on the reference path, which raises its
QPError. Needs numba, DAQP and MuJoCo.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

from rcmplan._validate import FloatArray
from rcmplan.compiled.kernels import task
from rcmplan.compiled.loop import closest_lambda, keep_record, put, target_frame
from rcmplan.compiled.mujoco_loop import read_sliders
from rcmplan.compiled.qp_kernels import X, solve_servo_step
from rcmplan.compiled.qp_loop import record_and_step
from rcmplan.compiled.qp_rows import lead_error
from rcmplan.compiled.records import DONE, NO_TIP, PAUSED, PLANT_STOPPED, QP_FAILED, STEPPED
from rcmplan.robot.iramis_kernels import joints_from_actuators, trig
from rcmplan.sim.mujoco.compiled import OK, advance

FAIL_WIDTH = 48  # (q, q_new, s_new, error, s_qp, error at the plan, q at the plan, scratch)


@njit(cache=True)
def iterate_qp_servo(
    P: FloatArray, Q: FloatArray, contacts: FloatArray, K: FloatArray, tol: FloatArray,
    max_it: int, drift: bool, bounds: FloatArray, target: FloatArray, tip_t: FloatArray,
    trocar: FloatArray, s: FloatArray, cmd: FloatArray, res: FloatArray, state: FloatArray,
    it: int, row: FloatArray, fail: FloatArray, info: np.ndarray, w: FloatArray, qp: tuple,
) -> int:  # fmt: skip
    """One iteration from the measured sliders s with the last command cmd (6,) and the slider
    resolution res (6,) (see the module docstring); returns DONE, STEPPED (the next command in
    fail[12:18]) or a stop code. state = (lambda, time [s], dt [s])."""
    q, e, s_qp = fail[0:6], fail[18:24], fail[24:30]
    e_plan, q_plan, x_now = fail[30:36], fail[36:42], fail[42:48]
    joints_from_actuators(P, s, q)
    tr = trig(q)
    if drift:
        state[0] = closest_lambda(P, q, tr, trocar, w)
    for i in range(6):  # the command as the plant rounds it (`QpSolver.planned_joints`)
        x_now[i] = np.rint(cmd[i] / res[i]) * res[i]
    joints_from_actuators(P, x_now, q_plan)
    flag = solve_servo_step(P, Q, contacts, K, q_plan, trig(q_plan), state[0], target, s_qp, e,
                            e_plan, qp)  # fmt: skip
    if flag != 1:
        info[2] = flag
        return QP_FAILED
    task(P, q, tr, state[0], x_now)  # X_ext at the measured joints
    lead_error(Q, qp[X], target, x_now, e_plan, e)
    return record_and_step(P, tol, max_it, bounds, tip_t, trocar, s, state, it, row, fail,
                           info, w, q, tr, e, s_qp, qp[X])  # fmt: skip


@njit(cache=True)
def run_targets_qp_on_mujoco(
    P: FloatArray, Q: FloatArray, contacts: FloatArray, K: FloatArray, tol: FloatArray,
    max_it: int, drift: bool, bounds: FloatArray, targets: FloatArray, k0: int, it0: int,
    s: FloatArray, cmd: FloatArray, res: FloatArray, state: FloatArray, rec: FloatArray,
    irec: NDArray[np.int64], info: NDArray[np.int64], fail: FloatArray, qp: tuple,
    slider_qpos: NDArray[np.intp], fns: NDArray[np.intp], model: int, data: int,
    substeps: int, dt: float, steps: FloatArray, speed: FloatArray, ramp: float, gap2: float,
    act: FloatArray, ctrl: FloatArray, qpos: FloatArray, qvel: FloatArray, xpos: FloatArray,
    warn: NDArray[np.int32], act_idx: NDArray[np.intp], servo: NDArray[np.intp],
    feedforward: NDArray[np.intp], slot: NDArray[np.intp], pin: NDArray[np.intp],
) -> int:  # fmt: skip
    """Algorithm 1 with the QP on targets[k0:] (from iteration it0 of target k0) on the MuJoCo
    plant; cmd (6,) holds the plant's last slider command. Records, info and the PAUSED
    protocol are `mujoco_loop.run_targets_on_mujoco`'s."""
    w, v = np.empty(6), np.empty(6)
    trocar, tip_t = np.full(3, np.nan), np.empty(3)
    n = 0
    for k in range(k0, targets.shape[0]):
        info[0], info[1] = n, k
        if target_frame(targets[k], True, w, tip_t, trocar) < 0:
            return NO_TIP
        for it in range(it0 if k == k0 else 0, max_it + 1):
            if not read_sliders(n, k, it, rec, info, s, qpos, slider_qpos):
                return PAUSED
            status = iterate_qp_servo(P, Q, contacts, K, tol, max_it, drift, bounds,
                                      targets[k], tip_t, trocar, s, cmd, res, state, it, rec[n],
                                      fail, info, w, qp)  # fmt: skip
            n = keep_record(status, k, it, n, irec, info)
            if status == DONE:
                break
            if status != STEPPED:
                info[1] = k
                return status
            put(cmd, 0, fail, 12, 6)
            code = advance(cmd, v, fns, model, data, substeps, dt, steps, speed, ramp, gap2,
                           act, ctrl, qpos, qvel, xpos, warn, act_idx, servo, feedforward, slot,
                           pin)  # fmt: skip
            state[1] += state[2]
            if code != OK:
                info[1], info[2] = k, code
                return PLANT_STOPPED
    info[0], info[1] = n, targets.shape[0]
    return DONE
