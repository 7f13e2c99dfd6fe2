"""One phase of Algorithm 1 through the compiled loop, with the reference loop's side effects.

`run_in_blocks` drives the one compiled loop (`algorithm.run_targets`) for every robot:
iRAM!S's phases here (`run_phase_compiled`) and in the QP's drivers (`qp_phase`,
`qp_mujoco_phase`), a serial arm's in `arm_phase`. Records go to the controller's log, the plant
ends at the last command with its time advanced (the kinematic plant, or the dynamic MuJoCo
plant whose periods the loop runs),
controller.lam holds the last lambda, and an early stop raises what
`Controller.converge` raises: the failing check is repeated with the reference function, which
raises the same exception with the same message.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray
from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.records import (
    BLOCK,
    DONE,
    FAIL_WIDTH,
    PAUSED,
    PLANT_STOPPED,
    append_rows,
    iramis_method,
    is_curved,
    loop_bounds,
    method_code,
    raise_stop,
    record_width,
    robot_params,
    solver_arrays,
    where,
)
from rcmplan.control.solvers import Solver
from rcmplan.exceptions import SimulationError
from rcmplan.robot.curved_block import BLOCK_ROWS
from rcmplan.sim.mujoco.compiled import PlantArrays, exact_plant, stepping_plant

if TYPE_CHECKING:
    from rcmplan.control.runner import ControlState as Controller
    from rcmplan.sim.mujoco.plant import MujocoPlant

IntArray = NDArray[np.int64]


def run_phase_compiled(
    controller: Controller, solver: Solver, targets: FloatArray, pid: int, sid: int,
    P: FloatArray | None = None, plant: PlantArrays | None = None, per_target: int = 4,
) -> None:  # fmt: skip
    """Algorithm 1 on each target in turn in the compiled iRAM!S loop; see the module docstring.

    P: the kernels' parameters (default: iRAM!S's own; a curved needle's carry its arc,
    `curved_iramis.params`, and its records the roll error). plant: the dynamic MuJoCo plant's
    arrays (`sim.mujoco.compiled.plant_arrays`), whose periods the loop then runs; default the
    kinematic plant. per_target: records per target in a block on the kinematic plant.
    """
    method = iramis_method(solver, controller.robot)
    if method is None:
        raise ValueError(f"the iRAM!S loop does not run solver {solver.name!r}")
    P = robot_params(controller.robot) if P is None else P
    status, info, fail, tol = run_phase_loop(controller, solver, targets, pid, sid, method, P,
                                             plant=plant, per_target=per_target)  # fmt: skip
    if status != DONE:
        k, m = int(info[1]), solver.tolerance().shape[0]
        raise_stop(controller, status, k, targets, fail, tol[:m], where(controller, pid, k))


def run_phase_loop(
    controller: Controller, solver: Solver, targets: FloatArray, pid: int, sid: int,
    method: tuple[int, FloatArray], P: FloatArray, qpa: tuple[Any, ...] | None = None,
    plant: PlantArrays | None = None, cmd: FloatArray | None = None, per_target: int = 4,
) -> tuple[int, IntArray, FloatArray, FloatArray]:  # fmt: skip
    """The compiled loop (`algorithm.run_targets`) on iRAM!S, for a phase's targets, every driver's
    (`run_phase_compiled`, the QP's `qp_phase` and `qp_mujoco_phase`); returns (status, info,
    fail, tolerance) for the caller to raise the stop its reference loop raises.

    method: (code, K) (`records.iramis_method`, or the QP's code with its K); P: the kernels'
    parameters; qpa: the QP's arrays (`qp_kernels.loop_qp`) for its methods, else None. plant:
    the dynamic MuJoCo plant's arrays, whose periods the loop runs with the command array cmd
    (default a copy of the plant's command, `run_in_blocks`); None: the kinematic plant. per_target:
    records per target in a block on the kinematic plant.
    """
    code, K = method
    curved, cfg = is_curved(code), controller.settings
    _, damping, tol = solver_arrays(solver)
    targets = np.ascontiguousarray(targets, dtype=np.float64)
    fail = np.empty(FAIL_WIDTH)
    head = (P, None, code, K, damping, tol, cfg.max_iterations, cfg.drift_correction,
            loop_bounds(controller), qpa, np.empty((BLOCK_ROWS, 7)) if curved else None,
            targets)  # fmt: skip
    run = loop_runner(head, fail, None if plant is None else plant.loop_args())
    status, info = run_in_blocks(controller, targets, pid, sid, run, per_target, curved, cmd,
                                 dynamic=plant is not None)  # fmt: skip
    return status, info, fail, tol


# The compiled loop on one phase's targets, run(k0, it0, s, cmd, state, rec, irec, info) ->
# status: the protocol of `algorithm.run_targets` after its head (`loop_runner`)
BlockRunner = Callable[
    [int, int, FloatArray, FloatArray, FloatArray, FloatArray, IntArray, IntArray], int
]


def loop_runner(
    head: tuple[Any, ...], fail: FloatArray, plant: tuple[Any, ...] | None = None
) -> BlockRunner:
    """The compiled loop `algorithm.run_targets` on head = (P, arm, method, K, damping, tol,
    max_it, drift, bounds, qpa, C, targets), its last iteration in fail; plant: the dynamic
    MuJoCo plant's arrays (`PlantArrays.loop_args`) or a plant stepping in Python's
    (`stepping_plant`), by default the kinematic plant's (`exact_plant`). Every robot and
    every plant run the one compiled loop."""
    loop = fast_cache.algorithm()
    args = exact_plant() if plant is None else plant
    work: list[tuple[FloatArray, ...]] = []  # the loop's scratch, made at the first call

    def run(k0: int, it0: int, s: FloatArray, cmd: FloatArray, state: FloatArray,
            rec: FloatArray, irec: IntArray, info: IntArray) -> int:  # fmt: skip
        if not work:
            work.append(loop.work_arrays(s.shape[0]))
        return int(loop.run_targets(*head, k0, it0, s, cmd, state, rec, irec, info, fail, args,
                                    work[0]))  # fmt: skip

    return run


# Records per block on the dynamic MuJoCo plant. Python answers a signal only between blocks, so
# a block is short: 1,024 control periods of the default injection take about 0.15 s (53,989 in
# 8.0 s of wall time; a 32,768-record block held an interrupt for seconds); a block costs one
# call and one append.
CAPACITY = 1 << 10


def run_in_blocks(
    controller: Controller, targets: FloatArray, pid: int, sid: int, run: BlockRunner,
    per_target: int = 4, roll: bool = False, cmd: FloatArray | None = None,
    dynamic: bool = False,
) -> tuple[int, IntArray]:  # fmt: skip
    """Call the compiled loop `run` (`loop_runner`) until it stops pausing, each block of
    records (`records.record_columns` of the plant's actuators, with the roll error column
    for a curved needle: `roll`) appended to the log. Returns (status, info).

    dynamic: the plant is the dynamic MuJoCo plant whose periods the loop runs (blocks of
    CAPACITY records); else the kinematic plant, whose actuators the loop moves to each command
    (blocks of `per_target` records per target). cmd: the array the loop writes each command
    into (a QP planned from its servo passes the servo's command array; default the plant's
    command, or a copy of its actuators). Either plant ends at the last command and time (the
    kinematic one advanced to it), controller.lam holds the last lambda, and a failed period
    of the dynamic plant (PLANT_STOPPED) raises the plant's SimulationError.
    """
    plant = controller.plant
    s = np.array(plant.read_actuators(), dtype=np.float64)
    if cmd is None:
        cmd = (
            np.array(cast("MujocoPlant", plant).command, dtype=np.float64) if dynamic else s.copy()
        )
    state = np.array([controller.lam, plant.time, plant.dt])
    if dynamic:
        cap = CAPACITY
    else:
        cap = per_target * targets.shape[0] + controller.settings.max_iterations
    n = s.shape[0]
    rec, irec = np.empty((cap, record_width(n, roll))), np.empty((cap, 2), dtype=np.int64)
    info = np.zeros(3, dtype=np.int64)
    status, k0, it0 = PAUSED, 0, 0
    try:
        while status == PAUSED:
            status = run(k0, it0, s, cmd, state, rec, irec, info)
            append_rows(controller.log, rec, irec, int(info[0]), n, pid, sid)
            k0, it0 = int(info[1]), int(info[2])
    finally:
        plant.command_actuators(cmd)
        if not dynamic:
            plant.advance()
        plant.time = float(state[1])
        controller.lam = float(state[0])
    if status == PLANT_STOPPED:
        cast("MujocoPlant", plant).check()  # raises the plant's own SimulationError
        raise SimulationError(f"the plant stopped (check {int(info[2])}) at t = {plant.time} s")
    return status, info


def run_phase_on_plant(
    controller: Controller, solver: Solver, targets: FloatArray, pid: int, sid: int
) -> None:
    """Algorithm 1 on iRAM!S with any plant: the plant steps in Python, each iteration one
    compiled call (`run_phase_per_period`)."""
    code = method_code(solver)
    if code is None:
        raise ValueError(f"the iRAM!S iteration does not run solver {solver.name!r}")
    cfg = controller.settings
    K, damping, tol = solver_arrays(solver)
    head = (robot_params(controller.robot), None, code, K, damping, tol, cfg.max_iterations,
            cfg.drift_correction, loop_bounds(controller), None, None)  # fmt: skip
    fail, m = np.empty(FAIL_WIDTH), solver.tolerance().shape[0]

    def stop(status: int, k: int) -> None:
        raise_stop(controller, status, k, targets, fail, tol[:m], where(controller, pid, k))

    run_phase_per_period(controller, targets, pid, sid, head, fail, stop)


def run_phase_per_period(
    controller: Controller, targets: FloatArray, pid: int, sid: int, head: tuple[Any, ...],
    fail: FloatArray, stop: Callable[[int, int], None], roll: bool = False,
    before: Callable[[], None] | None = None,
) -> None:  # fmt: skip
    """Algorithm 1 on each target with a plant stepping in Python, in the one compiled loop
    (`algorithm.run_targets` on head = (P, arm, method, K, damping, tol, max_it, drift,
    bounds, qpa, C), its last iteration in fail, given `stepping_plant`): each period reads
    the plant, runs one iteration and, when it stepped, commands and advances the plant.
    Records go to the log in blocks (with the roll error column: `roll`), also when a stop or
    the plant raises; controller.lam follows each iteration; a stop status calls stop(status,
    target index), which raises the reference exception. before: called before each
    iteration (a QP planned from its servo's command)."""
    plant = controller.plant
    targets = np.ascontiguousarray(targets, dtype=np.float64)
    run = loop_runner((*head, targets), fail, stepping_plant())
    n = np.asarray(plant.read_actuators()).shape[0]
    state = np.array([controller.lam, plant.time, plant.dt])
    rec, irec = np.empty((BLOCK, record_width(n, roll))), np.empty((BLOCK, 2), dtype=np.int64)
    info, cmd = np.zeros(3, dtype=np.int64), np.empty(n)
    count, k0, it0 = 0, 0, 0
    try:
        while True:
            state[1] = plant.time
            s = np.array(plant.read_actuators(), dtype=np.float64)
            if before is not None:
                before()
            status = run(k0, it0, s, cmd, state, rec[count:], irec[count:], info)
            count += int(info[0])
            if count == BLOCK:
                append_rows(controller.log, rec, irec, count, n, pid, sid)
                count = 0
            controller.lam = float(state[0])
            if status != PAUSED:
                if status != DONE:
                    stop(status, int(info[1]))
                return
            if int(info[1]) == k0:  # the iteration stepped (else target k0 was done)
                plant.command_actuators(cmd.copy())
                plant.advance()
            k0, it0 = int(info[1]), int(info[2])
    finally:  # also on a stop: the partial log keeps every record so far
        append_rows(controller.log, rec, irec, count, n, pid, sid)
