"""The QP controller's control step and run, compiled against the reference Python path.

Run alone: python benchmarks/bench_qp_step.py [--states N]  (or: python benchmarks/run.py).

- The step (QP assembly + DAQP solve + the removable error) at the states the QP controller
  visits in the default injection (recorded from a reference run): the reference
  `QpSolver` (build_step in Python + daqp.solve), timed per state, against the compiled step
  (`qp_kernels.solve_step`: assembly in numba, DAQP's C function called directly), timed over
  batches of BATCH consecutive states inside compiled code (what the compiled loop pays), and
  the step one period at a time that teleoperation and the subretinal episode call from Python
  (`qp_period.period_step`: the solve, the RCM box held, the joints' step) against the
  reference `QpSolver.step`.
- The whole default injection with `--method qp`: `wall_time_s` of `rcmplan inject` in a new
  process (numba's cache warmed first), and the compiled loop's time per iteration in this
  process.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from typing import Any

import numpy as np
from numba import njit

from _common import quick, row, use_path
from _recording import RecordingQp
from rcmplan import Iramis
from rcmplan._validate import FloatArray
from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.qp_kernels import solve_step
from rcmplan.compiled.qp_params import qp_params
from rcmplan.compiled.records import robot_params
from rcmplan.control.qp import QpSolver
from rcmplan.controller import Controller
from rcmplan.robot.iramis_kernels import trig
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.scene.procedures import injection
from rcmplan.sim import KinematicPlant
from rcmplan.warmup import compile_kernels

BATCH = 8


def record_states() -> tuple[FloatArray, QpSolver]:
    """Every state of the default injection's QP steps (N, 13) = (q, lambda, X_ext target)."""
    robot = Iramis()
    eye = default_eye(robot)
    solver = RecordingQp(robot, eye)
    Controller(KinematicPlant(robot), solver).run(injection(robot, eye, default_points(eye)))
    return np.array(solver.states), QpSolver(robot, eye)


def reference_step_s(solver: QpSolver, states: FloatArray) -> FloatArray:
    """Time [s] of the reference step at each state: the X_ext error, build_step and
    daqp.solve (`QpSolver._solve`, its one-state cache cleared)."""
    robot, times = solver.robot, np.empty(len(states))
    for i, x in enumerate(states):
        solver.last = None
        t = time.perf_counter()
        solver._solve(robot, x[:6], float(x[6]), x[7:])
        times[i] = time.perf_counter() - t
    return times


@njit(cache=True)
def _steps(P: Any, Q: Any, contacts: Any, K: Any, states: Any, s: Any, e: Any, qp: Any) -> int:
    """solve_step at every state in turn (the compiled loop's step); returns the optimal count."""
    ok = 0
    for i in range(states.shape[0]):
        q = states[i, :6]
        x, lam = states[i, 7:], states[i, 6]
        ok += solve_step(P, Q, contacts, K, q, trig(q), lam, x, s, e, qp, None, e[:0]) == 1
    return ok


def compiled_step_s(solver: QpSolver, states: FloatArray) -> FloatArray:
    """Mean time [s] per step over each batch of BATCH consecutive states, in compiled code."""
    params = qp_params(solver.robot, solver)
    if params is None:
        raise RuntimeError("the compiled QP step does not apply to the recorded solver")
    K = np.ascontiguousarray(solver.K, dtype=np.float64)
    args = (robot_params(solver.robot), *params, K)
    s, e, qp = np.empty(6), np.empty(6), fast_cache.qp_kernels().buffers()
    _steps(*args, states[:BATCH], s, e, qp)
    times = []
    for i in range(0, len(states) - BATCH + 1, BATCH):
        chunk = states[i : i + BATCH]
        t = time.perf_counter()
        if _steps(*args, chunk, s, e, qp) != BATCH:
            raise RuntimeError("a recorded step QP failed compiled")
        times.append((time.perf_counter() - t) / BATCH)
    return np.array(times)


def period_step_s(solver: QpSolver, states: FloatArray, passes: int = 3) -> tuple[float, float]:
    """Median time [s] per state of the QP's step one period at a time from Python: the
    compiled `qp_period.period_step` (what teleoperation and the subretinal episode call: the
    solve, the RCM box held on the true kinematics, the joints' step) and the reference
    `QpSolver.step` with its task error (its one-state cache cleared). Each path goes over every
    state in turn, `passes` times, alternating; each figure is the lowest of its passes'
    medians (this shared machine's other work only ever adds time)."""
    from rcmplan.compiled.qp_period import period_step

    step = period_step(solver)
    if step is None:
        raise RuntimeError("the compiled period step does not apply to the recorded solver")
    robot, fast, ref = solver.robot, [], []
    for _ in range(passes):
        times = np.empty(len(states))
        for i, x in enumerate(states):
            q, lam, target = x[:6], float(x[6]), x[7:]
            t = time.perf_counter()
            step(q, lam, target)
            times[i] = time.perf_counter() - t
        fast.append(float(np.median(times)))
        for i, x in enumerate(states):
            q, lam, target = x[:6], float(x[6]), x[7:]
            solver.last = None
            t = time.perf_counter()
            solver.step(robot, q, lam, target, solver.task_error(robot, q, lam, target))
            times[i] = time.perf_counter() - t
        ref.append(float(np.median(times)))
    return min(fast), min(ref)


def step_rows(n_states: int) -> list[dict[str, Any]]:
    """The QP step, reference against compiled, at states of the default injection."""
    states, solver = record_states()
    picked = states[np.linspace(0, len(states) - 1, n_states).astype(int)]
    ref = 1e6 * statistics.median(reference_step_s(solver, picked))
    # Consecutive states (as the loop meets them), from evenly spaced starts.
    starts = np.linspace(0, len(states) - 64, max(1, n_states // 64)).astype(int)
    runs = np.concatenate([states[s : s + 64] for s in starts])
    comp = 1e6 * statistics.median(compiled_step_s(solver, runs))
    period, period_ref = (1e6 * t for t in period_step_s(solver, picked))
    tag = f"default injection, {len(runs)} of {len(states)} recorded states"
    return [
        row(f"QP step (assembly + DAQP solve), compiled, median over batches of {BATCH}; {tag}",
            comp, "us", "reference Python (build_step + daqp.solve)", ref, "<= 30 us"),
        row(f"QP step one period at a time from Python (qp_period.period_step: solve, RCM box "
            f"held, joints' step), lowest median of 3 passes; {n_states} states", period, "us",
            "reference Python (QpSolver.task_error + step)", period_ref, "<= 10 us"),
    ]  # fmt: skip


def inject_wall_s() -> tuple[float, dict[str, Any]]:
    """`wall_time_s` of `rcmplan inject --method qp --no-plots` in a new process."""
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "rcmplan", "inject", "--method", "qp", "--no-plots",
               "--out", f"{tmp}/out"]  # fmt: skip
        subprocess.run(cmd, check=True, capture_output=True)
        with open(f"{tmp}/out/summary.json") as f:
            summary = json.load(f)
    return float(summary["wall_time_s"]), summary


def run_rows() -> list[dict[str, Any]]:
    """The whole default injection with the QP: CLI wall time and the loop per iteration."""
    compile_kernels()  # numba's cache warm: the run times the work, not the compile
    fast_s, summary = inject_wall_s()
    robot = Iramis()
    eye = default_eye(robot)
    phases = injection(robot, eye, default_points(eye))
    use_path("on")
    try:
        Controller(KinematicPlant(robot), QpSolver(robot, eye)).run(phases)  # loaded
        t = time.perf_counter()
        log = Controller(KinematicPlant(robot), QpSolver(robot, eye)).run(phases)
        per_it = (time.perf_counter() - t) / len(log)
    finally:
        use_path(None)
    return [
        row(f"`rcmplan inject --method qp` wall_time_s, warm cache "
            f"({summary['iterations']} iterations, status {summary['status']})", fast_s, "s",
            target="<= 1.5 s"),
        row("QP run in process, compiled, per iteration (loop, records, target checks)",
            1e6 * per_it, "us"),
    ]  # fmt: skip


def rows(n_states: int = 2000) -> list[dict[str, Any]]:
    """Every figure of the QP step."""
    if quick():
        n_states = 300
    return step_rows(n_states) + run_rows()


def main() -> None:
    """Print the table."""
    from run import print_table

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--states", type=int, default=2000, help="states sampled evenly")
    args = parser.parse_args()
    print_table(rows(args.states))


if __name__ == "__main__":
    main()
