"""Median QP solve time per control step, per candidate solver, on problems recorded from the
default injection run with the QP controller on the kinematic plant.

Run: python benchmarks/bench_qp.py [--problems N] [--repeat R]

Each installed candidate solves the same recorded problems; the table gives the median wall
time of its successful solves, the ratio to DAQP's, the number of failed solves, and the
largest difference of the solution from DAQP's (in um of slider motion, the variables' unit).
Back ends that are not installed are listed as skipped, with no time.
"""

from __future__ import annotations

import argparse
import importlib.util
import time
import warnings
from typing import Any

import numpy as np

from _common import quick, row
from _recording import RecordingQp
from rcmplan import Iramis
from rcmplan.analysis.limits import KINDS, violations
from rcmplan.control.methods import MethodSettings
from rcmplan.control.qp import QpSolver
from rcmplan.control.qp_backends import BACKENDS, solve
from rcmplan.control.qp_problem import QPProblem
from rcmplan.control.solvers import DlsSolver, PinvSolver
from rcmplan.controller import Controller
from rcmplan.exceptions import QPError, RcmplanError
from rcmplan.scene.constrained import Scene, grazing_spiral, near_slider_limit
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.scene.procedures import injection
from rcmplan.sim import KinematicPlant


def record_problems() -> tuple[list[QPProblem], float]:
    """Every QP solved in the default injection with the QP method, and the run's time per
    control step (build, solve and loop) in [s]."""
    robot = Iramis()
    eye = default_eye(robot)
    solver = RecordingQp(robot, eye)
    start = time.perf_counter()
    log = Controller(KinematicPlant(robot), solver).run(injection(robot, eye, default_points(eye)))
    return solver.problems, (time.perf_counter() - start) / len(log)


def installed(name: str) -> bool:
    """True if the back end can run here: DAQP's own module, or qpsolvers with that solver."""
    if name == "daqp":
        return importlib.util.find_spec("daqp") is not None
    if importlib.util.find_spec("qpsolvers") is None:
        return False
    import qpsolvers

    return ("daqp" if name == "daqp-qpsolvers" else name) in qpsolvers.available_solvers


def time_backend(
    name: str, problems: list[QPProblem], repeat: int
) -> tuple[np.ndarray, float, int]:
    """Per-problem best-of-`repeat` solve times [s] (NaN where the solve failed), the largest
    |x - x_daqp| [um] and the number of failed solves (QPError)."""
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
        times[i] = best if x is not None else np.nan
        if x is None:
            failed += 1
        else:
            worst = max(worst, float(np.max(np.abs(x - solve(p, "daqp").x))))
    return times, worst, failed


def solve_rows(n_problems: int, repeat: int) -> list[dict[str, Any]]:
    """Median solve time per installed backend on problems recorded from the default injection;
    a backend that is not installed is listed as skipped, one that failed every solve as
    failed, never with a time."""
    problems, per_step = record_problems()
    picked = [problems[i] for i in np.linspace(0, len(problems) - 1, n_problems).astype(int)]
    present = [name for name in BACKENDS if installed(name)]
    with warnings.catch_warnings():  # peers report their iteration caps; failures are counted
        warnings.simplefilter("ignore")
        timed = {name: time_backend(name, picked, repeat) for name in present}
    medians = {name: _median_us(t) for name, (t, _, _) in timed.items()}
    chosen = medians["daqp"]
    out = [row(f"QP solve per control step, DAQP own API ({len(picked)} of {len(problems)} "
               "recorded)", chosen, "us", target="<= 50 us")]  # fmt: skip
    for name in sorted(present, key=lambda n: (np.isnan(medians[n]), medians[n])):
        if name == "daqp":
            continue
        _, worst, failed = timed[name]
        label = f"QP solve per control step, {name} ({failed} of {len(picked)} failed"
        if np.isnan(medians[name]):
            out.append(row(f"{label}; no time)", "every solve failed", "", name))
            continue
        out.append(row(f"{label}, timed on the rest; max |x - daqp| {worst:.1e} um)", chosen,
                       "us", name, medians[name]))  # fmt: skip
    for name in BACKENDS:
        if name not in present:
            out.append(row(f"QP solve per control step, {name}", "not installed: skipped", "",
                           name))  # fmt: skip
    out.append(row("whole QP control step in the run (build + solve + loop)", 1e6 * per_step, "us"))
    return out


def _median_us(times_s: np.ndarray) -> float:
    """Median of the successful solves in [us]; NaN when none succeeded."""
    ok = times_s[np.isfinite(times_s)]
    return 1e6 * float(np.median(ok)) if ok.size else float("nan")


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
