"""Algorithm 1 closed around the dynamic MuJoCo plant, all in compiled code.

The phase runs in the one compiled loop (`loop.run_targets`) given the plant's arrays: each
control period it reads the simulated sliders, runs one iteration of Algorithm 1
(`loop.iterate`; the QP's planned from the plant's last command, the plant being its servo)
and, when it steps, runs the plant's period (`sim.mujoco.compiled.advance`: the physics steps
through MuJoCo's C functions). Python is back only between record blocks and at the end, so a
period costs the physics and about a microsecond more. The log, the plant's state and the
stops equal those of the per-iteration path (`phase.run_phase_on_plant`);
tests/test_fast_mujoco.py checks it bit for bit, and tests/test_qp_mujoco_compiled.py the QP's
against the Python QP on the same plant. Needs MuJoCo (the `sim` extra).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, cast

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.compiled.phase import BlockRunner, IntArray, loop_runner
from rcmplan.compiled.records import (
    DONE,
    FAIL_WIDTH,
    PAUSED,
    PLANT_STOPPED,
    REC_WIDTH,
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
from rcmplan.sim.mujoco.compiled import PlantArrays, plant_arrays

if TYPE_CHECKING:
    from rcmplan.control.runner import ControlState as Controller
    from rcmplan.sim.mujoco.plant import MujocoPlant

# Records per block. Python answers a signal only between blocks, so a block is short: 1,024
# control periods of the default injection take about 0.15 s (53,989 in 8.0 s of wall time; a
# 32,768-record block held an interrupt for seconds); a block costs one call and one append.
CAPACITY = 1 << 10


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
    fail = np.empty(FAIL_WIDTH)
    run = loop_runner(head, fail, arrays.loop_args())
    width = record_width(6, roll=is_curved(code))
    status, info = run_in_blocks_on_mujoco(controller, plant.command, pid, sid, run, width)
    if status != DONE:
        where = f"phase {controller.log.phase_names[pid]!r} step {int(info[1])}"
        m = solver.tolerance().shape[0]
        raise_stop(controller, status, int(info[1]), targets, fail, tol[:m], where)
    return True


def run_in_blocks_on_mujoco(
    controller: Controller, cmd: FloatArray, pid: int, sid: int, run: BlockRunner,
    width: int = REC_WIDTH,
) -> tuple[int, IntArray]:  # fmt: skip
    """Call the compiled loop `run` (`phase.loop_runner`) around the dynamic MuJoCo plant until it
    stops pausing, each block of CAPACITY records appended to the log. The plant ends at its last
    command cmd (6,) and time, controller.lam holds the last lambda, and a failed period
    (PLANT_STOPPED) raises the plant's SimulationError. Returns (status, info); state = (lambda,
    plant time [s], dt [s]); records are `width` wide (a curved needle's carry the roll error:
    `records.record_width`)."""
    plant = cast("MujocoPlant", controller.plant)
    s, state = np.empty(6), np.array([controller.lam, plant.time, plant.dt])
    rec, irec = np.empty((CAPACITY, width)), np.empty((CAPACITY, 2), dtype=np.int64)
    info = np.zeros(3, dtype=np.int64)
    status, k0, it0 = PAUSED, 0, 0
    try:
        while status == PAUSED:
            status = run(k0, it0, s, cmd, state, rec, irec, info)
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
