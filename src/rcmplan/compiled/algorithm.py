"""Algorithm 1 over a phase's targets, compiled: one loop for every robot and both plants.

`run_targets` is the loop of `Controller.converge` over a phase: for each target, iterations
until every error is within tolerance, each one reading the plant, running one iteration of the
robot's kernels and, when it steps, commanding the plant. The robot comes as its kernel arrays,
in one of two arguments, the other None:

- P: iRAM!S's closed forms' parameter vector (`records.robot_params`; a curved needle's carry
  its arc), iterated by `loop.iterate` (the PCJM sliders are its actuators);
- arm: a serial arm's tuple (A, ix, posture gain, lower, upper, W, d) of its chain arrays
  (`arm.arm_arrays`, or a curved needle's), its joints' travel and its work arrays
  (`arm_phase._Setup`), iterated by `arm_loop.arm_iterate` (its joints are its actuators).

Each family's iteration stands in the loop under its own `is not None` guard: numba prunes a
branch on an argument that is None before it inlines the callees, so each family's loop
compiles with its own kinematics only (as the QP's and the curved needle's arrays, qpa and C,
leave out their methods' code), while the loop itself, its pausing, its records and its plants
are written once. Neither iteration is a compiled function of its own: numba would optimise its
whole callee tree once more in every caller (docs/benchmarks.md, the cold compile rows).

plant: the dynamic MuJoCo plant's arrays (`PlantArrays.loop_args`, iRAM!S's `MujocoPlant` or an
arm's `ArmPlant`): each period the loop reads the simulated actuators and runs the plant's
period towards the command (`sim.mujoco.compiled.advance`); or, with model address 0
(`exact_plant`), the kinematic plant: the actuators reach each command exactly and time moves
on by dt; or, with model address -1 (`stepping_plant`), a plant that steps in Python (a user's
own, MuJoCo's kinematic mode): the loop returns after each iteration (PAUSED, the command in
cmd), and its Python driver commands and advances the plant and calls it again
(`phase.run_phase_per_period`). Every plant runs the one loop.

The loop stops with a status code (`records`) instead of raising; the Python drivers
(`phase.run_in_blocks`) turn it into the reference exception. Records go to preallocated rows
in the `records.record_columns(n)` layout, `irec` (cap, 2) with (target, iteration).
"""

from __future__ import annotations

import numpy as np

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.compiled.arm_loop import arm_iterate, command_status
from rcmplan.compiled.loop import holds_rcm, iterate, keep_record, put, target_frame
from rcmplan.compiled.records import DONE, NO_TIP, PAUSED, PLANT_STOPPED, STEPPED
from rcmplan.robot.curved_block import BLOCK_ROWS
from rcmplan.sim.mujoco.compiled import OK, advance


def work_arrays(n: int) -> tuple[FloatArray, ...]:
    """The loop's scratch for n actuators (`run_targets`' `work`): iRAM!S's iteration's (w,
    d, f and its work block J), the plant's (w, v) and the target's trocar and tip."""
    return (np.empty(6), np.empty(7), np.empty(7), np.empty((BLOCK_ROWS, 7)), np.empty(6),
            np.empty((4, n)), np.empty(3), np.empty(3))  # fmt: skip


@njit(cache=True, borrows=True)
def run_targets(
    P: FloatArray | None, arm: tuple | None, method: int, K: FloatArray, damping: float,
    tol: FloatArray, max_it: int, drift: bool, bounds: FloatArray, qpa: tuple | None,
    C: FloatArray | None, targets: FloatArray, k0: int, it0: int, s: FloatArray,
    cmd: FloatArray, state: FloatArray, rec: FloatArray, irec: np.ndarray, info: np.ndarray,
    fail: FloatArray, plant: tuple, work: tuple,
) -> int:  # fmt: skip
    """Algorithm 1 on targets[k0:] (from iteration it0 of target k0); returns a status.

    P, arm: the robot's kernel arrays, one of them None (see the module docstring); method,
    K, damping, tol: the solver's code and constants (`records.solver_arrays`); bounds:
    (singularity threshold, RCM bound [m]); qpa: the QP's arrays for its methods, else None;
    C: a curved needle's work block for its methods, else None. s (n,) and state = (lambda,
    time [s], dt [s]) are updated in place; cmd (n,) holds the last command (for a QP planned
    from its servo, the servo's command array). On return info holds (records written, target
    index reached, actuator index for SLIDER_LIMIT, DAQP's exit flag for iRAM!S's QP_FAILED or
    the plant's check for PLANT_STOPPED) and fail the last iteration's joints, command and
    error. PAUSED means the record block rec is full, or (a plant stepping in Python) an
    iteration ran: call again from target info[1], iteration info[2]. work: the loop's
    scratch (`work_arrays(n)`, n = s.shape[0]).

    The loop allocates nothing and is compiled without reference counts (`_jit`'s borrows):
    the counts numba otherwise adds at every view it takes (a target's row, a record's row,
    the command's slice of fail) were the last ones of an iteration.
    """
    if P is None and arm is None:
        raise ValueError("algorithm.run_targets: give iRAM!S's P or an arm's arrays")
    na = s.shape[0]
    w6, d7, f7, J, w, v, trocar, tip_t = work
    if v.shape[1] != na:
        raise ValueError("algorithm.run_targets: work must be work_arrays(s.shape[0])")
    for i in range(3):  # no trocar until a target states one
        trocar[i] = np.nan
    reads, fns, address, data, substeps, dt, steps, speed, ramp, gap2 = plant[:10]
    clip_lo, clip_hi, act, ctrl, qpos, qvel, xpos, warn, act_idx, servo = plant[10:20]
    feedforward, slot, pin = plant[20:]
    n, once = 0, False  # once: an iteration ran, a plant stepping in Python reads again
    for k in range(k0, targets.shape[0]):
        info[0], info[1] = n, k
        kind = target_frame(targets[k], holds_rcm(method), w, tip_t, trocar)
        if kind < 0:
            return NO_TIP
        for it in range(it0 if k == k0 else 0, max_it + 1):
            if n == rec.shape[0] or once:
                info[0], info[1], info[2] = n, k, it
                return PAUSED
            if address > 0:  # the dynamic plant's measured actuators
                for i in range(na):
                    s[i] = qpos[reads[i]]
            # The family's iteration, written here and not in a helper: numba prunes a
            # branch on a None argument of this function before it inlines the callees, so
            # each family's loop never holds (nor types) the other's code.
            status, at = DONE, 0
            if P is not None:  # iRAM!S: fail = (q, q_new, s_new, ...)
                status = iterate(P, method, K, damping, tol, max_it, drift, bounds, qpa, C,
                                 targets[k], kind == 1, tip_t, trocar, s, state, it, rec[n],
                                 fail, info, w6, d7, f7, J)  # fmt: skip
                at = 12
            if arm is not None:  # an arm: fail = (q, q_new, ...), its joints its actuators
                A, ix, gain, lower, upper, W, dq = arm
                status = arm_iterate(A, ix, method, K, gain, damping, tol, max_it, drift,
                                     bounds, qpa, C, targets[k], kind == 1, tip_t, trocar, s,
                                     state, it, rec[n], fail, W, dq)  # fmt: skip
                at = ix[0]
                if status == STEPPED:
                    status = command_status(fail, at, lower, upper, info)
            n = keep_record(status, k, it, n, irec, info)
            once = address < 0
            if status == DONE:
                break
            if status != STEPPED:
                return status
            put(cmd, 0, fail, at, na)
            code = OK
            if address == 0:  # the kinematic plant reaches the command
                put(s, 0, fail, at, na)
            elif address > 0:  # the dynamic MuJoCo plant's period
                code = advance(cmd, v, fns, address, data, substeps, dt, steps, speed, ramp,
                               gap2, clip_lo, clip_hi, act, ctrl, qpos, qvel, xpos, warn, act_idx,
                               servo, feedforward, slot, pin)  # fmt: skip
            state[1] += state[2]
            if code != OK:
                info[1], info[2] = k, code
                return PLANT_STOPPED
    info[0], info[1] = n, targets.shape[0]
    return DONE
