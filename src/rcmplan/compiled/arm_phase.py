"""One phase of Algorithm 1 for a serial arm on any plant: the plant steps in Python, each
iteration's kinematics, error, record and step are one compiled call (`arm_loop.arm_iterate`).

Applies to a `SerialArm` itself (exact type: a subclass may change its actuator map) whose
kinematics the chain kernels reproduce (`arm.arm_arrays`), with a solver the kernels implement
(exact types, `records.method_code`). The side effects are the reference loop's: records go to
the controller's log, the plant and controller.lam end where `Controller.converge` leaves them,
and a stop raises the reference exception with the partial log kept (commands go through the
robot's `actuators_from_joints` and the plant's own checks, as in the reference loop).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray
from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.arm import FastArm, arm_arrays
from rcmplan.compiled.records import (
    BLOCK,
    DONE,
    NO_CONVERGENCE,
    STEPPED,
    method_code,
    singular_threshold,
    solver_arrays,
)
from rcmplan.control.log import LogBuilder
from rcmplan.control.solvers import DlsSolver, PinvSolver, Solver, TipSolver
from rcmplan.control.targets import rcm_target, tip_of_target
from rcmplan.exceptions import ConvergenceError, RcmplanError
from rcmplan.robot.chain import JointChain
from rcmplan.robot.iramis import Iramis
from rcmplan.robot.model import SerialArm
from rcmplan.robot.needle import StraightNeedle

if TYPE_CHECKING:
    from rcmplan.control.runner import ControlState as Controller

ITERATIONS_PER_TARGET = 3  # on a kinematic plant: 150 records for the UR5 p3-p4 phase's 50 targets


def applies(controller: Controller, solver: Solver) -> bool:
    """True for a SerialArm itself and a solver the arm loop implements (cheap checks; whether
    the kernels reproduce the arm is probed in `run_if_fast`)."""
    return type(controller.robot) is SerialArm and method_code(solver) is not None


def run_if_fast(
    controller: Controller, solver: Solver, targets: FloatArray, pid: int, sid: int
) -> bool:
    """Run the phase compiled if the fast path is on for it (`cache.use_fast`) and the kernels
    reproduce the arm; False (nothing done) otherwise."""
    if not fast_cache.use_fast(ITERATIONS_PER_TARGET * len(targets)):
        return False
    if arm_arrays(controller.robot) is None:
        return False
    run_arm_phase(controller, solver, targets, pid, sid)
    return True


def arm_columns(n: int) -> dict[str, tuple[int, int]]:
    """Record columns of `arm_loop` rows for n joints: field -> (first, end)."""
    widths = {"time": 1, "sliders": n, "joints": n, "lam": 1, "tip": 3, "rcm": 3, "trocar": 3,
              "base": 3, "target_tip": 3, "error": 6}  # fmt: skip
    ends = np.cumsum(list(widths.values()))
    return {k: (int(e - w), int(e)) for (k, w), e in zip(widths.items(), ends, strict=True)}


def append_rows(log: LogBuilder, rec: FloatArray, irec: NDArray[np.int64], n_rec: int, n: int,
                pid: int, sid: int) -> None:  # fmt: skip
    """Append the first n_rec rows of rec (and their (step, iteration) in irec) to the log."""
    cols = {k: rec[:n_rec, a:b] for k, (a, b) in arm_columns(n).items()}
    cols["time"], cols["lam"] = cols["time"][:, 0], cols["lam"][:, 0]
    log.extend(n_rec, step=irec[:n_rec, 0], iteration=irec[:n_rec, 1], solver=sid, phase=pid,
               **cols)  # fmt: skip


class _Buffer:
    """Record rows waiting for the log."""

    def __init__(self, controller: Controller, n: int, pid: int, sid: int) -> None:
        self.log, self.n, self.pid, self.sid = controller.log, n, pid, sid
        self.rec = np.empty((BLOCK, fast_cache.arm_loop().record_width(n)))
        self.irec = np.empty((BLOCK, 2), dtype=np.int64)
        self.count = 0

    def keep(self, k: int, it: int) -> None:
        """Keep the row just written, for target k, iteration it."""
        self.irec[self.count] = k, it
        self.count += 1
        if self.count == BLOCK:
            self.flush()

    def flush(self) -> None:
        append_rows(self.log, self.rec, self.irec, self.count, self.n, self.pid, self.sid)
        self.count = 0


def run_arm_phase(
    controller: Controller, solver: Solver, targets: FloatArray, pid: int, sid: int
) -> None:
    """Algorithm 1 on each target in turn (see the module docstring)."""
    robot, plant, cfg = controller.robot, controller.plant, controller.settings
    loop, frame = fast_cache.arm_loop(), fast_cache.loop_kernels().target_frame
    A, ix = arm_arrays(robot)  # type: ignore[misc]
    n, m = int(ix[0]), int(ix[1])
    code, (K, damping, tol) = method_code(solver), solver_arrays(solver)
    gain = float(getattr(solver, "posture_gain", 0.0))
    args = (A, ix, code, K, gain, damping, tol, cfg.max_iterations, cfg.drift_correction,
            singular_threshold(controller))  # fmt: skip
    W = np.empty(fast_cache.chain_kernels().work_shape(n, m))
    state, fail, d = np.array([controller.lam, plant.time]), np.empty(2 * n + 6), np.empty(m + 1)
    w, tip_t, trocar = np.empty(6), np.empty(3), np.full(3, np.nan)
    buf = _Buffer(controller, n, pid, sid)
    targets = np.ascontiguousarray(targets, dtype=np.float64)
    try:
        for k in range(targets.shape[0]):
            kind = frame(targets[k], code != 3, w, tip_t, trocar)
            if kind < 0:
                tip_of_target(targets[k])  # raises the reference exception
            for it in range(cfg.max_iterations + 1):
                state[1] = plant.time
                s = np.ascontiguousarray(plant.read_actuators(), dtype=np.float64)
                status = loop.arm_iterate(*args, targets[k], kind == 1, tip_t, trocar, s, state,
                                          it, buf.rec[buf.count], fail, W, d)  # fmt: skip
                if it > 0:
                    buf.keep(k, it)
                controller.lam = float(state[0])
                if status == DONE:
                    break
                if status != STEPPED:
                    _stop(controller, solver, status, f"phase {controller.log.phase_names[pid]!r} "
                          f"step {k}", fail, n)  # fmt: skip
                plant.command_actuators(robot.actuators_from_joints(fail[n : 2 * n].copy()))
                plant.advance()
    finally:  # also on a stop: the partial log keeps every record so far
        buf.flush()


def _stop(controller: Controller, solver: Solver, status: int, where: str, fail: FloatArray,
          n: int) -> None:  # fmt: skip
    """Raise what the reference loop raises for a compiled stop (fail: q, q_new, error)."""
    tol = solver.tolerance()
    if status == NO_CONVERGENCE:
        e = np.abs(fail[2 * n : 2 * n + tol.shape[0]])
        raise ConvergenceError(controller.settings.max_iterations, e, tol, where=where)
    controller.robot.check_singularity(fail[:n].copy(), controller.settings.singular_threshold)
    raise RcmplanError(f"compiled arm loop stopped with status {status} at {where}")


def compile_arm_kernels() -> None:
    """Compile (or load from numba's cache) the arm kernels and loop with the argument types
    used here, on iRAM!S's DH chain holding its needle (no robot package needed)."""
    from rcmplan.control.loop import Controller
    from rcmplan.sim.kinematic import KinematicPlant

    robot = Iramis()
    mount = np.eye(4)
    mount[2, 3] = -robot.params.l6  # the needle runs along the tip frame's z up to its origin
    arm = SerialArm(JointChain.from_dh(robot.chain), StraightNeedle(robot.params.l6, mount),
                    robot.home, name="warm", roll_joint=5)  # fmt: skip
    fast, q = FastArm(arm), arm.home
    x = fast.task(q, 0.5)
    fast.augmented_jacobian(q, 0.5, "thesis")
    fast.step(q, 0.5, x, np.ones(6), np.empty(6))
    fast.dls_step(q, 0.5, x, 1e-4, np.empty(6))
    tip, trocar = arm.tip(q), arm.needle_point(q, 0.5)
    rcm = np.array([rcm_target(tip - 1e-4 * arm.needle_axis(q), trocar)])  # insert 0.1 mm
    jobs: list[tuple[Solver, FloatArray]] = [
        (PinvSolver(), rcm), (PinvSolver(variant="thesis"), rcm), (DlsSolver(), rcm),
        (TipSolver(), tip[None, :] + 1e-5),
    ]  # fmt: skip
    for solver, targets in jobs:
        ctl = Controller(KinematicPlant(arm), solver)
        ctl.lam = 0.5
        run_arm_phase(ctl, solver, targets, ctl.log.phase_id("warm"), 0)
