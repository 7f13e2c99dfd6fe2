"""Median QP solve time per control step, per candidate solver, on problems recorded from the
default injection run with the QP controller on the kinematic plant.

Run: python benchmarks/bench_qp.py [--problems N] [--repeat R]

Each candidate solves the same recorded problems; the table gives the median and 90th
percentile wall time per solve, the ratio to the fastest median, and the largest difference of
the solution from DAQP's (in um of slider motion, the variables' unit).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from rcmplan import Iramis
from rcmplan._validate import FloatArray
from rcmplan.control.loop import Controller
from rcmplan.control.qp import QpSolver
from rcmplan.control.qp_backends import BACKENDS, QpResult, solve
from rcmplan.control.qp_problem import QPProblem, StepQP
from rcmplan.exceptions import QPError
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.scene.procedures import injection
from rcmplan.sim import KinematicPlant


class RecordingQp(QpSolver):
    """A QpSolver that keeps every problem it solves."""

    problems: list[QPProblem]

    def _solve(
        self, robot: Iramis, q: FloatArray, lam: float, target: FloatArray
    ) -> tuple[StepQP, QpResult]:
        before = self.last
        out = super()._solve(robot, q, lam, target)
        if out is not before:
            self.problems.append(out[0].problem)
        return out


def record_problems() -> tuple[list[QPProblem], float]:
    """Every QP solved in the default injection with the QP method, and the run's time per
    control step (build, solve and loop) in [s]."""
    robot = Iramis()
    eye = default_eye(robot)
    solver = RecordingQp(robot, eye)
    solver.problems = []
    start = time.perf_counter()
    log = Controller(KinematicPlant(robot), solver).run(injection(robot, eye, default_points(eye)))
    return solver.problems, (time.perf_counter() - start) / len(log)


def time_backend(
    name: str, problems: list[QPProblem], repeat: int
) -> tuple[np.ndarray, float, int]:
    """Per-problem best-of-`repeat` solve times [s], the largest |x - x_daqp| [um] and the
    number of failed solves (QPError; their time is kept)."""
    times = np.empty(len(problems))
    worst, failed = 0.0, 0
    for i, p in enumerate(problems):
        best, x = np.inf, None
        for _ in range(repeat):
            t0 = time.perf_counter()
            try:
                x = solve(p, name).x
            except QPError:
                x = None
            best = min(best, time.perf_counter() - t0)
        times[i] = best
        if x is None:
            failed += 1
        else:
            worst = max(worst, float(np.max(np.abs(x - solve(p, "daqp").x))))
    return times, worst, failed


def main() -> None:
    """Print the table."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--problems", type=int, default=2000, help="problems sampled evenly")
    parser.add_argument("--repeat", type=int, default=3, help="solves per problem (best kept)")
    args = parser.parse_args()
    problems, per_step = record_problems()
    picked = [problems[i] for i in np.linspace(0, len(problems) - 1, args.problems).astype(int)]
    rows = []
    for name in BACKENDS:
        times, worst, failed = time_backend(name, picked, args.repeat)
        rows.append((name, 1e6 * np.median(times), 1e6 * np.percentile(times, 90), worst, failed))
    fastest = min(r[1] for r in rows)
    print(f"{len(problems)} QPs recorded from the default injection; {len(picked)} timed")
    print(f"whole control step (build + solve + loop) in the run: {1e6 * per_step:.0f} us")
    head = f"{'solver':<16}{'median us':>10}{'p90 us':>9}{'ratio':>7}"
    print(f"{head}{'max |x - daqp| um':>19}{'failed':>8}")
    for name, med, p90, worst, failed in sorted(rows, key=lambda r: r[1]):
        line = f"{name:<16}{med:>10.1f}{p90:>9.1f}{med / fastest:>7.2f}"
        print(f"{line}{worst:>19.2e}{failed:>8d}")


if __name__ == "__main__":
    main()
