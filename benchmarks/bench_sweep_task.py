"""Where a sweep target's CPU time goes, in one process: the whole task, the compiled loop's
kernel and the controller's check of the steps between targets.

    python benchmarks/bench_sweep_task.py [--targets 400] [--no-step-bound]

Runs `rcmplan.sweep.task.run_chunk` on the first N reachable targets of the default sweep
(default method and cone) after a warm-up of 5: the CPU time per target (time.process_time,
best of 3), then one run under cProfile for the kernel (`compiled/loop.py` run_targets) and the
check (`Controller._check_target_steps`), per target and as a share of the profiled time
(cProfile slows the Python parts, not the kernel), and the iterations per target.
--no-step-bound runs the loop with `rcm_tolerance=None` (steps as the solver gives them). Takes
only the sweep's public pieces, so it runs against another checkout's `src` too.
"""

from __future__ import annotations

import argparse
import cProfile
import math
import os
import pstats
import time
from dataclasses import replace
from typing import TYPE_CHECKING

from rcmplan.sweep.sampling import sample_region
from rcmplan.sweep.settings import MotionSettings, Region, SweepSettings
from rcmplan.sweep.task import run_chunk

if TYPE_CHECKING:  # the checkout of 2026-11-22 has no rcmplan.control.phase
    from rcmplan.control.phase import LoopSettings


class UnboundedSteps(MotionSettings):
    """The default motion with the loop's step bound off (LoopSettings.rcm_tolerance None)."""

    def loop(self) -> LoopSettings:
        """The default loop settings without the step bound."""
        return replace(super().loop(), rcm_tolerance=None)


def main(n: int | None = None, bounded: bool = True) -> None:
    """Print the figures for n targets (400; 100 under `run.py --quick`, whose environment
    variable is read here rather than through _common, which a 2026-11-22 checkout lacks)."""
    if n is None:
        n = 100 if os.environ.get("RCMPLAN_BENCH_QUICK") == "1" else 400
    motion = MotionSettings() if bounded else UnboundedSteps()
    settings = SweepSettings(Region(n_targets=math.ceil(n / 0.62)), motion)
    sample = sample_region(settings.region, settings.motion)
    items = [(i, sample.points[i].tolist()) for i in sample.reachable_ids.tolist()[:n]]
    run_chunk(settings.motion, items[:5])
    best = math.inf
    for _ in range(3):
        c = time.process_time()
        results = run_chunk(settings.motion, items)
        best = min(best, time.process_time() - c)
    iterations = sum(r.iterations for r in results) / len(results)
    prof = cProfile.Profile()
    prof.enable()
    run_chunk(settings.motion, items)
    prof.disable()
    stats = pstats.Stats(prof).stats  # type: ignore[attr-defined]
    total = sum(v[2] for v in stats.values())
    kernel = sum(v[2] for k, v in stats.items() if k[2] == "run_targets")
    check = sum(v[3] for k, v in stats.items() if k[2] == "_check_target_steps")
    print(f"{len(items)} targets, load {os.getloadavg()[0]:.2f}: CPU {1e3 * best / n:.2f} ms per "
          f"target (best of 3); under cProfile: kernel {1e3 * kernel / n:.2f} ms "
          f"({100 * kernel / total:.0f} %), target-step check {1e3 * check / n:.2f} ms "
          f"({100 * check / total:.0f} %); {iterations:.1f} iterations per target")  # fmt: skip


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--targets", type=int, help="targets run (400)")
    ap.add_argument("--no-step-bound", action="store_true", help="rcm_tolerance=None")
    a = ap.parse_args()
    main(a.targets, not a.no_step_bound)
