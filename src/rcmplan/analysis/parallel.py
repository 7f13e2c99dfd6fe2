"""Draw independent figures at the same time in forked processes (POSIX), else one by one.

Matplotlib draws on one core; a run's figures are independent, so on a machine with two or
more cores they can be drawn side by side. A child process inherits the imported matplotlib
(fork, no new interpreter) and only writes its PNG file; the process itself only waits, so an
interrupt is answered at once rather than after a figure. Forking is used only when the process
runs a single thread (forking a threaded process can deadlock) and more than one core exists.
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path

from rcmplan._atomic import remove_unfinished
from rcmplan._signals import signals_deferred
from rcmplan.exceptions import RcmplanError

Job = tuple[Path, Callable[[], object]]  # the file a job writes, and the job


def can_fork() -> bool:
    """True on POSIX with more than one core and no other thread in this process."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return hasattr(os, "fork") and (cores or 1) > 1 and threading.active_count() == 1


def run_jobs(jobs: Sequence[Job]) -> list[Path]:
    """Run every job and return the paths they wrote: each in a forked child while this
    process waits, so that SIGINT and SIGTERM interrupt the wait at once (the children are
    stopped and reaped). Raises RcmplanError naming the files whose child failed.

    Where forking is unsafe the jobs run here one by one, each with SIGINT and SIGTERM deferred
    to its end: matplotlib's C code turns an exception raised inside it (the interrupt's) into
    a ValueError ("Invalid bounding box"), so an interrupt there would end the command with a
    traceback instead of its partial outputs."""
    if not can_fork():
        for _, job in jobs:
            with signals_deferred():
                job()
        return [path for path, _ in jobs]
    children: list[tuple[int, Path]] = []
    try:
        for path, job in jobs:
            children.append((_fork(job), path))
        failed = [str(path) for pid, path in children if os.waitpid(pid, 0)[1] != 0]
    except BaseException:  # interrupted (SIGINT, SIGTERM): stop and reap the children
        _stop(pid for pid, _ in children)
        raise
    if failed:
        raise RcmplanError(f"drawing {', '.join(failed)} failed (see the messages above)")
    return [path for path, _ in jobs]


def _stop(pids: Iterable[int]) -> None:
    """SIGTERM each child still running and reap it (no zombie, no orphan left drawing)."""
    for pid in pids:
        with contextlib.suppress(ChildProcessError, ProcessLookupError):
            os.kill(pid, signal.SIGTERM)
            os.waitpid(pid, 0)


def _fork(job: Callable[[], object]) -> int:
    with signals_deferred():  # a signal inside fork's hooks would be lost
        pid = os.fork()
        if pid == 0:  # child: draw, then leave without running the parent's exit handlers
            _child(job)
    return pid


def _child(job: Callable[[], object]) -> None:
    """Run job and exit; SIGINT and SIGTERM stop it cleanly (its half-written file removed)."""
    code = 1
    try:
        for s in (signal.SIGINT, signal.SIGTERM):
            signal.signal(s, signal.default_int_handler)
        job()
        code = 0
    finally:
        remove_unfinished()  # a temporary file an interrupt cut off from its block's cleanup
        os._exit(code)
