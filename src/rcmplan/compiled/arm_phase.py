"""One phase of Algorithm 1 for a serial arm, compiled: the whole loop (`algorithm.run_targets`,
the one loop of every robot) on a plant that reaches its commands exactly (`exact_commands`, the
kinematic plant) or on the dynamic MuJoCo `ArmPlant`, whose periods the loop runs
(`compiled_physics`); else one compiled call per iteration with the plant stepping in Python
(`arm_loop.arm_iterate`).

Applies to a `SerialArm` itself (exact type: a subclass may change its actuator map) whose
kinematics the chain kernels reproduce (`arm.arm_arrays`), with a solver the kernels implement
(exact types, `records.method_code`), the QP's free-space step (`LimitedTipSolver`, as
TIP_LIMITED), or the QP controller where the arm's compiled QP step
reproduces it (`arm_qp.arm_qp_applies`: one solve gives the iteration's error and step, in the
same loop); `curved_phase` runs a curved needle on an arm through
`run_arm_phase_compiled` with the curved needle's arrays (its QP as CURVED_QP, the QP's free-space
`LimitedPoseSolver` as CURVED_POSE_LIMITED). The side effects are the reference
loop's: records go to the controller's log, the plant and controller.lam end where
`Controller.converge` leaves them, and a stop raises the reference exception with the partial
log kept (`records.raise_arm_stop` repeats the failing check with the reference function: the
plant's own command checks, the robot's singularity check; a failed QP solve is repeated by the
solver itself, `qp_phase.raise_qp_failure`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.arm import arm_arrays
from rcmplan.compiled.arm_qp import arm_qp_applies, curved_qp_applies, qp_arrays, servo_command
from rcmplan.compiled.phase import loop_runner, run_in_blocks, run_phase_per_period
from rcmplan.compiled.qp_phase import raise_qp_failure
from rcmplan.compiled.records import (
    CURVED_POSE_LIMITED,
    CURVED_QP,
    DONE,
    QP,
    QP_FAILED,
    TIP_LIMITED,
    loop_bounds,
    method_code,
    raise_arm_stop,
    record_width,
    solver_arrays,
    where,
)
from rcmplan.control.curved import LimitedPoseSolver
from rcmplan.control.limited_tip import LimitedTipSolver
from rcmplan.control.qp import QpSolver
from rcmplan.control.solvers import Solver
from rcmplan.robot.curved import CurvedArrays
from rcmplan.robot.model import RobotModel, SerialArm

if TYPE_CHECKING:
    from rcmplan.control.runner import ControlState as Controller
    from rcmplan.sim.mujoco.compiled import PlantArrays

ITERATIONS_PER_TARGET = 3  # on a kinematic plant: 150 records for the UR5 p3-p4 phase's 50 targets


def arm_code(controller: Controller, solver: Solver) -> int | None:
    """The arm loop's method code for the solver (`records.method_code`, or QP for a QpSolver
    on the controller's robot that the compiled arm QP reproduces, CURVED_QP for a curved
    needle's, `arm_qp.curved_qp_applies`), else None."""
    code = method_code(solver)
    if code is None and isinstance(solver, QpSolver) and solver.robot is controller.robot:
        if solver.curved:
            return CURVED_QP if curved_qp_applies(solver) else None
        return QP if arm_qp_applies(solver) else None
    if type(solver) is LimitedTipSolver:
        return TIP_LIMITED
    if type(solver) is LimitedPoseSolver:
        return CURVED_POSE_LIMITED
    return code


def limited_K(robot: RobotModel, solver: LimitedTipSolver | LimitedPoseSolver) -> FloatArray:
    """What the arm loop's limited steps hold (`arm_loop.limit_step`): each moving joint's
    largest move per period (speed x dt), its travel (lower, upper), the margin and the tip's
    largest move per axis and period (tip speed x dt; 0: no tip speed bound); for the curved
    needle's whole-pose step (CURVED_POSE_LIMITED) after its gains (7,)."""
    active = list(robot.active)
    speed = getattr(solver, "tip_speed", None)
    tip = 0.0 if speed is None else speed * solver.dt
    bounds = np.concatenate([robot.speed[active] * solver.dt, robot.lower[active],
                             robot.upper[active], [solver.travel_margin, tip]])  # fmt: skip
    if isinstance(solver, LimitedPoseSolver):
        return np.concatenate([np.asarray(solver.K, dtype=np.float64), bounds])
    return bounds


def applies(controller: Controller, solver: Solver) -> bool:
    """True for a SerialArm itself and a solver the arm loop implements (whether the kernels
    reproduce the arm is probed in `run_if_fast`)."""
    return type(controller.robot) is SerialArm and arm_code(controller, solver) is not None


def run_if_fast(
    controller: Controller, solver: Solver, targets: FloatArray, pid: int, sid: int
) -> bool:
    """Run the phase compiled if the kernels reproduce the arm: the whole loop on a plant
    with `exact_commands` or on the dynamic MuJoCo plant (`compiled_physics`, a QP's servo
    being that plant), else one compiled call per iteration; False (nothing done)
    otherwise."""
    if arm_arrays(controller.robot) is None:
        return False
    if whole_loop(controller, solver):
        run_arm_phase_compiled(controller, solver, targets, pid, sid)
    else:
        run_arm_phase(controller, solver, targets, pid, sid)
    return True


def whole_loop(controller: Controller, solver: Solver) -> bool:
    """True if the whole phase runs in the compiled loop: on a plant that reaches its
    commands exactly, or on a dynamic MuJoCo plant whose period runs compiled (`plant_arrays`
    finds MuJoCo's C functions); a QP planned from a servo only if that servo is the plant."""
    plant = controller.plant
    servo = getattr(solver, "servo", None)
    if servo is not None and servo is not plant:
        return False
    if getattr(plant, "exact_commands", False):
        return True
    return bool(getattr(plant, "compiled_physics", False)) and _plant_arrays(plant) is not None


def _plant_arrays(plant: object) -> PlantArrays | None:
    from rcmplan.sim.mujoco.compiled import plant_arrays  # the dynamic MuJoCo plant only

    return plant_arrays(plant)


class _Setup:
    """What the compiled loop and the per-period driver pass to the kernels for one phase: the
    arm's arrays (or a curved needle's, `curved`), the solver's code and constants, the loop
    settings, and work arrays."""

    def __init__(self, controller: Controller, solver: Solver,
                 curved: CurvedArrays | None = None) -> None:  # fmt: skip
        cfg = controller.settings
        packed = arm_arrays(controller.robot) if curved is None else curved.arm()
        A, ix = packed  # type: ignore[misc]
        self.n, m = int(ix[0]), int(ix[1])
        code, (K, damping, tol) = arm_code(controller, solver), solver_arrays(solver)
        self.code, self.tol = int(code), tol  # type: ignore[arg-type]
        if code in (TIP_LIMITED, CURVED_POSE_LIMITED):
            K = limited_K(controller.robot, solver)  # type: ignore[arg-type]
        gain = float(getattr(solver, "posture_gain", 0.0))
        self.qpa = qp_arrays(solver, self.n)
        kin = fast_cache.chain_kernels()  # W holds no frames yet (`holds_frames`)
        if curved is None:
            self.W = kin.blank_work(kin.work_shape(self.n, m), self.n)
            self.fail, self.d = np.empty(2 * self.n + 6), np.empty(m + 1)
        else:
            self.W = kin.blank_work(curved.work_shape(), self.n)
            self.fail, self.d = np.empty(2 * self.n + 7), np.empty(curved.m + 1)
        robot = controller.robot
        lower = np.ascontiguousarray(robot.lower, dtype=np.float64)
        upper = np.ascontiguousarray(robot.upper, dtype=np.float64)
        arm = (A, ix, gain, lower, upper, self.W, self.d)  # `algorithm.run_targets`' arm
        self.args = (None, arm, self.code, K, damping, tol, cfg.max_iterations,
                     bool(cfg.drift_correction), loop_bounds(controller), self.qpa,
                     None if curved is None else self.W)  # fmt: skip
        self.roll = curved is not None
        self.width = record_width(self.n, roll=self.roll)

    def head(self, targets: FloatArray) -> tuple[Any, ...]:
        """The compiled loop's arguments before the resume point (`phase.loop_runner`): no
        iRAM!S parameters, the arm's arrays (`algorithm.run_targets`), then the solver's."""
        return (*self.args, targets)

    def stop(self, controller: Controller, solver: Solver, status: int, target: FloatArray,
             where: str) -> None:  # fmt: skip
        """Raise the reference exception for a stop status."""
        if status == QP_FAILED:
            assert self.qpa is not None  # QP_FAILED comes from the QP's solve
            flag = int(self.qpa[5][0])  # DAQP's exit flag (`arm_qp.qp_arrays`)
            raise_qp_failure(controller, solver, target, self.fail[: self.n], flag)  # type: ignore[arg-type]
        tol = self.tol[: solver.tolerance().shape[0]]
        raise_arm_stop(controller, status, target, self.fail, self.n, tol, where)


def run_arm_phase_compiled(
    controller: Controller, solver: Solver, targets: FloatArray, pid: int, sid: int,
    curved: CurvedArrays | None = None,
) -> None:  # fmt: skip
    """Algorithm 1 on each target in turn, the whole loop compiled (`algorithm.run_targets`),
    on a plant whose commands are reached exactly or on the dynamic MuJoCo plant, whose periods
    the loop runs: the plant ends at the last command with its time advanced by dt per step,
    as the reference loop leaves it. `curved`: the arrays of a curved needle on the arm
    (`rcmplan.compiled.curved`)."""
    setup = _Setup(controller, solver, curved)
    targets = np.ascontiguousarray(targets, dtype=np.float64)
    exact = getattr(controller.plant, "exact_commands", False)
    arrays = None if exact else _plant_arrays(controller.plant)
    run = loop_runner(setup.head(targets), setup.fail, None if arrays is None else
                      arrays.loop_args())  # fmt: skip
    cmd = None
    if setup.qpa is not None and setup.qpa[-1].shape[0] > 0:  # the QP plans from the command
        servo_command(solver, setup.qpa)
        cmd = setup.qpa[-1][: setup.n]
    status, info = run_in_blocks(controller, targets, pid, sid, run,
                                 ITERATIONS_PER_TARGET + 1, setup.roll, cmd,
                                 dynamic=arrays is not None)  # fmt: skip
    if status != DONE:
        k = int(info[1])
        setup.stop(controller, solver, status, targets[k], where(controller, pid, k))


def run_arm_phase(
    controller: Controller, solver: Solver, targets: FloatArray, pid: int, sid: int
) -> None:
    """Algorithm 1 on each target in turn on any plant: the plant steps in Python, each
    iteration one compiled call (`phase.run_phase_per_period`)."""
    setup = _Setup(controller, solver)
    targets = np.ascontiguousarray(targets, dtype=np.float64)

    def stop(status: int, k: int) -> None:
        setup.stop(controller, solver, status, targets[k], where(controller, pid, k))

    run_phase_per_period(controller, targets, pid, sid, setup.args, setup.fail,
                         stop, before=lambda: servo_command(solver, setup.qpa))  # fmt: skip
