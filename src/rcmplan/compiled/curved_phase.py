"""One phase of Algorithm 1 with a curved needle, compiled, on a plant that reaches its commands
exactly (the kinematic plant): iRAM!S through the iRAM!S loop (`loop.run_targets`), an arm
through the arm loop (`arm_loop.run_arm_targets`), each with the curved needle's method codes.

Applies to `CurvedPinvSolver`, `CurvedDlsSolver` and `CurvedPoseSolver` (exact types; the pose
solver with at most six active joints) driving a robot `curved.curved_arrays` accepts. The side
effects are the reference loop's: records (with the roll error) go to the controller's log, the
plant and controller.lam end where `Controller.converge` leaves them, and a stop raises the
reference exception with the partial log kept. Plants with dynamics take the reference loop.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.compiled import arm_phase
from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.curved import CurvedArrays, curved_arrays, screen
from rcmplan.compiled.phase import IntArray, run_in_blocks
from rcmplan.compiled.records import (
    CURVED_POSE,
    DONE,
    FAIL_WIDTH,
    is_curved,
    loop_bounds,
    method_code,
    raise_stop,
    record_width,
    solver_arrays,
)
from rcmplan.control.solvers import Solver

if TYPE_CHECKING:
    from rcmplan.control.runner import ControlState as Controller

ITERATIONS_PER_TARGET = 4  # on the kinematic plant: 12,725 records / 9,768 targets (`curved`)
# The whole-pose task has seven rows for a rigid needle's six freedoms: with more than six
# active joints its Jacobian is rank-deficient both ways, and the reference's least-squares
# step (an SVD) runs on the reference path.
POSE_JOINTS = 6


def applies(controller: Controller, solver: Solver) -> bool:
    """True for a curved needle's solver (whether the compiled path runs is `run_if_fast`'s)."""
    return is_curved(method_code(solver))


def run_if_fast(
    controller: Controller, solver: Solver, targets: FloatArray, pid: int, sid: int
) -> bool:
    """Run the phase compiled if the plant reaches its commands exactly and the kernels
    reproduce the robot; False (nothing done) otherwise."""
    if not getattr(controller.plant, "exact_commands", False):
        return False
    arrays = curved_arrays(controller.robot)
    if arrays is None or (method_code(solver) == CURVED_POSE and arrays.m > POSE_JOINTS):
        return False
    if arrays.P is not None:
        run_iramis_phase(controller, solver, targets, pid, sid, arrays)
    else:
        arm_phase.run_arm_phase_exact(controller, solver, targets, pid, sid, arrays)
    return True


def run_iramis_phase(
    controller: Controller, solver: Solver, targets: FloatArray, pid: int, sid: int,
    arrays: CurvedArrays,
) -> None:  # fmt: skip
    """Algorithm 1 on each target in turn in the iRAM!S loop, with iRAM!S holding the curved
    needle (`arrays.P`); the plant ends at the last command with its time advanced."""
    loop = fast_cache.loop_kernels()
    cfg = controller.settings
    K, damping, tol = solver_arrays(solver)
    targets = np.ascontiguousarray(targets, dtype=np.float64)
    fail = np.empty(FAIL_WIDTH)
    args = (arrays.P, method_code(solver), K, damping, tol, cfg.max_iterations,
            cfg.drift_correction, loop_bounds(controller), targets)  # fmt: skip

    def run(k0: int, s: FloatArray, state: FloatArray, rec: FloatArray, irec: IntArray,
            info: IntArray) -> int:  # fmt: skip
        return int(loop.run_targets(*args, k0, s, state, rec, irec, info, fail))

    status, info = run_in_blocks(controller, targets, pid, sid, run, ITERATIONS_PER_TARGET + 1,
                                 record_width(6, roll=True))  # fmt: skip
    if status != DONE:
        k = int(info[1])
        where = f"phase {controller.log.phase_names[pid]!r} step {k}"
        raise_stop(controller, status, k, targets, fail, tol, where)


def compile_curved_kernels() -> None:
    """Compile (or load from numba's cache) the curved needle's loops and target screens with
    the argument types used here: the screen and each curved solver on one target, on iRAM!S
    and on iRAM!S's DH chain as an arm holding the needle (no robot package needed)."""
    from rcmplan.control.curved import CurvedDlsSolver, CurvedPinvSolver, CurvedPoseSolver
    from rcmplan.control.loop import Controller
    from rcmplan.robot.chain import JointChain
    from rcmplan.robot.curved import CurvedTipRobot
    from rcmplan.robot.curved_needle import CurvedNeedle
    from rcmplan.robot.iramis import Iramis
    from rcmplan.robot.model import SerialArm
    from rcmplan.robot.needle import StraightNeedle
    from rcmplan.sim.kinematic import KinematicPlant

    iramis = Iramis()
    mount = np.eye(4)
    mount[2, 3] = -iramis.params.l6  # the needle runs along the tip frame's z up to its origin
    arm = SerialArm(JointChain.from_dh(iramis.chain), StraightNeedle(iramis.params.l6, mount),
                    iramis.home, name="warm", roll_joint=5)  # fmt: skip
    for base in (iramis, arm):
        robot = CurvedTipRobot(base, CurvedNeedle(base.needle_length))
        q = robot.home
        shaft = robot.needle_point(q, 0.5)
        x = np.array([*robot.tip(q), robot.roll(q), *shaft]) + 1e-6
        pose = np.array([*robot.tip(q), robot.roll(q), *robot.needle_point(q, 0.0)]) + 1e-6
        jobs: list[tuple[Solver, FloatArray]] = [
            (CurvedPinvSolver(), x), (CurvedDlsSolver(), x), (CurvedPoseSolver(), pose)
        ]  # fmt: skip
        arrays = curved_arrays(robot)
        if arrays is None:
            continue
        screen(robot, arrays, x[None, :], np.ascontiguousarray(q, dtype=np.float64))
        for solver, target in jobs:
            ctl = Controller(KinematicPlant(base), solver, robot=robot)
            ctl.lam = 0.5
            pid = ctl.log.phase_id("warm")
            if arrays.P is not None:
                run_iramis_phase(ctl, solver, target[None, :], pid, 0, arrays)
            else:
                arm_phase.run_arm_phase_exact(ctl, solver, target[None, :], pid, 0, arrays)
