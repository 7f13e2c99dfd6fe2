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
