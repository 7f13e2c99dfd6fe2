"""Figures drawn side by side: every file written, a failing child named."""

from __future__ import annotations

from pathlib import Path

import pytest

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
