"""Signals held back while a process starts workers: a SIGINT or SIGTERM that lands inside
`fork` or a pool's start-up would be lost in at-fork hooks ("Exception ignored") or leave a
worker untracked; deferred, it takes effect right after.
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading
from collections.abc import Iterator

# The command's interrupt handling imports this module before its handler exists: `typing` is
# not imported (typing.TYPE_CHECKING, spelled out; `rcmplan.cli.interrupts`).
TYPE_CHECKING = False
if TYPE_CHECKING:
    from collections.abc import Callable
    from typing import NoReturn


@contextlib.contextmanager
def signals_deferred() -> Iterator[None]:
    """SIGINT and SIGTERM that arrive inside the block take effect when it ends (their handlers
    then run as usual). In the main thread only; elsewhere the block runs as is."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    sigs = (signal.SIGINT, signal.SIGTERM)
    old = {s: signal.signal(s, lambda signum, _frame: caught.append(signum)) for s in sigs}
    try:
        yield
    finally:
        for s, handler in old.items():
            signal.signal(s, handler)
        for signum in caught[:1]:
            handler = old[signal.Signals(signum)]
            if callable(handler):
                handler(signum, None)
            elif handler == signal.SIG_DFL:
                os.kill(os.getpid(), signum)


def raise_interrupt(
    exc: BaseException, result: Callable[[KeyboardInterrupt], object] | None = None
) -> NoReturn:
    """Raise `exc` again; if it is an interrupt or carries one (`wrapped_interrupt`: numba
    wraps one landing in its dispatcher in a SystemError), raise the interrupt itself, with
    `result(interrupt)` (what the interrupted code has done so far) as its `result`."""
    interrupt = wrapped_interrupt(exc)
    if interrupt is None:
        raise exc
    if result is not None:
        interrupt.result = result(interrupt)  # type: ignore[attr-defined]
    if interrupt is exc:
        raise exc
    raise interrupt from exc


def wrapped_interrupt(exc: BaseException) -> KeyboardInterrupt | None:
    """The interrupt an exception carries as its cause or context, if any: Python wraps an
    exception raised in some hooks (a signal landing in `__set_name__` while a module such as
    matplotlib is imported becomes a RuntimeError; one landing while a pybind11 extension such
    as mujoco initialises becomes an ImportError)."""
    seen: set[int] = set()
    cur: BaseException | None = exc
    while cur is not None and id(cur) not in seen:
        if isinstance(cur, KeyboardInterrupt):
            return cur
        seen.add(id(cur))
        cur = cur.__cause__ or cur.__context__
    return None
