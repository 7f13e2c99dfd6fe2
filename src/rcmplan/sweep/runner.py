"""A sweep end to end: sample the region, run every reachable target, checkpoint as results come.

Results already in the checkpoint are not run again; each finished chunk is written before the
next is awaited, so an interrupted sweep loses at most the chunks still running.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rcmplan.sweep.checkpoint import Checkpoint
from rcmplan.sweep.errors import CheckpointError
from rcmplan.sweep.executors import Executor, LocalExecutor, make_chunks
from rcmplan.sweep.sampling import Sample, sample_region
from rcmplan.sweep.settings import MotionSettings, SweepSettings
from rcmplan.sweep.task import TargetItem, TargetResult

ChunkCallback = Callable[[list[TargetResult]], None]


@dataclass(frozen=True)
class SweepResult:
    """A finished (or resumed and finished) sweep.

    Attributes:
        settings: What ran.
        sample: Every sampled target with its reachability.
        results: Result per reachable target id.
        wall_time_s: Wall time of this call in [s] (sampling and motions).
        executor: Which executor ran it.
        resumed: How many results came from the checkpoint rather than this call.
    """

    settings: SweepSettings
    sample: Sample
    results: dict[int, TargetResult]
    wall_time_s: float
    executor: str
    resumed: int = 0

    def ordered(self) -> list[TargetResult]:
        """Results sorted by target id."""
        return [self.results[i] for i in sorted(self.results)]

    def column(self, name: str) -> NDArray[np.float64]:
        """A result field per sampled target (N,), NaN where not run or None."""
        out = np.full(len(self.sample), np.nan)
        for i, r in self.results.items():
            v = r.converged if name == "converged" else getattr(r, name)
            out[i] = np.nan if v is None else float(v)
        return out


def run_targets(
    motion: MotionSettings,
    sample: Sample,
    ids: Sequence[int],
    executor: Executor,
    checkpoint: Checkpoint | None = None,
    on_chunk: ChunkCallback | None = None,
    chunk_size: int | None = None,
) -> tuple[dict[int, TargetResult], int]:
    """Run the targets `ids` not yet in the checkpoint; (results by id, number resumed)."""
    done = checkpoint.load() if checkpoint is not None else {}
    wanted = {int(i) for i in ids}
    stray = sorted(set(done) - wanted)
    if stray and checkpoint is not None:
        raise CheckpointError(checkpoint.path, f"holds ids {stray[:5]} that this sweep never runs")
    resumed = len(done)
    todo: list[TargetItem] = [
        (int(i), sample.points[i].tolist()) for i in sorted(wanted) if i not in done
    ]
    for results in executor.map_chunks(motion, make_chunks(todo, executor.workers, chunk_size)):
        if checkpoint is not None:
            checkpoint.write(results)
        done.update((r.id, r) for r in results)
        if on_chunk is not None:
            on_chunk(results)
    return done, resumed


def run_sweep(
    settings: SweepSettings,
    executor: Executor | None = None,
    checkpoint: Checkpoint | None = None,
    on_chunk: ChunkCallback | None = None,
    on_sample: Callable[[Sample], None] | None = None,
    chunk_size: int | None = None,
) -> SweepResult:
    """Sample the region and run every reachable target (all cores locally by default).

    Args:
        executor: Where chunks run (default: LocalExecutor on every core, closed afterwards).
        checkpoint: Where finished chunks are written and resumed from.
        on_chunk: Called with each finished chunk's results (progress bars).
        on_sample: Called once with the sample, before any motion.
    """
    start = time.perf_counter()
    sample = sample_region(settings.region, settings.motion)
    if on_sample is not None:
        on_sample(sample)
    own = executor is None
    ex: Executor = LocalExecutor() if executor is None else executor
    try:
        results, resumed = run_targets(
            settings.motion,
            sample,
            sample.reachable_ids.tolist(),
            ex,
            checkpoint,
            on_chunk,
            chunk_size,
        )
    finally:
        if own:
            ex.close()
    return SweepResult(
        settings, sample, results, time.perf_counter() - start, ex.label, resumed=resumed
    )
