"""Executors: run chunks of jobs on local processes or on a Dask distributed cluster.

Both yield each finished chunk as soon as it completes (in completion order), so the caller can
checkpoint it at once. Chunks batch several jobs per task to amortise the per-task overhead
(pickling, scheduling). A job is `fn(context, chunk)` with a module-level `fn` (the sweep's
`run_chunk` by default) and picklable arguments; results do not depend on the executor when
`fn` is a pure function of them, as a sweep's targets are of (motion settings, target).
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import math
import multiprocessing
import os
import time
from collections.abc import Callable, Generator, Iterator, Sequence
from types import TracebackType
from typing import Any, Protocol, TypeVar

from rcmplan._signals import signals_deferred
from rcmplan.exceptions import InvalidInputError, require_extra
from rcmplan.sweep.errors import SchedulerError, WorkerLostError, endings
from rcmplan.sweep.settings import MotionSettings
from rcmplan.sweep.task import TargetItem, TargetResult, run_chunk

Chunk = list[TargetItem]
C = TypeVar("C")  # what every job of a run shares (a sweep's motion settings)
Item = TypeVar("Item")
R = TypeVar("R")
ChunkFn = Callable[[C, Sequence[Item]], list[R]]
DEFAULT_TIMEOUT_S = 10.0
POLL_S = 0.02  # how often a Dask sweep looks for finished chunks [s]
POLL_LOST_S = 1.0  # how often a local run, with no chunk finished, looks for a dead worker [s]
MAX_POOL_BREAKS = 3  # pools a local run starts again after a worker died, then WorkerLostError


class Executor(Protocol):
    """Runs chunks of targets and yields each chunk's results when it finishes."""

    workers: int

    @property
    def label(self) -> str:
        """Where the chunks ran (for the run's summary)."""
        ...

    def map_chunks(self, motion: MotionSettings, chunks: Sequence[Chunk]) -> Iterator[
        list[TargetResult]
    ]:  # fmt: skip
        """Results of each chunk, in completion order."""
        ...

    def map_jobs(self, fn: ChunkFn[C, Item, R], context: C, chunks: Sequence[Sequence[Item]]
                 ) -> Iterator[list[R]]:  # fmt: skip
        """fn(context, chunk) for each chunk, in completion order."""
        ...

    def close(self) -> None:
        """Release processes or the cluster connection."""
        ...


def check_timeout(timeout_s: float, name: str = "timeout") -> float:
    """timeout_s as a float, or InvalidInputError (naming the argument `name`) unless it is
    positive and finite."""
    try:
        t = float(timeout_s)
    except (TypeError, ValueError, OverflowError):
        t = math.nan
    if not (math.isfinite(t) and t > 0):
        raise InvalidInputError(name, timeout_s, "a positive finite time in s")
    return t


def make_chunks(items: Sequence[Item], workers: int, size: int | None = None) -> list[list[Item]]:
    """Split items into chunks: `size` each, or about 8 chunks per worker, 1 to 50 items."""
    if size is None:
        size = min(50, max(1, math.ceil(len(items) / (8 * max(1, workers)))))
    if size < 1:
        raise InvalidInputError("chunk size", size, "an integer >= 1")
    return [list(items[i : i + size]) for i in range(0, len(items), size)]


class _ExecutorBase:
    def __enter__(self) -> Any:
        return self

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    def close(self) -> None:
        """Nothing to release by default."""


class LocalExecutor(_ExecutorBase):
    """Local worker processes (forkserver); one worker runs in this process, no pool.

    Args:
        workers: Number of processes (default: every core, os.cpu_count()).
        preload: Modules the workers import before their first job (those of the jobs' `fn`).
    """

    def __init__(self, workers: int | None = None,
                 preload: Sequence[str] = ("rcmplan.sweep.task",)) -> None:  # fmt: skip
        n = (os.cpu_count() or 1) if workers is None else workers
        if not isinstance(n, int) or isinstance(n, bool) or n < 1:
            raise InvalidInputError("workers", workers, "an integer >= 1")
        self.workers = n
        self.preload = list(preload)
        self._pool: cf.ProcessPoolExecutor | None = None
        self.lost: list[list[int]] = []  # each broken pool's dead workers' exit codes

    def _get_pool(self) -> cf.ProcessPoolExecutor:
        if self._pool is None:
            ctx = multiprocessing.get_context("forkserver")
            ctx.set_forkserver_preload(self.preload)
            self._pool = cf.ProcessPoolExecutor(max_workers=self.workers, mp_context=ctx)
        return self._pool

    def map_chunks(self, motion: MotionSettings, chunks: Sequence[Chunk]) -> Iterator[
        list[TargetResult]
    ]:  # fmt: skip
        """Each chunk's results as it finishes; pending chunks are cancelled if we stop early."""
        return self.map_jobs(run_chunk, motion, chunks)

    def map_jobs(self, fn: ChunkFn[C, Item, R], context: C, chunks: Sequence[Sequence[Item]]
                 ) -> Iterator[list[R]]:  # fmt: skip
        """fn(context, chunk) for each chunk as it finishes; pending chunks are cancelled if we
        stop early. One worker runs them in this process, in order. A worker process that dies
        (killed, crashed) breaks the pool: its chunks and those not finished run again on a new
        one (`lost` and `label` say so), found within about POLL_LOST_S even when the worker
        died while it sent a result; after MAX_POOL_BREAKS breaks, WorkerLostError."""
        if self.workers == 1:
            for chunk in chunks:
                yield fn(context, chunk)
            return
        todo = dict(enumerate(chunks))  # the chunks not finished yet, by index
        while todo:
            if not (yield from self._run_on_pool(fn, context, todo)):
                return
            self.lost.append(self._dead_codes())
            self.terminate()  # the pool's other workers, and the pool thread's wait
            if len(self.lost) > MAX_POOL_BREAKS:
                codes = [code for codes in self.lost for code in codes]
                raise WorkerLostError(codes, len(todo), len(self.lost))
            self.close()  # a new pool for the chunks left

    def _run_on_pool(
        self, fn: ChunkFn[C, Item, R], context: C, todo: dict[int, Sequence[Item]]
    ) -> Generator[list[R], None, bool]:
        """Run todo's chunks on the pool, yielding each one's results as it finishes (its
        entry leaves todo); returns True if the pool broke first (a worker died)."""
        with signals_deferred():  # the pool starts whole: every worker it launches is tracked
            pool = self._get_pool()
            futures = {pool.submit(fn, context, chunk): i for i, chunk in todo.items()}
        pending = set(futures)
        try:
            while pending:  # each second without a finished chunk, a look for a dead worker
                finished = cf.as_completed(pending, timeout=POLL_LOST_S)
                while True:
                    try:
                        fut = next(finished)
                    except (StopIteration, TimeoutError):
                        break
                    pending.discard(fut)
                    try:
                        results = fut.result()
                    except cf.BrokenExecutor:
                        return True
                    del todo[futures[fut]]
                    yield results
                # A worker that died while it sent a result leaves part of a message in the
                # result pipe, and the pool thread waits for the rest forever: no future would
                # ever finish. A dead worker means a broken pool, whatever it was doing.
                if pending and self._dead_codes():
                    return True
            return False
        finally:
            for fut in futures:
                fut.cancel()

    @property
    def label(self) -> str:
        """Where the chunks ran: the processes, and the workers lost meanwhile."""
        base = f"local ({self.workers} process{'es' if self.workers > 1 else ''}"
        if not self.lost:
            return base + ")"
        ends = "; ".join(endings(codes) for codes in self.lost)
        times = f"{len(self.lost)} time{'s' if len(self.lost) > 1 else ''}"
        return f"{base}; a worker died, the pool broke {times} ({ends}): its chunks re-ran)"

    def _workers(self) -> list[Any]:
        """The pool's worker processes (CPython's pool internals; none without a pool)."""
        return list(dict(getattr(self._pool, "_processes", None) or {}).values())

    def _dead_codes(self) -> list[int]:
        """Exit codes of the pool's workers that have ended."""
        return [p.exitcode for p in self._workers() if p.exitcode is not None]

    def close(self) -> None:
        """Shut the pool down, cancelling chunks not yet started."""
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        if kind is not None and issubclass(kind, KeyboardInterrupt):
            self.terminate()
        self.close()

    def terminate(self) -> None:
        """Stop the pool's workers now (SIGTERM, then reaped), dropping the chunks they run:
        an interrupted sweep waits for no chunk and leaves no worker behind, and a pool broken
        by a dead worker ends at once. Finished chunks are in the checkpoint already."""
        pool = self._pool
        if pool is None:
            return
        # CPython's pool internals: its workers, and its work items. When the workers die,
        # Python 3.11's pool thread sets an exception on every pending item, which fails with a
        # traceback on a cancelled future; the cancelled items get a fresh stand-in future
        # (nobody waits on it) instead. The items stay in the table: removing them here races
        # the pool thread, which reads them by id (a KeyError traceback from that thread).
        pending = getattr(pool, "_pending_work_items", {})
        for item in list(pending.values()):
            if item.future.cancelled():
                item.future = cf.Future()
        workers = self._workers()
        for proc in workers:
            proc.terminate()
        for proc in workers:
            proc.join(timeout=5.0)
            if proc.is_alive():
                proc.kill()
                proc.join()
        # A worker stopped while it sent a result leaves part of a message in the result pipe,
        # and the pool thread waits for the rest forever (and `close`, and Python's exit, for
        # that thread). The workers are gone, so this process holds the pipe's only write end:
        # closing it ends that wait (end of file: the pool is broken and the thread finishes).
        writer = getattr(getattr(pool, "_result_queue", None), "_writer", None)
        if workers and writer is not None:
            writer.close()


class DaskExecutor(_ExecutorBase):
    """A Dask distributed cluster reached through its scheduler address.

    Args:
        address: Scheduler address, e.g. "tcp://10.0.0.5:8786".
        timeout_s: Time in [s] to connect and to see at least one worker.

    Raises:
        SchedulerError: The scheduler does not answer or has no worker within the timeout.
        MissingExtraError: dask[distributed] is not installed (extra "dist").
    """

    def __init__(self, address: str, timeout_s: float = DEFAULT_TIMEOUT_S) -> None:
        distributed = require_extra("distributed", "dist")
        self.address = address
        self.timeout_s = check_timeout(timeout_s)
        self._distributed = distributed
        self.client = self._connect(distributed)
        self._seen = self._worker_addresses()
        self.workers = len(self._seen)
        self.lost: set[str] = set()  # workers that left while chunks ran (their chunks re-ran)

    @property
    def label(self) -> str:
        """Where the chunks ran: the address, the workers, and the workers lost meanwhile."""
        lost = len(self.lost)
        note = f", {lost} lost during the sweep (their chunks were re-run)" if lost else ""
        return f"dask {self.address} ({self.workers} workers{note})"

    def _worker_addresses(self) -> set[str]:
        return set(self.client.scheduler_info(n_workers=-1).get("workers", {}))

    def _connect(self, distributed: Any) -> Any:
        t = self.timeout_s
        try:
            client = distributed.Client(self.address, timeout=t, set_as_default=False)
        except (OSError, TimeoutError, ValueError, TypeError) as exc:
            raise SchedulerError(self.address, t, f"did not answer within {t:g} s ({exc})") from exc
        try:
            client.wait_for_workers(1, timeout=t)
        except (OSError, TimeoutError) as exc:
            client.close()
            raise SchedulerError(self.address, t, f"has no worker after {t:g} s") from exc
        return client

    def map_chunks(self, motion: MotionSettings, chunks: Sequence[Chunk]) -> Iterator[
        list[TargetResult]
    ]:  # fmt: skip
        """Each chunk's results as it finishes (`map_jobs`)."""
        return self.map_jobs(run_chunk, motion, chunks)

    def map_jobs(self, fn: ChunkFn[C, Item, R], context: C, chunks: Sequence[Sequence[Item]]
                 ) -> Iterator[list[R]]:  # fmt: skip
        """fn(context, chunk) for each chunk as it finishes. A worker that dies costs only its
        chunks, which the scheduler runs again elsewhere (`label` counts the lost workers); a
        chunk whose workers keep dying, or no worker left for `timeout_s`, raises
        SchedulerError."""
        futures = [self.client.submit(fn, context, c, pure=False) for c in chunks]
        done = self._distributed.as_completed(futures, loop=self.client.loop)
        waited = time.monotonic()
        try:
            while not done.is_empty():
                batch = done.next_batch(block=False)
                for fut in batch:
                    yield self._result(fut, done.count() + 1)
                    fut.release()
                if batch or time.monotonic() - waited < self.timeout_s:
                    waited = waited if not batch else time.monotonic()
                    time.sleep(0 if batch else POLL_S)
                    continue
                self._check_workers(done.count())
                waited = time.monotonic()
        finally:
            with contextlib.suppress(Exception):  # bookkeeping only: never mask the real error
                self._check_workers(None)
            self.client.cancel(futures)

    def _check_workers(self, pending: int | None) -> None:
        """Note the workers that left; with `pending` chunks and none left, raise."""
        now = self._worker_addresses()
        self.lost |= self._seen - now
        self._seen |= now
        if pending is not None and not now:
            t = self.timeout_s
            raise SchedulerError(
                self.address, t, f"has no worker left ({len(self.lost)} lost) after {t:g} s; "
                f"{pending} chunks not run (finished ones are in the checkpoint)",
            )  # fmt: skip

    def _result(self, fut: Any, pending: int) -> list[Any]:
        """The chunk's results; a result lost with its worker is waited for while workers
        remain (the scheduler recomputes it)."""
        while True:
            try:
                result: list[Any] = fut.result(timeout=self.timeout_s)
                return result
            except self._distributed.KilledWorker as exc:
                raise SchedulerError(
                    self.address, self.timeout_s, f"workers died running a chunk ({exc})"
                ) from exc
            except TimeoutError:
                self._check_workers(pending)

    def close(self) -> None:
        """Close the client (the cluster keeps running)."""
        self.client.close()


def make_executor(
    workers: int | None = None,
    scheduler: str | None = None,
    timeout_s: float = DEFAULT_TIMEOUT_S,
    preload: Sequence[str] = ("rcmplan.sweep.task",),
) -> LocalExecutor | DaskExecutor:
    """A Dask executor when a scheduler address is given, else local processes (importing
    `preload` before their first job)."""
    if scheduler:
        return DaskExecutor(scheduler, timeout_s)
    return LocalExecutor(workers, preload)
