"""One phase of Algorithm 1 through the compiled loop, with the reference loop's side effects.

Records go to the controller's log, the kinematic plant ends at the last slider command with
its time advanced, controller.lam holds the last lambda, and an early stop raises what
`Controller.converge` raises: the failing check is repeated with the reference function, which
raises the same exception with the same message.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray
from rcmplan.compiled import cache as fast_cache
from rcmplan.control.log import LogBuilder
from rcmplan.control.solvers import DlsSolver, PinvSolver, Solver, TipSolver
from rcmplan.control.targets import tip_of_target
from rcmplan.exceptions import ConvergenceError, InvalidInputError, RcmplanError
from rcmplan.robot.iramis import Iramis
from rcmplan.robot.model import RobotModel

if TYPE_CHECKING:
    from rcmplan.control.loop import Controller

# status codes and record layout of rcmplan.compiled.loop (kept here to avoid importing it)
DONE, PAUSED, NO_CONVERGENCE, SINGULAR, BAD_JOINTS, SLIDER_LIMIT, NO_TIP, STEPPED = range(8)
BLOCK = 4096  # records buffered before they go to the log
REC_COLUMNS = {"time": (0, 1), "sliders": (1, 7), "joints": (7, 13), "lam": (13, 14),
               "tip": (14, 17), "rcm": (17, 20), "trocar": (20, 23), "base": (23, 26),
               "target_tip": (26, 29), "error": (29, 35)}  # fmt: skip
VECTORS = tuple(k for k, (a, b) in REC_COLUMNS.items() if b - a > 1)


def robot_params(robot: RobotModel) -> FloatArray:
    """The parameter vector P of the kernels: l1..l6 [m], PCJM spacing d [m], travel (6 + 6)."""
    if not isinstance(robot, Iramis):
        raise InvalidInputError("robot", robot.name, "an iRAM!S model (the kernels' closed form)")
    p = robot.params
    head = [p.l1, p.l2, p.l3, p.l4, p.l5, p.l6, robot.pcjm.spacing]
    return np.array([*head, *robot.lower, *robot.upper], dtype=np.float64)


def method_code(solver: Solver) -> int | None:
    """The kernel's method code for a solver the compiled loop reproduces, else None."""
    if type(solver) is PinvSolver:
        return 0 if solver.variant == "exact" else 1
    if type(solver) is DlsSolver:
        return 2
    if type(solver) is TipSolver:
        return 3
    return None


def solver_arrays(solver: Solver) -> tuple[FloatArray, float, FloatArray]:
    """(K (6,), damping [m], tolerance padded to (6,)) of a supported solver."""
    K = np.asarray(getattr(solver, "K", (1.0,) * 6), dtype=np.float64)
    tol = np.zeros(6)
    t = solver.tolerance()
    tol[: t.shape[0]] = t
    return K, float(getattr(solver, "damping", 0.0)), tol


def singular_threshold(controller: Controller) -> float:
    """The loop's singular threshold: its own setting, else the robot's."""
    own = controller.settings.singular_threshold
    return float(controller.robot.singular_threshold if own is None else own)


def append_records(
    log: LogBuilder, rec: FloatArray, irec: NDArray[np.int64], n: int, pid: int, sid: int
) -> None:
    """Append the first n compiled records to a LogBuilder, as one block."""
    vectors = {k: rec[:n, a:b] for k, (a, b) in ((k, REC_COLUMNS[k]) for k in VECTORS)}
    log.extend(
        n, time=rec[:n, 0], lam=rec[:n, 13], step=irec[:n, 0], iteration=irec[:n, 1],
        solver=sid, phase=pid, **vectors,
    )  # fmt: skip


def run_phase_compiled(
    controller: Controller, solver: Solver, targets: FloatArray, pid: int, sid: int
) -> None:
    """Algorithm 1 on each target in turn, compiled; see the module docstring."""
    loop = fast_cache.loop_kernels()
    robot, plant, cfg = controller.robot, controller.plant, controller.settings
    code = method_code(solver)
    K, damping, tol = solver_arrays(solver)
    thr = singular_threshold(controller)
    targets = np.ascontiguousarray(targets, dtype=np.float64)
    s = plant.read_actuators()
    state = np.array([controller.lam, plant.time, plant.dt])
    cap = 4 * targets.shape[0] + cfg.max_iterations
    rec, irec = np.empty((cap, 35)), np.empty((cap, 2), dtype=np.int64)
    info, fail = np.zeros(3, dtype=np.int64), np.empty(24)
    args = (robot_params(robot), code, K, damping, tol, cfg.max_iterations,
            cfg.drift_correction, float(thr), targets)  # fmt: skip
    status, k0 = PAUSED, 0
    while status == PAUSED:
        status = loop.run_targets(*args, k0, s, state, rec, irec, info, fail)
        append_records(controller.log, rec, irec, int(info[0]), pid, sid)
        k0 = int(info[1])
    plant.command_actuators(s)
    plant.advance()
    plant.time = float(state[1])
    controller.lam = float(state[0])
    if status != DONE:
        where = f"phase {controller.log.phase_names[pid]!r} step {int(info[1])}"
        m = solver.tolerance().shape[0]
        raise_stop(controller, status, int(info[1]), targets, fail, tol[:m], where)


def run_phase_on_plant(
    controller: Controller, solver: Solver, targets: FloatArray, pid: int, sid: int
) -> None:
    """Algorithm 1 on each target with any plant: the plant steps in Python, each iteration's
    kinematics, error, record and step in one compiled call (`fast_loop.iterate`)."""
    loop = fast_cache.loop_kernels()
    robot, plant, cfg = controller.robot, controller.plant, controller.settings
    code = method_code(solver)
    K, damping, tol = solver_arrays(solver)
    thr = singular_threshold(controller)
    P, state = robot_params(robot), np.array([controller.lam, plant.time, plant.dt])
    rec, irec = np.empty((BLOCK, 35)), np.empty((BLOCK, 2), dtype=np.int64)
    info, fail = np.zeros(3, dtype=np.int64), np.empty(24)
    w, d, f, J, A = np.empty(6), np.empty(6), np.empty(6), np.empty((6, 6)), np.empty((6, 6))
    tip_t, trocar = np.empty(3), np.full(3, np.nan)
    targets = np.ascontiguousarray(targets, dtype=np.float64)
    n = 0
    for k in range(targets.shape[0]):
        kind = loop.target_frame(targets[k], code != 3, w, tip_t, trocar)
        for it in range(cfg.max_iterations + 1):
            status = NO_TIP if kind < 0 else STEPPED
            if kind >= 0:
                state[1] = plant.time
                status = loop.iterate(P, code, K, damping, tol, cfg.max_iterations,
                                      cfg.drift_correction, float(thr), targets[k], kind == 1,
                                      tip_t, trocar, plant.read_actuators(), state, it, rec[n],
                                      fail, info, w, d, f, J, A)  # fmt: skip
            if it > 0 and kind >= 0:
                irec[n] = k, it
                n += 1
                if n == BLOCK:
                    append_records(controller.log, rec, irec, n, pid, sid)
                    n = 0
            if status == STEPPED:
                plant.command_actuators(fail[12:18].copy())
                try:
                    plant.advance()
                except RcmplanError:  # the partial log keeps every record so far
                    append_records(controller.log, rec, irec, n, pid, sid)
                    controller.lam = float(state[0])
                    raise
                continue
            controller.lam = float(state[0])
            if status != DONE:
                append_records(controller.log, rec, irec, n, pid, sid)
                where = f"phase {controller.log.phase_names[pid]!r} step {k}"
                m = solver.tolerance().shape[0]
                raise_stop(controller, status, k, targets, fail, tol[:m], where)
            break
    append_records(controller.log, rec, irec, n, pid, sid)
    controller.lam = float(state[0])


def raise_stop(
    controller: Controller, status: int, k: int, targets: FloatArray, fail: FloatArray,
    tol: FloatArray, where: str,
) -> None:  # fmt: skip
    """Raise the exception the reference loop raises for a compiled early stop."""
    robot, cfg = controller.robot, controller.settings
    q, qn, sn, e = fail[0:6].copy(), fail[6:12].copy(), fail[12:18].copy(), fail[18:24]
    if status == NO_CONVERGENCE:
        raise ConvergenceError(cfg.max_iterations, np.abs(e[: tol.size]), tol, where=where)
    checks: dict[int, Any] = {
        SINGULAR: lambda: robot.check_singularity(q, cfg.singular_threshold),
        BAD_JOINTS: lambda: robot.actuators_from_joints(qn),
        SLIDER_LIMIT: lambda: robot.check_actuators(sn),
        NO_TIP: lambda: tip_of_target(targets[k]),
    }
    checks[status]()
    raise RcmplanError(f"compiled loop stopped with status {status} at target {k}")
