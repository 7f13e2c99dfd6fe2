"""What one default subretinal episode costs, and where: the compiled block loop against one
period at a time, on the kinematic plant and on the dynamic MuJoCo plant.

Run alone: python benchmarks/bench_subretinal_episode.py [--repeats N]; `rows()` for run.py
(1 run per figure under --quick). Alone, it prints one JSON object: per compensation and path
(`blocks`: the planned periods of each iOCT interval as one compiled call, `episode_blocks`;
`periods`: one period at a time with the compiled QP step, `period_step`; `python`: one period
at a time with the Python `QpSolver.step`; `mujoco`: the dynamic MuJoCo plant, one period at a
time with the compiled QP step planned from the plant's last command), the minimum and median
over N runs (3) of the episode's loop (`Episode.run`, 9,350 periods of 1 ms, built beforehand)
in [s], the real-time factor of the fastest run (simulated 9.35 s / loop wall time), for the
per-period paths the time inside the QP step in [s] (timed around each call), and the fastest
run's max RCM deviation and hover tracking RMS [m] (`summary.json`'s figures). The machine's
load average is printed with them. The episodes take the iOCT stand-in (`--ioct-estimates
noise`, the default here: no image rendered, so that the loop's own cost is measured);
`--ioct-estimates image` times them with every volume rendered and segmented.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import time
from typing import Any

from _common import quick, row
from rcmplan.subretinal.episode import Episode
from rcmplan.subretinal.episode_metrics import summarise
from rcmplan.subretinal.episode_settings import EpisodeSettings

PATHS = ("blocks", "periods", "python", "mujoco")


def timed_run(
    compensation: str, path: str, estimates: str = "noise"
) -> tuple[float, float, float, dict[str, Any]]:
    """(loop wall time [s], time in the QP step [s] (NaN for the block loop), simulated time
    [s], the episode's summary) of one default episode on a path (PATHS)."""
    plant = "mujoco" if path == "mujoco" else "kinematic"
    ep = Episode(EpisodeSettings(compensation=compensation, plant=plant, ioct_estimates=estimates))
    spent = [0.0]
    if path == "blocks" and ep.blocks is None:
        raise RuntimeError("the compiled block loop does not apply here")
    if path == "mujoco" and (ep.fast_step is None or ep.solver.servo is not ep.plant):
        raise RuntimeError("the compiled servo step does not apply here")
    if path != "blocks":
        ep.blocks = None
        if path == "python" or ep.fast_step is None:
            ep.fast_step = None
            inner = ep.solver.step
        else:
            inner = ep.fast_step

        def step(*args: Any) -> Any:
            t = time.perf_counter()
            out = inner(*args)
            spent[0] += time.perf_counter() - t
            return out

        if ep.fast_step is None:
            ep.solver.step = step  # type: ignore[method-assign]
        else:
            ep.fast_step = step
    start = time.perf_counter()
    result = ep.run()
    loop = time.perf_counter() - start
    return loop, spent[0] if path != "blocks" else math.nan, ep.length_s, summarise(result)


def measure(repeats: int, estimates: str = "noise") -> dict[str, Any]:
    """Per compensation and path: the loop's minimum and median [s], the real-time factor at
    the minimum, the QP step's share, the run's RCM and tracking figures."""
    out: dict[str, Any] = {"load_average": os.getloadavg(), "ioct_estimates": estimates}
    for compensation in ("none", "kalman"):
        for path in PATHS:
            runs = [timed_run(compensation, path, estimates) for _ in range(repeats)]
            loop = [r[0] for r in runs]
            best = runs[loop.index(min(loop))]
            out[f"{compensation}/{path}"] = {
                "loop_s_min": min(loop), "loop_s_median": statistics.median(loop),
                "real_time_factor": best[2] / best[0], "qp_step_s_at_min": best[1],
                "status": best[3]["status"],
                "max_rcm_deviation_m": best[3]["max_rcm_deviation_m"],
                "tracking_rms_m": best[3]["tracking_rms_m"],
            }  # fmt: skip
    out["load_average_after"] = os.getloadavg()
    return out


def rows() -> list[dict[str, Any]]:
    """The loop of the default episode as compiled blocks, against one period at a time with
    the compiled QP step; on the dynamic MuJoCo plant against the kinematic plant's blocks."""
    m = measure(1 if quick() else 3)
    out = [row(f"subretinal episode loop, 9,350 periods ({c}), compiled blocks",
               m[f"{c}/blocks"]["loop_s_min"], "s", "one period at a time, compiled QP step",
               m[f"{c}/periods"]["loop_s_min"]) for c in ("none", "kalman")]  # fmt: skip
    out += [row(f"subretinal episode loop, 9,350 periods ({c}), dynamic MuJoCo plant",
                m[f"{c}/mujoco"]["loop_s_min"], "s", "kinematic plant, compiled blocks",
                m[f"{c}/blocks"]["loop_s_min"]) for c in ("none", "kalman")]  # fmt: skip
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--ioct-estimates", choices=("noise", "image"), default="noise")
    args = parser.parse_args()
    out = measure(args.repeats, args.ioct_estimates)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
