"""The curved needle's compiled control step against the straight needle's, and the curved
injection on the compiled and the reference path.

`python benchmarks/bench_curved.py`:
- Compiled step: Algorithm 1 on the kinematic plant, the compiled loop alone (no Python, no
  log), per iteration (one record = one control step: joints, drift correction, error, record,
  checks, step, command) on the p3-p4 phase, for iRAM!S and the UR5: the straight needle on
  the default injection (X_ext, J_a 6 x 6) beside the curved needle on the `curved` scenario
  (X_c with the roll row, J_c 7 x 7), measured in the same run. The issue's target: curved
  <= 1.3 x straight.
- `rcmplan inject --scenario curved --no-plots [--robot ur5]` wall time, one process each,
  numba's cache warmed first.
- The QP on the `curved` scenario (iRAM!S; the UR5 without --quick): `Controller.run` of the
  whole procedure (target checks and motion) in the compiled loop (`CURVED_QP`, its free
  phases `CURVED_POSE_LIMITED`) against the Python loop (`ReferenceRunner`), same process.
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
import time
from typing import Any

import numpy as np

from _common import quick, row
from rcmplan.compiled import arm_phase
from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.curved import curved_arrays
from rcmplan.compiled.records import (
    FAIL_WIDTH,
    REC_WIDTH,
    method_code,
    record_width,
    robot_params,
    solver_arrays,
)
from rcmplan.control import PinvSolver
from rcmplan.control.curved import CurvedPinvSolver
from rcmplan.control.curved_targets import solve_curved_pose
from rcmplan.control.methods import make_solver
from rcmplan.control.phase import LoopSettings
from rcmplan.control.runner import ReferenceRunner, Runner
from rcmplan.control.solvers import Solver
from rcmplan.control.targets import rcm_target, solve_pose
from rcmplan.controller import Controller
from rcmplan.robot.curved_block import BLOCK_ROWS
from rcmplan.robot.iramis import Iramis
from rcmplan.robot.model import RobotModel
from rcmplan.robot.registry import make_robot
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.scene.procedures import injection
from rcmplan.scene.scenario import load_scenario
from rcmplan.sim import KinematicPlant
from rcmplan.sim.mujoco.compiled import exact_plant
from rcmplan.warmup import compile_kernels

ROBOTS = {"iramis": "iRAM!S", "ur5": "UR5"}
RATIO_TARGET = 1.3


class Problem:
    """The p3-p4 phase of one needle on one robot: targets, the starting joints and lambda."""

    def __init__(self, robot: RobotModel, solver: Solver, targets: np.ndarray, q0: np.ndarray,
                 lam0: float) -> None:  # fmt: skip
        self.robot, self.solver, self.q0, self.lam0 = robot, solver, q0, lam0
        self.targets = np.ascontiguousarray(targets, dtype=np.float64)


def straight(name: str) -> Problem:
    """The default injection's p3-p4 phase, from the pose at p3."""
    robot = make_robot(name)
    eye = default_eye(robot)
    points = default_points(eye)
    phase = next(ph for ph in injection(robot, eye, points) if ph.name == "p3-p4")
    pose = solve_pose(robot, rcm_target(points.p3, eye.port))
    return Problem(robot, PinvSolver(), phase.plan(pose.q), pose.q, pose.lam)


def curved(name: str) -> Problem:
    """The `curved` scenario's p3-p4 phase, from the pose at the end of the insertion."""
    scenario = load_scenario("curved").with_robot(name)
    robot = scenario.needle.fit(make_robot(name))
    phases = {ph.name: ph for ph in scenario.phases(robot)}
    start = phases["insert"].plan(robot.home)[-1]
    pose = solve_curved_pose(robot, start)
    return Problem(robot, CurvedPinvSolver(), phases["p3-p4"].plan(pose.q), pose.q, pose.lam)


def kernel_run(problem: Problem) -> Any:
    """A function running the compiled loop on the problem once: (seconds, records)."""
    robot, solver, targets = problem.robot, problem.solver, problem.targets
    plant = KinematicPlant(robot)
    plant.reset(robot.actuators_from_joints(problem.q0))
    ctl = Controller(plant, solver)
    arrays = curved_arrays(robot)
    cap = 10 * len(targets) + 200
    irec, info = np.empty((cap, 2), dtype=np.int64), np.zeros(4, dtype=np.int64)
    code, (K, damping, tol) = method_code(solver), solver_arrays(solver)
    s0 = robot.actuators_from_joints(problem.q0)
    if isinstance(robot, Iramis) or (arrays is not None and arrays.P is not None):
        P = robot_params(robot) if arrays is None else arrays.P
        width = REC_WIDTH if arrays is None else record_width(6, roll=True)
        rec, fail = np.empty((cap, width)), np.empty(FAIL_WIDTH)
        bounds = np.array([robot.singular_threshold, LoopSettings().rcm_tolerance])
        C = np.empty((BLOCK_ROWS, 7)) if arrays is not None else None  # the curved block
        head = (P, None, code, K, damping, tol, 100, True, bounds, None, C, targets, 0, 0)
        kernel = fast_cache.algorithm().run_targets

        def once() -> tuple[float, int]:
            s, state = s0.copy(), np.array([problem.lam0, 0.0, 1e-3])
            t = time.perf_counter()
            kernel(*head, s, np.empty(6), state, rec, irec, info[:3], fail, exact_plant())
            return time.perf_counter() - t, int(info[0])

        return once
    setup = arm_phase._Setup(ctl, solver, arrays)
    rec = np.empty((cap, setup.width))
    arm_head, kernel = setup.head(targets), fast_cache.algorithm().run_targets

    def once_arm() -> tuple[float, int]:
        s, state = s0.copy(), np.array([problem.lam0, 0.0, 1e-3])
        t = time.perf_counter()
        kernel(*arm_head, 0, 0, s, s.copy(), state, rec, irec, info[:3], setup.fail,
               exact_plant())  # fmt: skip
        return time.perf_counter() - t, int(info[0])

    return once_arm


def per_iteration_us(problem: Problem, repeat: int) -> tuple[float, int]:
    """Median time per record in [us] over `repeat` runs of the compiled loop, and records."""
    once = kernel_run(problem)
    _, n = once()
    return 1e6 * statistics.median(t / c for t, c in (once() for _ in range(repeat))), n


def step_rows(name: str) -> list[dict[str, Any]]:
    """The straight and the curved compiled step on one robot, alternated so that both see the
    same machine load."""
    label, repeat = ROBOTS[name], 11 if quick() else 51
    problems = {"straight": straight(name), "curved": curved(name)}
    times: dict[str, list[float]] = {k: [] for k in problems}
    counts: dict[str, int] = {}
    for _ in range(3 if quick() else 7):
        for k, p in problems.items():
            t, counts[k] = per_iteration_us(p, repeat)
            times[k].append(t)
    straight_us, curved_us = (statistics.median(times[k]) for k in ("straight", "curved"))
    return [
        row(f"{label} compiled step, straight needle (X_ext; p3-p4, {counts['straight']} "
            "iterations)", straight_us, "us"),
        row(f"{label} compiled step, curved needle (X_c with the roll row; p3-p4, "
            f"{counts['curved']} iterations)", curved_us, "us", f"{label} straight needle",
            straight_us, f"ratio <= {RATIO_TARGET:g}"),
    ]  # fmt: skip


def inject_seconds(name: str, out: str) -> float:
    """Wall time in [s] of `rcmplan inject --scenario curved --no-plots` in a new process."""
    cmd = [sys.executable, "-m", "rcmplan", "inject", "--scenario", "curved", "--robot", name,
           "--no-plots", "--out", out]  # fmt: skip
    t = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True)
    return time.perf_counter() - t


def inject_rows(name: str) -> list[dict[str, Any]]:
    """The curved injection's wall time (numba's cache warmed first)."""
    compile_kernels()
    with tempfile.TemporaryDirectory() as tmp:
        seconds = inject_seconds(name, f"{tmp}/run")
    figure = f"`rcmplan inject --scenario curved --robot {name} --no-plots`, warm cache"
    return [row(figure, seconds, "s")]


def qp_run_seconds(name: str, runner: Runner | None) -> tuple[float, int]:
    """(wall time [s], records) of `Controller.run` on the `curved` scenario with the QP on
    robot `name`, on the runner given (None: the default, compiled)."""
    scenario = load_scenario("curved").with_method("qp")
    robot = scenario.needle.fit(make_robot(name))
    plant = KinematicPlant(getattr(robot, "base", robot))
    plant.reset(robot.home_actuators)
    solver = make_solver("qp", scenario.method_settings, robot, eye=default_eye(robot))
    ctl = Controller(plant, solver, settings=scenario.loop, runner=runner, robot=robot)
    phases = scenario.phases(robot)
    t = time.perf_counter()
    log = ctl.run(phases)
    return time.perf_counter() - t, len(log)


def qp_rows(name: str) -> list[dict[str, Any]]:
    """The curved QP's procedure, compiled (after a first run that compiles) and in Python."""
    qp_run_seconds(name, None)
    compiled, n = qp_run_seconds(name, None)
    python, _ = qp_run_seconds(name, ReferenceRunner())
    figure = (f"{ROBOTS[name]} curved needle, QP: `Controller.run` of the `curved` procedure "
              f"({n} records)")  # fmt: skip
    return [row(figure, compiled, "s", "the Python loop, same run", python)]


def rows() -> list[dict[str, Any]]:
    """The step rows of both robots, the curved QP's procedure, then the injection's wall time
    (iRAM!S only with --quick)."""
    out: list[dict[str, Any]] = []
    for name in ROBOTS:
        out += step_rows(name)
    for name in ("iramis",) if quick() else tuple(ROBOTS):
        out += qp_rows(name) + inject_rows(name)
    return out


if __name__ == "__main__":
    from run import print_table

    print_table(rows())
