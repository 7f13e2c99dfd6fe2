"""Speed of the control step, the compiled loop, batches, the injection and process start.

Run alone: python benchmarks/bench_speed.py (or all benchmarks: python benchmarks/run.py).
Each row: figure, value, unit, peer, peer_value, ratio (value / peer_value), target.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from typing import Any

import numpy as np

from _common import THESIS_ITERATION_S, FastController, per_call, quick, row, use_path
from rcmplan import Iramis
from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.records import FAIL_WIDTH, robot_params
from rcmplan.compiled.runner import FastIramis
from rcmplan.control import PinvSolver, extended_task, solve_pose
from rcmplan.control.augmented import augmented_jacobian
from rcmplan.control.phase import LoopSettings
from rcmplan.controller import Controller
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.scene.procedures import injection, spiral
from rcmplan.sim import KinematicPlant
from rcmplan.sim.mujoco.compiled import exact_plant

SEED = 20180507


def random_poses(n: int, seed: int = SEED) -> tuple[np.ndarray, np.ndarray]:
    """n joint vectors (prismatic +-30 mm, revolute +-1.2 rad) and lambdas in [0, 1]."""
    rng = np.random.default_rng(seed)
    Q = rng.uniform(-1.0, 1.0, (n, 6)) * np.array([0.03, 1.2, 0.03, 1.2, 0.03, 1.2])
    return Q, rng.uniform(0.0, 1.0, n)


def step_rows() -> list[dict[str, Any]]:
    """One control step (X_ext, J_a, solve) called from Python, compiled and reference."""
    robot, fast, solver = Iramis(), FastIramis(), PinvSolver()
    q, lam = random_poses(1)[0][0], 0.4
    target = extended_task(robot, q + 1e-3, 0.5)
    K, out = np.ones(6), np.empty(6)
    n = 2000 if quick() else 20000
    t_fast = per_call(lambda: fast.step(q, lam, target, K, "exact", out), n)

    def reference() -> None:
        solver.step(robot, q, lam, target, solver.error(robot, q, lam, target))

    t_ref = per_call(reference, n // 20)
    return [
        row("control step from Python (X_ext + J_a + solve), median", 1e6 * t_fast, "us",
            "rcmplan reference Python", 1e6 * t_ref, "<= 3 us"),
    ]  # fmt: skip


def loop_rows() -> list[dict[str, Any]]:
    """Algorithm 1 inside compiled code: the spiral phase (1200 targets) of the spiral job."""
    robot = Iramis()
    eye = default_eye(robot)
    targets = np.ascontiguousarray(spiral(robot, eye, default_points(eye))[4].targets)
    pose = solve_pose(robot, targets[0])
    loop = fast_cache.algorithm()
    cap = 4 * len(targets) + 100
    rec, irec = np.empty((cap, 35)), np.empty((cap, 2), dtype=np.int64)
    info, fail = np.zeros(3, dtype=np.int64), np.empty(FAIL_WIDTH)
    bounds = np.array([0.1, LoopSettings().rcm_tolerance])  # singular floor, RCM step bound
    args = (
        robot_params(robot),
        None,
        0,
        np.ones(6),
        0.0,
        np.full(6, 1e-8),
        100,
        True,
        bounds,
        None,
        None,
        targets,
        0,
        0,
    )
    s0, plant = robot.actuators_from_joints(pose.q), exact_plant()
    work = loop.work_arrays(6)

    def once() -> float:
        t = time.perf_counter()
        state = np.array([pose.lam, 0.0, 1e-3])
        loop.run_targets(*args, s0.copy(), np.empty(6), state, rec, irec, info, fail, plant, work)
        return time.perf_counter() - t

    once()
    wall = statistics.median(once() for _ in range(3 if quick() else 9))
    per_it = wall / int(info[0])
    return [
        row(f"compiled loop, per iteration ({int(info[0])} iterations, spiral phase)",
            1e6 * per_it, "us", "thesis V-REP loop", 1e6 * THESIS_ITERATION_S, "<= 1 us"),
    ]  # fmt: skip


def batch_rows() -> list[dict[str, Any]]:
    """X_ext and J_a over N configurations on one core (the kernel is serial)."""
    n = 100_000 if quick() else 1_000_000
    Q, lam = random_poses(n)
    kernels, P = fast_cache.kernels(), robot_params(Iramis())
    X, J = np.empty((n, 6)), np.empty((n, 6, 6))
    kernels.batch_task_jacobians(P, Q[:10], lam[:10], False, X[:10], J[:10])

    def once() -> float:
        t = time.perf_counter()
        kernels.batch_task_jacobians(P, Q, lam, False, X, J)
        return time.perf_counter() - t

    rate = n / statistics.median(once() for _ in range(5))
    robot, m = Iramis(), 2000
    t = time.perf_counter()
    for i in range(m):
        extended_task(robot, Q[i], lam[i])
        augmented_jacobian(robot, Q[i], lam[i])
    ref_rate = m / (time.perf_counter() - t)
    return [
        row("batched X_ext + J_a evaluations, one core", rate / 1e6, "M/s",
            "rcmplan reference Python", ref_rate / 1e6, ">= 5 M/s"),
    ]  # fmt: skip


def injection_rows() -> list[dict[str, Any]]:
    """The whole default injection on the kinematic plant: compiled path and reference path."""
    robot = Iramis()
    eye = default_eye(robot)
    pts = default_points(eye)

    def once(make: type[Controller]) -> tuple[float, int]:
        t = time.perf_counter()
        log = make(KinematicPlant(robot), PinvSolver()).run(injection(robot, eye, pts))
        return time.perf_counter() - t, len(log)

    once(FastController)
    fast = statistics.median(once(FastController)[0] for _ in range(3 if quick() else 9))
    use_path("off")
    try:
        ref, n = once(Controller)
        ref = min(ref, *(once(Controller)[0] for _ in range(1 if quick() else 2)))
    finally:
        use_path(None)
    thesis = n * THESIS_ITERATION_S
    tag = f"default injection, kinematic plant ({n} iterations)"
    return [
        row(f"{tag}, compiled path", 1e3 * fast, "ms", "thesis V-REP rate", 1e3 * thesis,
            "<= 50 ms"),
        row(f"{tag}, reference Python", 1e3 * ref, "ms", "thesis V-REP rate", 1e3 * thesis),
    ]  # fmt: skip


def timed_process(cmd: list[str], env: dict[str, str]) -> float:
    """Wall time in [s] of one process. Python writes its bytecode whatever this shell says
    (PYTHONDONTWRITEBYTECODE): a fresh bytecode prefix that is never written would make every
    "later" run compile every module it imports again, which no installed copy does."""
    full = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    t = time.perf_counter()
    subprocess.run(cmd, env={**full, **env}, check=True, capture_output=True)
    return time.perf_counter() - t


def process_rows() -> list[dict[str, Any]]:
    """Process start to finish: `rcmplan inject` (and its first QP run), numba's cold compile and
    warm load."""
    py = sys.executable
    with tempfile.TemporaryDirectory() as tmp:
        fresh = {"NUMBA_CACHE_DIR": f"{tmp}/numba", "XDG_CACHE_HOME": f"{tmp}/stamps",
                 "PYTHONPYCACHEPREFIX": f"{tmp}/pyc"}  # fmt: skip
        inject = [py, "-m", "rcmplan", "inject", "--no-plots", "--out", f"{tmp}/out"]
        first = timed_process(inject, fresh)
        later = statistics.median(timed_process(inject, fresh) for _ in range(3))
        qp = {**fresh, "NUMBA_CACHE_DIR": f"{tmp}/numba3", "XDG_CACHE_HOME": f"{tmp}/stamps3"}
        first_qp = timed_process([*inject, "--method", "qp"], qp)
        load = [py, "-c", "from rcmplan.warmup import compile_kernels; compile_kernels()"]
        compile_s = timed_process(load, {**fresh, "NUMBA_CACHE_DIR": f"{tmp}/numba2"})
        load_s = statistics.median(timed_process(load, fresh) for _ in range(3))
    note = "(fresh bytecode and numba caches)"
    return [
        row(f"`rcmplan inject --no-plots` first run {note}", first, "s"),
        row("`rcmplan inject --no-plots` later runs, median of 3", later, "s", target="< 1 s"),
        row(f"`rcmplan inject --method qp --no-plots` first run {note}", first_qp, "s"),
        row(
            "compile every kernel, cold numba cache (one process)", compile_s, "s", target="<= 20 s"
        ),
        row("process that loads every kernel from numba's cache", load_s, "s"),
    ]


def rows() -> list[dict[str, Any]]:
    """Every speed figure."""
    return step_rows() + loop_rows() + batch_rows() + injection_rows() + process_rows()


if __name__ == "__main__":
    from run import print_table

    print_table(rows())
