"""Figures drawn side by side: every file written, a failing child named, an interrupt answered
at once with every child stopped."""

from __future__ import annotations

import os
import signal
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from procstat import children_of
from rcmplan.analysis import parallel
from rcmplan.exceptions import RcmplanError


def writer(path: Path, text: str):
    return (path, lambda: path.write_text(text))


def test_every_job_writes_its_file_and_the_paths_come_back_in_order(tmp_path: Path) -> None:
    jobs = [writer(tmp_path / f"{i}.txt", str(i)) for i in range(3)]
    assert parallel.run_jobs(jobs) == [p for p, _ in jobs]
    assert [(tmp_path / f"{i}.txt").read_text() for i in range(3)] == ["0", "1", "2"]


def test_jobs_run_one_by_one_when_forking_is_unsafe(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setattr(parallel, "can_fork", lambda: False)
    order: list[int] = []
    jobs = [(tmp_path / f"{i}", lambda i=i: order.append(i)) for i in range(3)]
    parallel.run_jobs(jobs)
    assert order == [0, 1, 2]


def test_a_failing_child_is_named(tmp_path: Path, capfd) -> None:
    if not parallel.can_fork():
        pytest.skip("this machine cannot fork safely here (one core or threads running)")

    def fail() -> None:
        raise ValueError("boom")

    jobs = [writer(tmp_path / "a.txt", "a"), (tmp_path / "b.png", fail)]
    with pytest.raises(RcmplanError, match=r"b\.png"):
        parallel.run_jobs(jobs)


def test_an_interrupt_stops_the_drawing_at_once_and_reaps_every_child(tmp_path: Path) -> None:
    if not parallel.can_fork():
        pytest.skip("this machine cannot fork safely here (one core or threads running)")

    def slow(path: Path) -> Callable[[], None]:
        def job() -> None:
            time.sleep(3.0)
            path.write_text("drawn")

        return job

    def raise_interrupt(_signum: int, _frame: object) -> None:
        raise KeyboardInterrupt

    jobs = [(tmp_path / f"{i}.txt", slow(tmp_path / f"{i}.txt")) for i in range(2)]
    before = children_of(os.getpid())  # e.g. multiprocessing's helpers started by other tests
    old_term = signal.signal(signal.SIGTERM, raise_interrupt)
    # SIGALRM sends the SIGTERM: no timer thread (a thread makes forking unsafe).
    old_alarm = signal.signal(signal.SIGALRM, lambda *_: os.kill(os.getpid(), signal.SIGTERM))
    try:
        signal.setitimer(signal.ITIMER_REAL, 0.5)
        with pytest.raises(KeyboardInterrupt):
            parallel.run_jobs(jobs)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old_alarm)
        signal.signal(signal.SIGTERM, old_term)
    assert children_of(os.getpid()) <= before  # each child forked here stopped and reaped
    time.sleep(3.5)  # long enough for a job that was left running to write its file
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # no job ran to its end
