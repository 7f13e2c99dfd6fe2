"""The QP controller's phases on the dynamic MuJoCo plant in the compiled loop around it
(`algorithm.run_targets` with method QP and the plant's arrays), behind the runner seam.

Applies to a `QpSolver` itself (exact type) with the DAQP back end, on iRAM!S with a straight
needle or a curved one (method CURVED_QP), with the controller's plant as its servo
(`QpSolver.servo`: steps planned from the plant's last command rounded to its
`actuator_resolution`), on a plant whose period runs in compiled code (`compiled_physics`),
for a robot the iRAM!S kernels reproduce, an eye and limits the kernels
reproduce (`qp_params`), when DAQP's and MuJoCo's C functions can be called from compiled code.
Everything else runs on the reference path.

The side effects are the reference loop's: records go to the controller's log, the plant ends
at its last command and time, controller.lam holds the last lambda, and a stop raises the
reference exception (a failed solve: `qp_phase.raise_qp_stop`, the plant's failed check:
its own SimulationError).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, cast

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.phase import run_phase_loop
from rcmplan.compiled.qp_params import qp_params
from rcmplan.compiled.qp_phase import qp_method, raise_qp_stop
from rcmplan.control.qp import QpSolver
from rcmplan.control.solvers import Solver

if TYPE_CHECKING:
    from rcmplan.control.runner import ControlState as Controller
    from rcmplan.sim.mujoco.plant import MujocoPlant


def applies(controller: Controller, solver: Solver) -> bool:
    """Cheap checks: a QpSolver itself with DAQP whose servo is the controller's plant, a plant
    that rounds commands to a resolution and whose period runs compiled (the robot, the eye
    and the C bindings are checked in `run_if_ready`)."""
    plant = controller.plant
    return (
        type(solver) is QpSolver
        and solver.backend == "daqp"
        and solver.servo is plant
        and getattr(plant, "actuator_resolution", None) is not None
        and bool(getattr(plant, "compiled_physics", False))
    )


def run_if_ready(
    controller: Controller, solver: QpSolver, targets: FloatArray, pid: int, sid: int,
    P: FloatArray,
) -> bool:  # fmt: skip
    """Run the phase compiled if DAQP's and MuJoCo's C functions are usable and the eye and
    limits are the kernels'; False (nothing done) otherwise. The caller has checked the robot
    (P: the kernels' parameters, `runner.kernel_params`, or a curved needle's,
    `qp_phase.curved_params`)."""
    from rcmplan.sim.mujoco.compiled import plant_arrays

    params = qp_params(controller.robot, solver)
    if params is None or fast_cache.qp_loop() is None:
        return False
    arrays = plant_arrays(controller.plant)
    if arrays is None:
        return False
    run_qp_phase_on_mujoco(controller, solver, targets, pid, sid, params, arrays, P)
    return True


def run_qp_phase_on_mujoco(
    controller: Controller, solver: QpSolver, targets: FloatArray, pid: int, sid: int,
    params: tuple[FloatArray, FloatArray], arrays: Any, P: FloatArray,
) -> None:  # fmt: skip
    """Algorithm 1 with the QP on each target in turn on the MuJoCo plant, compiled (see the
    module docstring); P: as `run_if_ready`'s."""
    plant = cast("MujocoPlant", controller.plant)
    res = np.ascontiguousarray(plant.actuator_resolution, dtype=np.float64)
    cmd = np.array(plant.command, dtype=np.float64)  # the loop writes it, the QP plans from it
    qpa = fast_cache.qp_kernels().loop_qp(params, res, cmd, curved=solver.curved)
    status, info, fail, tol = run_phase_loop(controller, solver, targets, pid, sid,
                                             qp_method(solver), P, qpa, arrays, cmd)  # fmt: skip
    raise_qp_stop(controller, solver, status, info, targets, fail, tol, pid)
