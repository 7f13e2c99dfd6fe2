"""The QP controller's phases on iRAM!S in the compiled loop (`algorithm.run_targets`, method
QP), behind the runner seam.

Applies to a `QpSolver` itself (exact type: a subclass may change its step) with the DAQP back
end, on a plant whose commands are reached exactly (the kinematic plant), for a robot the
iRAM!S kernels reproduce (`runner.kernel_params`) or iRAM!S holding a curved needle
(`curved.curved_arrays`: method CURVED_QP, X_c's seven rows, the roll's actuator moved), and an
eye whose retina is the kernels' sphere (`qp_params.spherical_eye`), when DAQP's C function can
be called from compiled code (`cache.qp_loop`). Everything else runs on the reference path.

The side effects are the reference loop's: records go to the controller's log, the plant and
controller.lam end where `Controller.converge` leaves them, and a stop raises the reference
exception. A failed QP solve is repeated on the reference path (`QpSolver.error` at the
failing state), which raises its QPError with the problem attached.

Targets are not checked again here: `Controller.run` has already passed every target of the
phase through `QpSolver.check_targets` before any motion (planned phases: before their own).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from rcmplan._validate import FloatArray
from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.curved import curved_arrays
from rcmplan.compiled.phase import IntArray, run_phase_loop
from rcmplan.compiled.qp_params import qp_params
from rcmplan.compiled.records import (
    CURVED_QP,
    DONE,
    QP,
    QP_FAILED,
    raise_stop,
    solver_arrays,
    where,
)
from rcmplan.control.qp import QpSolver
from rcmplan.control.solvers import Solver
from rcmplan.exceptions import QPError
from rcmplan.robot.model import RobotModel

if TYPE_CHECKING:
    from rcmplan.control.runner import ControlState as Controller

ITERATIONS_PER_TARGET = 40  # record buffer per target (the loop pauses when it is full)


def applies(controller: Controller, solver: Solver) -> bool:
    """Cheap checks: a QpSolver itself with DAQP, on a plant with exact commands (the robot,
    the eye and DAQP's binding are checked in `run_if_ready`)."""
    return (
        type(solver) is QpSolver
        and solver.backend == "daqp"
        and bool(getattr(controller.plant, "exact_commands", False))
    )


def runs_compiled(solver: Solver, exact_commands: bool) -> bool:
    """Whether a phase of this solver on a plant with (or without) exact commands would run
    compiled once the fast path is on: `applies`, and DAQP's binding and the eye usable."""
    return (
        type(solver) is QpSolver
        and solver.backend == "daqp"
        and exact_commands
        and (not solver.curved or curved_params(solver.robot) is not None)
        and fast_cache.qp_loop() is not None
        and qp_params(solver.robot, solver) is not None
    )


def curved_params(robot: RobotModel) -> FloatArray | None:
    """The kernels' P of iRAM!S holding a curved needle (`curved_iramis.params`), else None."""
    arrays = curved_arrays(robot)
    return None if arrays is None else arrays.P


def run_if_ready(
    controller: Controller, solver: QpSolver, targets: FloatArray, pid: int, sid: int,
    P: FloatArray,
) -> bool:  # fmt: skip
    """Run the phase compiled if DAQP's binding is usable and the eye is the kernels'; False
    (nothing done) otherwise. The caller has checked the robot (its kernels' parameters P:
    `runner.kernel_params`, or `curved_params` for a curved needle) and the mode."""
    params = qp_params(controller.robot, solver)
    if fast_cache.qp_loop() is None or params is None:
        return False
    run_qp_phase(controller, solver, targets, pid, sid, params, P)
    return True


def run_qp_phase(
    controller: Controller, solver: QpSolver, targets: FloatArray, pid: int, sid: int,
    params: tuple[FloatArray, FloatArray], P: FloatArray,
) -> None:  # fmt: skip
    """Algorithm 1 with the QP on each target in turn, compiled (see the module docstring)."""
    qpa = fast_cache.qp_kernels().loop_qp(params, curved=solver.curved)
    status, info, fail, tol = run_phase_loop(controller, solver, targets, pid, sid,
                                             qp_method(solver), P, qpa,
                                             per_target=ITERATIONS_PER_TARGET)  # fmt: skip
    raise_qp_stop(controller, solver, status, info, targets, fail, tol, pid)


def qp_method(solver: QpSolver) -> tuple[int, FloatArray]:
    """(method code, K) of the QP in the compiled loop, as `records.iramis_method` gives the
    other solvers': QP, or CURVED_QP for a curved needle."""
    return CURVED_QP if solver.curved else QP, solver_arrays(solver)[0]


def raise_qp_stop(
    controller: Controller, solver: QpSolver, status: int, info: IntArray, targets: FloatArray,
    fail: FloatArray, tol: FloatArray, pid: int,
) -> None:  # fmt: skip
    """Raise what the reference loop raises for a compiled QP loop's stop `status` at target
    info[1] of phase pid (nothing if DONE); fail holds the loop's (q, ...) at the stop."""
    if status == DONE:
        return
    k = int(info[1])
    if status == QP_FAILED:
        raise_qp_failure(controller, solver, targets[k], fail[0:6], int(info[2]))
    raise_stop(controller, status, k, targets, fail, tol, where(controller, pid, k))


def raise_qp_failure(
    controller: Controller, solver: QpSolver, target: FloatArray, q: FloatArray, flag: int
) -> None:
    """Raise the reference QPError of a solve that failed compiled: the same solve on the
    reference path at the failing state (joints q, controller.lam); if it succeeds there (a
    failure at the edge of DAQP's tolerances), a QPError with the compiled flag."""
    from rcmplan.compiled.daqp_c import exit_name

    solver.error(controller.robot, q.copy(), controller.lam, target)
    raise QPError(
        f"QP solve failed: daqp exit flag {flag} ({exit_name(flag)}) in compiled code; the "
        "same solve succeeded on the reference path",
        problem=None,
        result=flag,
    )
