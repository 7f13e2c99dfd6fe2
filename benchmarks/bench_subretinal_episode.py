"""What one default subretinal episode costs, and where: the QP step against the rest.

Run alone: python benchmarks/bench_subretinal_episode.py [--repeats N]; `rows()` for run.py
(1 run per figure under --quick). Alone, it prints one JSON object: per compensation and QP
path (the compiled step, `period_step`, and the Python `QpSolver.step`), the minimum and median
over N runs (3) of the episode's loop (`Episode.run`, 9,350 periods of 1 ms, built beforehand)
in [s], and of that the time inside the QP step in [s] (timed around each call). The machine's
load average is printed with them.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from typing import Any

from _common import quick, row
from rcmplan.subretinal.episode import Episode
from rcmplan.subretinal.episode_settings import EpisodeSettings


def timed_run(compensation: str, compiled: bool) -> tuple[float, float]:
    """(loop wall time, time in the QP step) [s] of one default episode."""
    ep = Episode(EpisodeSettings(compensation=compensation))
    spent = [0.0]
    if not compiled or ep.fast_step is None:
        ep.fast_step = None
        python_step = ep.solver.step

        def step(*args: Any) -> Any:
            t = time.perf_counter()
            out = python_step(*args)
            spent[0] += time.perf_counter() - t
            return out

        ep.solver.step = step  # type: ignore[method-assign]
    else:
        fast = ep.fast_step

        def fast_step(*args: Any) -> Any:
            t = time.perf_counter()
            out = fast(*args)
            spent[0] += time.perf_counter() - t
            return out

        ep.fast_step = fast_step
    start = time.perf_counter()
    ep.run()
    return time.perf_counter() - start, spent[0]


def measure(repeats: int) -> dict[str, Any]:
    """Per compensation and QP path: the loop's minimum and median [s], the QP step's share."""
    out: dict[str, Any] = {"load_average": os.getloadavg()}
    for compensation in ("none", "kalman"):
        for path, compiled in (("compiled", True), ("python", False)):
            runs = [timed_run(compensation, compiled) for _ in range(repeats)]
            loop = [r[0] for r in runs]
            out[f"{compensation}/{path}"] = {
                "loop_s_min": min(loop), "loop_s_median": statistics.median(loop),
                "qp_step_s_at_min": runs[loop.index(min(loop))][1],
            }  # fmt: skip
    out["load_average_after"] = os.getloadavg()
    return out


def rows() -> list[dict[str, Any]]:
    """The loop of the default episode on the compiled QP step, against the Python step."""
    m = measure(1 if quick() else 3)
    return [row(f"subretinal episode loop, 9,350 periods ({c}), compiled QP step",
                m[f"{c}/compiled"]["loop_s_min"], "s", "Python QP step",
                m[f"{c}/python"]["loop_s_min"]) for c in ("none", "kalman")]  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    out = measure(args.repeats)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
