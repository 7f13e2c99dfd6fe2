"""Executors: local processes and a Dask LocalCluster give identical results; bad addresses
raise a clear error."""

from __future__ import annotations

import math
import socket

import pytest

from rcmplan.exceptions import RcmplanError
from rcmplan.sweep.errors import SchedulerError
from rcmplan.sweep.executors import DaskExecutor, LocalExecutor, make_chunks, make_executor
from rcmplan.sweep.runner import run_sweep
from rcmplan.sweep.settings import MotionSettings, Region, SweepSettings

SETTINGS = SweepSettings(
    Region(max_angle=math.radians(20), n_targets=20),
    MotionSettings(step_position=1e-3, step_angle=1e-2),
)


def identities(result) -> dict:
    return {i: r.identity() for i, r in result.results.items()}


@pytest.fixture(scope="module")
def local_result():
    with LocalExecutor(1) as ex:
        return run_sweep(SETTINGS, ex, chunk_size=3)


def test_two_local_processes_match_one(local_result) -> None:
    with LocalExecutor(2) as ex:
        two = run_sweep(SETTINGS, ex)
    assert identities(two) == identities(local_result)
    assert set(local_result.results) == set(local_result.sample.reachable_ids.tolist())


def test_a_dask_local_cluster_matches_the_local_run(local_result) -> None:
    import distributed  # the `dist` extra; a missing package must fail, not skip

    with (
        distributed.LocalCluster(
            n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None
        ) as cluster,
        DaskExecutor(cluster.scheduler_address, timeout_s=30) as ex,
    ):
        assert ex.workers == 2
        dask_result = run_sweep(SETTINGS, ex, chunk_size=2)
    assert identities(dask_result) == identities(local_result)


def unused_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_a_scheduler_that_does_not_answer_raises_after_the_timeout() -> None:
    address = f"tcp://127.0.0.1:{unused_port()}"
    with pytest.raises(SchedulerError, match="did not answer within 1 s") as info:
        make_executor(scheduler=address, timeout_s=1.0)
    assert info.value.address == address
    assert isinstance(info.value, RcmplanError)


def test_chunks_cover_every_item_once() -> None:
    items = [(i, [0.0, 0.0, 0.0]) for i in range(23)]
    chunks = make_chunks(items, workers=2)
    assert [i for c in chunks for i, _ in c] == list(range(23))
    assert len(make_chunks(items, workers=2, size=5)) == 5


def test_workers_must_be_positive() -> None:
    with pytest.raises(RcmplanError):
        LocalExecutor(0)


# A worker stopped while it sends a result: the length of a message and only part of it in the
# pool's result pipe, as `terminate` can leave them (SIGTERM lands in the worker's write).
CUT_MESSAGE = """
import os, struct, sys, time
from rcmplan.sweep.executors import LocalExecutor

ex = LocalExecutor(2, preload=())
pool = ex._get_pool()
pool.submit(time.sleep, 0.01).result()  # the workers and the pool thread run
os.write(pool._result_queue._writer.fileno(), struct.pack("!i", 1000) + bytes(10))
time.sleep(0.2)  # the pool thread has read the 10 bytes and waits for the other 990
ex.terminate()
ex.close()
print("closed")
"""


def test_terminating_workers_that_left_half_a_result_in_the_pipe_does_not_hang() -> None:
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-c", CUT_MESSAGE], capture_output=True, text=True,
                          timeout=60)  # fmt: skip
    assert done.returncode == 0 and done.stdout.strip() == "closed", done.stderr[-2000:]


# A job that, in one chunk, writes part of a result into the pool's result pipe and dies (as a
# worker killed while it sends a result would leave it), and in the others sleeps.
HALF_RESULT_JOB = """
import gc, os, struct, time
from multiprocessing.queues import SimpleQueue


def job(context, chunk):
    if chunk == "die":
        time.sleep(0.5)  # the other worker has its chunk
        pipe = next(o for o in gc.get_objects() if isinstance(o, SimpleQueue))  # the results
        os.write(pipe._writer.fileno(), struct.pack("!i", 1000) + bytes(10))
        os._exit(1)
    time.sleep(chunk)
    return [chunk]
"""

LOST_WORKER = """
import os, signal, sys, threading, time
from rcmplan.sweep.errors import WorkerLostError
from rcmplan.sweep.executors import LocalExecutor

case = sys.argv[1]
with LocalExecutor(2, preload=()) as ex:
    from halfresult import job

    if case == "killed":
        fn, context, chunks = job, None, [2.0, 2.0, 2.0]

        def kill_one() -> None:
            while not getattr(ex._pool, "_processes", None):  # the workers started
                time.sleep(0.01)
            time.sleep(0.5)
            os.kill(next(iter(ex._pool._processes)), signal.SIGKILL)

        threading.Thread(target=kill_one, daemon=True).start()
    else:
        fn, context, chunks = job, None, ["die", 2.0, 2.0]
    t = time.monotonic()
    try:
        print("results", sorted(r for rs in ex.map_jobs(fn, context, chunks) for r in rs))
    except WorkerLostError as exc:
        print("lost", exc.breaks, exc.pending, exc)
    print(f"{time.monotonic() - t:.1f} s;", ex.label)
"""


def run_lost_worker(case: str, tmp_path) -> str:  # type: ignore[no-untyped-def]
    """LOST_WORKER's output for the case, in a new process (a hang fails at 60 s)."""
    import os
    import subprocess
    import sys

    (tmp_path / "halfresult.py").write_text(HALF_RESULT_JOB)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), *sys.path])}
    done = subprocess.run([sys.executable, "-c", LOST_WORKER, case], capture_output=True,
                          text=True, timeout=60, env=env)  # fmt: skip
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


def test_a_killed_local_worker_costs_only_a_new_pool_and_the_label_says_so(tmp_path) -> None:  # type: ignore[no-untyped-def]
    out = run_lost_worker("killed", tmp_path)
    assert "results [2.0, 2.0, 2.0]" in out, out  # every chunk, once
    assert "a worker died, the pool broke 1 time (signal SIGKILL" in out, out


def test_a_worker_that_keeps_dying_mid_result_ends_the_run_with_a_clear_error_not_a_hang(
    tmp_path,
) -> None:  # type: ignore[no-untyped-def]
    from rcmplan.sweep.executors import MAX_POOL_BREAKS

    out = run_lost_worker("half a result", tmp_path)
    assert f"lost {MAX_POOL_BREAKS + 1} " in out and "exit code 1" in out, out
    assert "chunks not run" in out, out
    seconds = float(out.split(" s;")[0].split()[-1])
    assert seconds < 20  # each break found within about a second, not a wait for ever


def kill_one_worker(cluster) -> None:
    """SIGKILL one worker process (its nanny starts a new one, at a new address)."""
    import os
    import signal

    nanny = next(iter(cluster.workers.values()))
    os.kill(nanny.process.process.pid, signal.SIGKILL)


def test_a_killed_dask_worker_costs_only_its_chunks_and_the_label_says_so(local_result) -> None:
    import distributed

    with (
        distributed.LocalCluster(
            n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None
        ) as cluster,
        DaskExecutor(cluster.scheduler_address, timeout_s=30) as ex,
    ):
        chunks: list[int] = []

        def on_chunk(results) -> None:
            chunks.append(len(results))
            if len(chunks) == 1:
                kill_one_worker(cluster)

        result = run_sweep(SETTINGS, ex, on_chunk=on_chunk, chunk_size=1)
    assert identities(result) == identities(local_result)
    assert len(ex.lost) >= 1 and "lost during the sweep" in result.executor


def test_losing_every_dask_worker_ends_the_sweep_with_a_clear_error() -> None:
    import distributed

    with (
        distributed.LocalCluster(
            n_workers=1, processes=True, threads_per_worker=1, dashboard_address=None
        ) as cluster,
        DaskExecutor(cluster.scheduler_address, timeout_s=2) as ex,
    ):

        def on_chunk(results) -> None:
            cluster.scale(0)

        with pytest.raises(SchedulerError, match="has no worker left"):
            run_sweep(SETTINGS, ex, on_chunk=on_chunk, chunk_size=1)


@pytest.mark.parametrize("timeout", [-1.0, 0.0, math.nan, math.inf])
def test_timeout_must_be_positive_and_finite(timeout: float) -> None:
    with pytest.raises(RcmplanError, match="timeout"):
        DaskExecutor("tcp://127.0.0.1:1", timeout_s=timeout)
