"""SIGINT and SIGTERM in the run commands: both stop the command with a Python exception (so
every `finally` runs and pool workers are shut down), the command writes its partial outputs
with status "interrupted", and the process exits 128 + the signal number (130, 143), as shells
report a command killed by that signal.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from types import FrameType

CAUGHT = (signal.SIGINT, signal.SIGTERM)


class Interrupted(KeyboardInterrupt):
    """SIGINT as a subclass of KeyboardInterrupt: code that handles Ctrl-C handles it. (Not
    KeyboardInterrupt itself: CPython kills itself with SIGINT at exit, whatever the exit code,
    once a bare KeyboardInterrupt has left code run through its C API, as some compiled
    dependencies do, even when rcmplan caught it later.)"""

    signal_name = "SIGINT"
    signum = signal.SIGINT


class Terminated(Interrupted):
    """SIGTERM, raised like Ctrl-C's KeyboardInterrupt so the same code handles both."""

    signal_name = "SIGTERM"
    signum = signal.SIGTERM


def _raise(signum: int, frame: FrameType | None) -> None:
    raise Terminated() if signum == signal.SIGTERM else Interrupted()


def signal_name(exc: BaseException) -> str:
    """ "SIGTERM" or "SIGINT" for an interrupt."""
    return getattr(exc, "signal_name", "SIGINT")


def exit_code(exc: BaseException) -> int:
    """128 + the signal number: 143 for SIGTERM, 130 for SIGINT."""
    return 128 + int(getattr(exc, "signum", signal.SIGINT))


@contextlib.contextmanager
def handled() -> Iterator[None]:
    """SIGTERM raises Terminated and SIGINT Interrupted (both KeyboardInterrupt) inside the
    block (main thread only; the previous handlers come back after it)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = {s: signal.getsignal(s) for s in CAUGHT}
    for s in CAUGHT:
        signal.signal(s, _raise)
    try:
        yield
    finally:
        for s, handler in old.items():
            signal.signal(s, handler)


@contextlib.contextmanager
def shielded() -> Iterator[None]:
    """SIGINT and SIGTERM ignored inside the block: a second signal cannot cut the writing of
    an interrupted run's partial outputs (which are short and written atomically anyway)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = {s: signal.signal(s, signal.SIG_IGN) for s in CAUGHT}
    try:
        yield
    finally:
        for s, handler in old.items():
            signal.signal(s, handler)


def wrapped_interrupt(exc: BaseException) -> KeyboardInterrupt | None:
    """The interrupt an exception carries as its cause or context, if any: Python wraps an
    exception raised in some hooks (a signal landing in `__set_name__` while a module such as
    matplotlib is imported becomes a RuntimeError)."""
    seen: set[int] = set()
    cur: BaseException | None = exc
    while cur is not None and id(cur) not in seen:
        if isinstance(cur, KeyboardInterrupt):
            return cur
        seen.add(id(cur))
        cur = cur.__cause__ or cur.__context__
    return None


@contextlib.contextmanager
def surfaced() -> Iterator[None]:
    """Inside the block, an exception that wraps an interrupt is raised as the interrupt, so
    the command's own interrupt handling writes the partial outputs."""
    try:
        yield
    except Exception as exc:
        interrupt = wrapped_interrupt(exc)
        if interrupt is None:
            raise
        raise interrupt from exc
