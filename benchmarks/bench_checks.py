"""What the argument checks cost on the control loop's path.

Run alone: python benchmarks/bench_checks.py [--loop]
Prints one JSON object: per call in [us] (best of 7 batches of 5,000) of the kinematics, solver
and target calls the Python loop makes per iteration or per target; with --loop also the default
injection on the Python loop (`ReferenceRunner`, pinv and DLS, minimum of 10 runs) and on the
compiled path (median and minimum of 30 runs) in [s]. To compare with code without the checks,
run it alternately with PYTHONPATH set to each source tree and take each figure's minimum.
"""

from __future__ import annotations

import json
import statistics
import sys
import time
import timeit
from collections.abc import Callable
from typing import Any

import rcmplan as rp


def per_call() -> dict[str, float]:
    """Microseconds per call at a pose on the default insertion, the needle through the trocar."""
    robot = rp.Iramis()
    eye = rp.default_eye(robot)
    targets = rp.injection(robot, eye, rp.default_points(eye))[2].targets
    pose = rp.solve_pose(robot, targets[3])
    q, lam, target = pose.q, pose.lam, targets[4]
    pinv, dls = rp.PinvSolver(), rp.DlsSolver()
    error = pinv.error(robot, q, lam, target)
    calls: dict[str, Callable[[], Any]] = {
        "Iramis.needle_point": lambda: robot.needle_point(q, lam),
        "Iramis.needle_point_jacobian": lambda: robot.needle_point_jacobian(q, lam),
        "Iramis.check_singularity": lambda: robot.check_singularity(q, None),
        "PinvSolver.error": lambda: pinv.error(robot, q, lam, target),
        "PinvSolver.step": lambda: pinv.step(robot, q, lam, target, error),
        "DlsSolver.error": lambda: dls.error(robot, q, lam, target),
        "DlsSolver.step": lambda: dls.step(robot, q, lam, target, error),
        "solve_pose": lambda: rp.solve_pose(robot, target),
    }
    return {k: 1e6 * min(timeit.repeat(f, number=5000, repeat=7)) / 5000 for k, f in calls.items()}


def runs(method: str, n: int) -> list[float]:
    """Wall times in [s] of n runs of the default injection with `method` (one warm-up)."""
    scenario = rp.load_scenario("default").with_method(method)
    rp.run_scenario(scenario)
    out = []
    for _ in range(n):
        start = time.perf_counter()
        rp.run_scenario(scenario)
        out.append(time.perf_counter() - start)
    return out


def loop_figures() -> dict[str, float]:
    """The default injection compiled, then on the Python loop (the runner is registered last:
    it stays for the rest of the process)."""
    from rcmplan.control.runner import ReferenceRunner, register_default

    compiled = runs("pinv", 30)
    register_default(ReferenceRunner())
    return {
        "compiled_median_s": statistics.median(compiled), "compiled_min_s": min(compiled),
        "python_pinv_min_s": min(runs("pinv", 10)), "python_dls_min_s": min(runs("dls", 10)),
    }  # fmt: skip


if __name__ == "__main__":
    figures = per_call()
    if "--loop" in sys.argv:
        figures |= loop_figures()
    print(json.dumps({k: round(v, 4) for k, v in figures.items()}))
