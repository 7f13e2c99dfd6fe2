"""Algorithm 1 closed around the dynamic MuJoCo plant, all in compiled code.

Each control period the compiled loop reads the simulated sliders, runs one iteration of
Algorithm 1 (`loop.iterate`; the QP's planned from the plant's last command, the plant being its
servo) and, when it steps, runs the plant's period (`sim.mujoco.compiled.advance`: the physics
steps through MuJoCo's C functions). Python is back only between record blocks and at the
end, so a period costs the physics and about a microsecond more. The log, the plant's state
and the stops equal those of the per-iteration path (`phase.run_phase_on_plant`);
tests/test_fast_mujoco.py checks it bit for bit, and tests/test_qp_mujoco_compiled.py the QP's
against the Python QP on the same plant. Needs MuJoCo (the `sim` extra).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from numba import njit
from numpy.typing import NDArray

from rcmplan._validate import FloatArray
from rcmplan.compiled.loop import holds_rcm, iterate_recorded, target_frame
from rcmplan.compiled.phase import IntArray
from rcmplan.compiled.records import (
    DONE,
    FAIL_WIDTH,
    NO_TIP,
    PAUSED,
    PLANT_STOPPED,
    REC_WIDTH,
    STEPPED,
    append_records,
    iramis_method,
    is_curved,
    loop_bounds,
    raise_stop,
    record_width,
    robot_params,
    solver_arrays,
)
from rcmplan.control.solvers import Solver
from rcmplan.exceptions import SimulationError
from rcmplan.robot.curved_block import BLOCK_ROWS
from rcmplan.sim.mujoco.compiled import OK, PlantArrays, advance, plant_arrays

if TYPE_CHECKING:
    from rcmplan.control.runner import ControlState as Controller
    from rcmplan.sim.mujoco.plant import MujocoPlant

# Records per block. Python answers a signal only between blocks, so a block is short: 1,024
# control periods of the default injection take about 0.15 s (53,989 in 8.0 s of wall time; a
# 32,768-record block held an interrupt for seconds); a block costs one call and one append.
CAPACITY = 1 << 10
# A compiled loop around the plant, run(k0, it0, state, rec, irec, info) -> status, with the
# protocol of `run_targets_on_mujoco`
BlockRunner = Callable[[int, int, FloatArray, FloatArray, IntArray, IntArray], int]


@njit(cache=True)
def read_sliders(n: int, k: int, it: int, rec: FloatArray, info: IntArray, s: FloatArray,
                 qpos: FloatArray, slider_qpos: NDArray[np.intp]) -> bool:  # fmt: skip
    """Before iteration it of target k with n records written: the measured sliders into s
    and True, or False when the record block rec is full (info = (n, k, it): the loop pauses
    and resumes there)."""
    if n == rec.shape[0]:
        info[0], info[1], info[2] = n, k, it
        return False
    for i in range(6):
        s[i] = qpos[slider_qpos[i]]
    return True


@njit(cache=True)
def run_targets_on_mujoco(
    P: FloatArray, method: int, K: FloatArray, damping: float, tol: FloatArray, max_it: int,
    drift: bool, bounds: FloatArray, qpa: tuple | None, C: FloatArray | None,
    targets: FloatArray, k0: int, it0: int,
    s: FloatArray,
    cmd: FloatArray, state: FloatArray, rec: FloatArray, irec: NDArray[np.int64],
    info: NDArray[np.int64], fail: FloatArray, slider_qpos: NDArray[np.intp],
    fns: NDArray[np.intp], model: int, data: int, substeps: int, dt: float, steps: FloatArray,
    speed: FloatArray, ramp: float, gap2: float, act: FloatArray, ctrl: FloatArray,
    qpos: FloatArray, qvel: FloatArray, xpos: FloatArray, warn: NDArray[np.int32],
    act_idx: NDArray[np.intp],
    servo: NDArray[np.intp], feedforward: NDArray[np.intp], slot: NDArray[np.intp],
    pin: NDArray[np.intp],
) -> int:  # fmt: skip
    """Algorithm 1 on targets[k0:] (from iteration it0 of target k0) on the MuJoCo plant.

    state = (lambda, plant time [s], dt [s]); cmd (6,) holds the last slider command (for the
    QP the same array as qpa's cmd: `qp_kernels.loop_qp`). On return info = (records written,
    target reached, detail) and, after PAUSED (the record block is full), info[1], info[2] are
    the target and iteration to resume from.
    """
    w, d, f, v = np.empty(6), np.empty(7), np.empty(7), np.empty((4, 6))
    J = np.empty((BLOCK_ROWS, 7))
    trocar, tip_t = np.full(3, np.nan), np.empty(3)
    n = 0
    for k in range(k0, targets.shape[0]):
        info[0], info[1] = n, k
        kind = target_frame(targets[k], holds_rcm(method), w, tip_t, trocar)
        if kind < 0:
            return NO_TIP
        for it in range(it0 if k == k0 else 0, max_it + 1):
            if not read_sliders(n, k, it, rec, info, s, qpos, slider_qpos):
                return PAUSED
            status, n = iterate_recorded(P, method, K, damping, tol, max_it, drift, bounds, qpa,
                                         C, targets[k], kind == 1, tip_t, trocar, s, state, k,
                                         it, n, rec, irec, fail, info, w, d, f, J)  # fmt: skip
            if status == STEPPED:
                for i in range(6):
                    cmd[i] = fail[12 + i]
                code = advance(cmd, v, fns, model, data, substeps, dt, steps, speed, ramp, gap2,
                               act, ctrl, qpos, qvel, xpos, warn, act_idx, servo,
                               feedforward, slot, pin)  # fmt: skip
                state[1] += state[2]
                if code != OK:
                    info[1], info[2] = k, code
                    return PLANT_STOPPED
                continue
            if status == DONE:
                break
            return status
    info[0], info[1] = n, targets.shape[0]
    return DONE


def run_phase_on_mujoco(
    controller: Controller, solver: Solver, targets: FloatArray, pid: int, sid: int,
    arrays: PlantArrays | None = None, P: FloatArray | None = None,
) -> bool:  # fmt: skip
    """Algorithm 1 on each target with the dynamic MuJoCo plant, compiled; False (nothing
    done) if MuJoCo's C functions cannot be found. See the module docstring. P: the kernels'
    parameters (default: iRAM!S's own; a curved needle's carry its arc, `curved_iramis.params`,
    and its records the roll error)."""
    plant = cast("MujocoPlant", controller.plant)
    arrays = arrays or plant_arrays(plant)
    if arrays is None:
        return False
    cfg = controller.settings
    method = iramis_method(solver, controller.robot)
    if method is None:
        raise ValueError(f"the iRAM!S loop does not run solver {solver.name!r}")
    code, K = method
    _, damping, tol = solver_arrays(solver)
    targets = np.ascontiguousarray(targets, dtype=np.float64)
    head: tuple[Any, ...] = (
        robot_params(controller.robot) if P is None else P, code, K, damping, tol,
        cfg.max_iterations, cfg.drift_correction, loop_bounds(controller),
        None, np.empty((BLOCK_ROWS, 7)) if is_curved(code) else None, targets,
    )  # fmt: skip
    s, cmd, fail = np.empty(6), plant.command, np.empty(FAIL_WIDTH)
    plant_args = (arrays.slider_qpos, *arrays.args())
    kernel: Any = run_targets_on_mujoco

    def run(k0: int, it0: int, state: FloatArray, rec: FloatArray, irec: IntArray,
            info: IntArray) -> int:  # fmt: skip
        return int(kernel(*head, k0, it0, s, cmd, state, rec, irec, info, fail, *plant_args))

    width = record_width(6, roll=is_curved(code))
    status, info = run_in_blocks_on_mujoco(controller, cmd, pid, sid, run, width)
    if status != DONE:
        where = f"phase {controller.log.phase_names[pid]!r} step {int(info[1])}"
        m = solver.tolerance().shape[0]
        raise_stop(controller, status, int(info[1]), targets, fail, tol[:m], where)
    return True


def run_in_blocks_on_mujoco(
    controller: Controller, cmd: FloatArray, pid: int, sid: int, run: BlockRunner,
    width: int = REC_WIDTH,
) -> tuple[int, IntArray]:  # fmt: skip
    """Call a compiled loop around the dynamic MuJoCo plant `run(k0, it0, state, rec, irec,
    info)` until it stops pausing, each block of CAPACITY records appended to the log. The
    plant ends at its last command cmd (6,) and time, controller.lam holds the last lambda,
    and a failed period (PLANT_STOPPED) raises the plant's SimulationError. Returns (status,
    info); state = (lambda, plant time [s], dt [s]); records are `width` wide (a curved
    needle's carry the roll error: `records.record_width`)."""
    plant = cast("MujocoPlant", controller.plant)
    state = np.array([controller.lam, plant.time, plant.dt])
    rec, irec = np.empty((CAPACITY, width)), np.empty((CAPACITY, 2), dtype=np.int64)
    info = np.zeros(3, dtype=np.int64)
    status, k0, it0 = PAUSED, 0, 0
    try:
        while status == PAUSED:
            status = run(k0, it0, state, rec, irec, info)
            append_records(controller.log, rec, irec, int(info[0]), pid, sid)
            k0, it0 = int(info[1]), int(info[2])
    finally:
        plant.command_actuators(cmd)
        plant.time = float(state[1])
        controller.lam = float(state[0])
    if status == PLANT_STOPPED:
        plant.check()  # raises the plant's own SimulationError
        raise SimulationError(f"the plant stopped (check {int(info[2])}) at t = {plant.time} s")
    return status, info
