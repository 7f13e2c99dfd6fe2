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
import warnings
from typing import Any

import numpy as np

from _common import quick, row
from rcmplan import Iramis
from rcmplan._validate import FloatArray
from rcmplan.control.loop import Controller
from rcmplan.control.methods import MethodSettings
from rcmplan.control.qp import QpSolver
from rcmplan.control.qp_backends import BACKENDS, QpResult, solve
from rcmplan.control.qp_problem import QPProblem, StepQP
from rcmplan.control.solvers import DlsSolver, PinvSolver
from rcmplan.exceptions import QPError, RcmplanError
from rcmplan.scene.constrained import Scene, grazing_spiral, near_slider_limit, violations
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


def solve_rows(n_problems: int, repeat: int) -> list[dict[str, Any]]:
    """Median solve time per backend on problems recorded from the default injection."""
    problems, per_step = record_problems()
    picked = [problems[i] for i in np.linspace(0, len(problems) - 1, n_problems).astype(int)]
    with warnings.catch_warnings():  # peers report their iteration caps; failures are counted
        warnings.simplefilter("ignore")
        timed = {name: time_backend(name, picked, repeat) for name in BACKENDS}
    medians = {name: 1e6 * float(np.median(t)) for name, (t, _, _) in timed.items()}
    chosen = 1e6 * float(np.median(timed["daqp"][0]))
    out = [row(f"QP solve per control step, DAQP own API ({len(picked)} of {len(problems)} "
               "recorded)", chosen, "us", target="<= 50 us")]  # fmt: skip
    for name in sorted(BACKENDS, key=medians.__getitem__):
        if name == "daqp":
            continue
        _, worst, failed = timed[name]
        out.append(row(f"QP solve per control step, {name} ({failed} failed, max |x - daqp| "
                       f"{worst:.1e} um)", chosen, "us", name, medians[name]))  # fmt: skip
    out.append(row("whole QP control step in the run (build + solve + loop)", 1e6 * per_step, "us"))
    return out


def violation_rows() -> list[dict[str, Any]]:
    """Limit violations in the log of each method on three scenarios (kinematic plant)."""
    robot = Iramis()
    eye = default_eye(robot)
    scenes = {
        "default injection": Scene(
            eye, default_points(eye), injection(robot, eye, default_points(eye))
        ),
        "near a slider limit": near_slider_limit(robot),
        "grazing the retina": grazing_spiral(robot),
    }
    out = []
    for label, scene in scenes.items():
        for name, solver in (
            ("pinv", PinvSolver()),
            ("dls", DlsSolver()),
            ("qp", QpSolver.from_settings(MethodSettings(), robot, scene.eye)),
        ):
            try:
                log, status = Controller(KinematicPlant(robot), solver).run(scene.phases), "ok"
            except RcmplanError as exc:
                log, status = exc.log, type(exc).__name__
            v = violations(log, robot, scene.eye)
            kinds = ", ".join(f"{k} {getattr(v, k)}" for k in KINDS if getattr(v, k))
            out.append(row(f"{label}, {name}: records breaking a limit ({kinds or 'none'}; "
                           f"run {status})", v.total, "", target="0 for qp"))  # fmt: skip
    return out


KINDS = ("travel", "speed", "lam", "rcm", "retina", "singular")


def rows(n_problems: int = 2000, repeat: int = 3) -> list[dict[str, Any]]:
    """Every QP figure."""
    if quick():
        n_problems, repeat = 300, 1
    return solve_rows(n_problems, repeat) + violation_rows()


def main() -> None:
    """Print the table."""
    from run import print_table

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--problems", type=int, default=2000, help="problems sampled evenly")
    parser.add_argument("--repeat", type=int, default=3, help="solves per problem (best kept)")
    args = parser.parse_args()
    print_table(rows(args.problems, args.repeat))


if __name__ == "__main__":
    main()
