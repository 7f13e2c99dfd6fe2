"""Many subretinal episodes: drawn conditions, every compensation method on the same episodes,
run on the sweep's executors and checkpointed as they finish.

Job i of a batch is episode i // M with method i % M (M methods, in `methods` order): the
episode's conditions come from `episode_draws.draw_episode(ranges, seed, episode)`, the rest of
its settings from `base` (among them `ioct_estimates`: with "image" every volume is rendered and
segmented, and the drawn `noise_std_m`, the stand-in's, is not used: its record holds None).
A job is a pure function of (batch settings, i), so its record is the same on any executor and
in any order; only `wall_time_s` differs.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field, fields, replace
from typing import Any

from rcmplan.exceptions import InvalidInputError, RcmplanError
from rcmplan.subretinal.episode_draws import DrawRanges, EpisodeDraw, draw_episode
from rcmplan.subretinal.episode_settings import EpisodeSettings
from rcmplan.subretinal.predictors import PREDICTORS
from rcmplan.sweep.checkpoint import RecordCheckpoint
from rcmplan.sweep.executors import Executor, make_chunks
from rcmplan.sweep.settings import settings_digest

METHODS = tuple(PREDICTORS)
PRELOAD = ("rcmplan.subretinal.episode_batch",)  # what local workers import before a job
MAX_EPISODES = 1_000_000
# Settings of `base` that every episode replaces with its draw and method.
DRAWN = ("compensation", "seed", "breathing_m", "cardiac_amplitude_m", "breathing_rate_hz",
         "cardiac_rate_hz", "ioct_rate_hz", "latency_s", "noise_std_m",
         "target_fraction", "eye_drift_m")  # fmt: skip


@dataclass(frozen=True)
class BatchSettings:
    """A batch of episodes (SI units).

    Attributes:
        episodes: Number of drawn episodes; each runs once per method.
        seed: Seed of the draws (`episode_draws`).
        methods: Compensation methods compared on every episode.
        ranges: Ranges of the drawn conditions.
        base: Settings of every episode apart from its draw and method (robot, hold, ...).
    """

    episodes: int
    seed: int = 0
    methods: tuple[str, ...] = METHODS
    ranges: DrawRanges = field(default_factory=DrawRanges)
    base: EpisodeSettings = field(default_factory=EpisodeSettings)

    def __post_init__(self) -> None:
        n = self.episodes
        if not isinstance(n, int) or isinstance(n, bool) or not 1 <= n <= MAX_EPISODES:
            raise InvalidInputError("episodes", n, f"an integer in [1, {MAX_EPISODES}]")
        if not isinstance(self.seed, int) or not 0 <= self.seed < 2**32:
            raise InvalidInputError("seed", self.seed, "an integer in [0, 2**32)")
        methods = tuple(self.methods)
        if not methods or len(set(methods)) != len(methods) or set(methods) - set(METHODS):
            valid = "distinct names among " + ", ".join(METHODS)
            raise InvalidInputError("methods", self.methods, valid)
        object.__setattr__(self, "methods", methods)
        self.ranges.check_against(self.base)

    @property
    def n_items(self) -> int:
        """Jobs in the batch: episodes x methods."""
        return self.episodes * len(self.methods)

    def job(self, item: int) -> tuple[EpisodeDraw, str]:
        """The draw and the method of job `item`."""
        episode, m = divmod(item, len(self.methods))
        return draw_episode(self.ranges, self.seed, episode), self.methods[m]

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON-ready dictionary (the base without the drawn settings)."""
        base = {k: v for k, v in asdict(self.base).items() if k not in DRAWN}
        base["direction"] = [float(x) for x in base["direction"]]
        return {"episodes": self.episodes, "seed": self.seed, "methods": list(self.methods),
                "ranges": self.ranges.as_dict(), "base": base}  # fmt: skip

    def digest(self) -> str:
        """SHA-256 over the settings, robot parameters and format and package versions."""
        return settings_digest({"subretinal_episodes": self.as_dict()})


FIGURES = ("tracking_rms_m", "depth_error_m", "depth_rms_error_m", "in_band_fraction",
           "rpe_breach", "max_depth_past_rpe_m", "max_rcm_deviation_m",
           "prediction_rms_m", "max_trocar_displacement_m", "segmentation_rms_m",
           "acquisitions_dropped")  # fmt: skip
DRAW_FIELDS = tuple(f.name for f in fields(EpisodeDraw))
# The columns of a record as written (episodes.csv, episodes.json, checkpoint rows): the record
# flat, its draw's fields in place of `draw`, the episode beside the id and the seed before the
# conditions.
COLUMNS = ("id", "episode", "compensation", "ioct_estimates", "status", "success",
           *(name for name in DRAW_FIELDS if name != "episode"), *FIGURES, "wall_time_s",
           "message")  # fmt: skip


@dataclass(frozen=True)
class EpisodeRecord:
    """One job's result (SI units): its draw, method, iOCT estimates, status and figures
    (`episode_metrics.summarise`). `success`: status "ok" (no RPE breach, RCM within its
    bound, ILM punctured) and the tip in the target band for the whole hold. The draw's
    `noise_std_m` is None with "image" estimates (the drawn value is the stand-in's)."""

    id: int
    draw: EpisodeDraw
    compensation: str
    ioct_estimates: str
    status: str
    success: bool
    tracking_rms_m: float | None
    depth_error_m: float | None
    depth_rms_error_m: float | None
    in_band_fraction: float | None
    rpe_breach: bool | None
    max_depth_past_rpe_m: float | None
    max_rcm_deviation_m: float | None
    prediction_rms_m: float | None
    max_trocar_displacement_m: float | None
    segmentation_rms_m: float | None
    acquisitions_dropped: int | None
    wall_time_s: float
    message: str = ""

    def identity(self) -> tuple[Any, ...]:
        """Every field except the wall time: equal on any executor for the same batch."""
        return tuple(getattr(self, f.name) for f in fields(self) if f.name != "wall_time_s")

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON-ready dictionary, flat, keys in `COLUMNS` order."""
        row = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "draw"}
        row.update(self.draw.as_dict())
        return {name: row[name] for name in COLUMNS}

    @staticmethod
    def from_dict(data: dict[str, Any]) -> EpisodeRecord:
        """Inverse of as_dict; KeyError or TypeError on a malformed record."""
        if set(data) != set(COLUMNS):
            raise KeyError(f"fields {sorted(data)} differ from {list(COLUMNS)}")
        draw = EpisodeDraw(**{name: data[name] for name in DRAW_FIELDS})
        own = {name: value for name, value in data.items() if name not in DRAW_FIELDS}
        return EpisodeRecord(draw=draw, **own)


def _finite(value: Any) -> Any:
    """A figure as stored: None for a missing or non-finite number."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def run_job(batch: BatchSettings, item: int) -> EpisodeRecord:
    """Run job `item` of the batch and measure it; an error inside the episode becomes its
    status ("error", or the error's own) with the message, not a failed batch."""
    from rcmplan.subretinal.episode import run_episode
    from rcmplan.subretinal.episode_metrics import summarise

    draw, method = batch.job(item)
    t0 = time.perf_counter()
    try:
        doc = summarise(run_episode(draw.settings(batch.base, method)))
        status, message = str(doc["status"]), str(doc["message"])
        figures = {k: _finite(doc[k]) for k in FIGURES}
    except RcmplanError as exc:
        status, message = exc.status, f"{type(exc).__name__}: {exc}"
        figures = dict.fromkeys(FIGURES)
    success = status == "ok" and figures["in_band_fraction"] == 1.0
    if batch.base.ioct_estimates == "image":
        draw = replace(draw, noise_std_m=None)  # the stand-in's, not used
    return EpisodeRecord(id=item, draw=draw, compensation=method,
                         ioct_estimates=batch.base.ioct_estimates, status=status,
                         success=success, **figures, wall_time_s=time.perf_counter() - t0,
                         message=message)  # fmt: skip


def run_jobs(batch: BatchSettings, items: Sequence[int]) -> list[EpisodeRecord]:
    """run_job on each item of a chunk, in order (the unit of work of an executor)."""
    return [run_job(batch, int(i)) for i in items]


class EpisodeCheckpoint(RecordCheckpoint[BatchSettings, EpisodeRecord]):
    """A batch's checkpoint: one record per job."""

    kind = "episode batch"
    format_name = "rcmplan-subretinal-episodes-checkpoint"

    @staticmethod
    def count(settings: BatchSettings) -> int:
        """Jobs in the batch."""
        return settings.n_items

    @staticmethod
    def parse(row: dict[str, Any]) -> EpisodeRecord:
        """A job's record."""
        return EpisodeRecord.from_dict(row)


@dataclass(frozen=True)
class BatchResult:
    """The records of a batch by job id, how many came from the checkpoint, the wall time of
    this call [s] and where the jobs ran."""

    settings: BatchSettings
    records: dict[int, EpisodeRecord]
    resumed: int
    wall_time_s: float
    executor: str

    def ordered(self) -> list[EpisodeRecord]:
        """Records sorted by job id."""
        return [self.records[i] for i in sorted(self.records)]


def run_batch(
    batch: BatchSettings,
    executor: Executor,
    checkpoint: EpisodeCheckpoint | None = None,
    on_chunk: Callable[[list[EpisodeRecord]], None] | None = None,
    chunk_size: int = 1,
) -> BatchResult:
    """Run every job not yet in the checkpoint, writing each finished chunk to it before the
    next is awaited (an interrupted batch loses only the chunks still running)."""
    start = time.perf_counter()
    done = checkpoint.load() if checkpoint is not None else {}
    resumed = len(done)
    todo = [i for i in range(batch.n_items) if i not in done]
    chunks = make_chunks(todo, executor.workers, chunk_size)
    for records in executor.map_jobs(run_jobs, batch, chunks):
        if checkpoint is not None:
            checkpoint.write(records)
        done.update((r.id, r) for r in records)
        if on_chunk is not None:
            on_chunk(records)
    return BatchResult(batch, done, resumed, time.perf_counter() - start, executor.label)
