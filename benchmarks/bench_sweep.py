"""Sweep throughput: 10,000 reachable retina targets on local processes, and Dask scaling.

    python benchmarks/bench_sweep.py                 # the full figures (minutes on 2 cores)
    python benchmarks/bench_sweep.py --targets 1000  # a shorter local sweep
    python benchmarks/bench_sweep.py --per-worker 0  # the local sweep alone, no Dask scaling
    python benchmarks/run.py --quick --only bench_sweep   # quick: 1,000 targets, 40 per worker

Figures:
- wall time of a sweep with the default method (the default scenario's pinv, K = 1, 0.2 mm
  steps) over the default 25 deg cone, sampled densely enough to give at least N reachable
  targets, on every local core (sampling included, figures and outputs excluded);
- the same fixed set of reachable targets on a Dask LocalCluster with one and with two worker
  processes (one thread each): wall time and speed-up.
Beside each wall time, the CPU time its worker processes used (psutil for the local pool,
time.process_time on each Dask worker) and the share of a core each worker got (CPU / wall):
on a shared machine a share below 1 is time the workers waited for a core, which no change of
rcmplan's code would remove.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import time
from typing import Any

from _common import quick, row
from rcmplan.sweep.executors import DaskExecutor, LocalExecutor
from rcmplan.sweep.runner import run_sweep, run_targets
from rcmplan.sweep.sampling import sample_region
from rcmplan.sweep.settings import MotionSettings, Region, SweepSettings
from rcmplan.sweep.task import run_chunk

REACHABLE_FRACTION = 0.62  # of the default 25 deg cone (measured: 0.63 at 1563 rays)


def children_cpu_s() -> dict[int, float]:
    """CPU time [s] (user + system) of each live descendant process of this one, by pid."""
    import psutil

    out = {}
    for child in psutil.Process().children(recursive=True):
        with contextlib.suppress(psutil.NoSuchProcess):
            out[child.pid] = sum(child.cpu_times()[:2])
    return out


def local_sweep(n_reachable: int) -> tuple[float, int, int, list[float]]:
    """(wall time [s], reachable targets run, rays sampled, CPU time [s] of each worker: the
    pool's `workers` busiest processes, its forkserver aside) of a local sweep on every core."""
    n_rays = math.ceil(n_reachable / REACHABLE_FRACTION)
    settings = SweepSettings(Region(n_targets=n_rays), MotionSettings())
    before = children_cpu_s()
    t = time.perf_counter()
    with LocalExecutor() as ex:
        result = run_sweep(settings, ex)
        wall, after = time.perf_counter() - t, children_cpu_s()
    cpu = sorted(v - before.get(pid, 0.0) for pid, v in after.items())[-ex.workers :]
    return wall, len(result.results), n_rays, cpu


def _cpu_s() -> float:
    return time.process_time()


def dask_wall(n_workers: int, settings: SweepSettings, ids: list[int]) -> tuple[float, list[float]]:
    """(wall time [s], CPU time [s] of each worker) of the given targets on a LocalCluster with
    n_workers processes."""
    from distributed import Client, LocalCluster

    sample = sample_region(settings.region, settings.motion)
    with (
        LocalCluster(n_workers=n_workers, processes=True, threads_per_worker=1,
                     dashboard_address=None) as cluster,
        Client(cluster.scheduler_address) as client,
        DaskExecutor(cluster.scheduler_address, timeout_s=60) as ex,
    ):  # fmt: skip
        warm = [[(int(i), sample.points[i].tolist())] for i in ids[:1]]
        client.run(lambda: run_chunk(settings.motion, warm[0]))  # every worker's kernels loaded
        run_targets(settings.motion, sample, ids[: 2 * n_workers], ex)
        c0, t = client.run(_cpu_s), time.perf_counter()
        run_targets(settings.motion, sample, ids, ex)
        wall, c1 = time.perf_counter() - t, client.run(_cpu_s)
        return wall, [c1[w] - c0[w] for w in c1]


def share(cpu: list[float], wall: float) -> str:
    """Each worker's CPU time over the wall time, e.g. "0.45 / 0.47"."""
    return " / ".join(f"{c / wall:.2f}" for c in cpu)


def scaling_rows(per_worker: int) -> list[dict[str, Any]]:
    """LocalCluster 1 vs 2 workers on the same 2 * per_worker targets."""
    settings = SweepSettings(Region(n_targets=4 * per_worker), MotionSettings())
    ids = sample_region(settings.region, settings.motion).reachable_ids.tolist()[: 2 * per_worker]
    (one, cpu1), (two, cpu2) = dask_wall(1, settings, ids), dask_wall(2, settings, ids)
    work = f"{len(ids)} targets"
    return [
        row(f"Dask LocalCluster, 2 workers ({work})", two, "s", "1 worker", one),
        row(f"Dask speed-up 1 -> 2 workers ({work})", one / two, "x", target="about 2 on 2 cores"),
        row("  workers' CPU time, 2 workers (sum)", sum(cpu2), "s", "1 worker", sum(cpu1)),
        row(f"  share of a core per worker, 2 workers: {share(cpu2, two)}; 1 worker: "
            f"{share(cpu1, one)}", "", ""),
        row("load average (1 min) after the scaling", os.getloadavg()[0], ""),
    ]  # fmt: skip


def rows(n_reachable: int | None = None, per_worker: int | None = None) -> list[dict[str, Any]]:
    """Every sweep figure."""
    n = n_reachable or (1000 if quick() else 10_000)
    load0 = os.getloadavg()[0]
    wall, ran, rays, cpu = local_sweep(n)
    load = os.getloadavg()[0]
    label = f"sweep, {ran} reachable targets of {rays} rays, local {os.cpu_count()} processes"
    out = [
        row(label, wall, "s", target="<= 60 s for 10,000"),
        row("sweep throughput", ran / wall, "targets/s"),
        row("  workers' CPU time (sum; sampling runs before them)", sum(cpu), "s"),
        row(f"  share of a core per worker: {share(cpu, wall)}", "", ""),
        row("load average (1 min) before the local sweep", load0, ""),
        row("load average (1 min) after the local sweep", load, ""),
    ]
    per = (150 if quick() else 2500) if per_worker is None else per_worker
    return out + (scaling_rows(per) if per > 0 else [])


if __name__ == "__main__":
    from run import print_table

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--targets", type=int, help="reachable targets of the local sweep (10000)")
    ap.add_argument(
        "--per-worker", type=int, help="targets per worker of the scaling (2500; 0: no scaling)"
    )
    a = ap.parse_args()
    print_table(rows(a.targets, a.per_worker))
