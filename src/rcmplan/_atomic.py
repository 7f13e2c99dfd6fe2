"""Atomic file writes: a file is written under a temporary name in its own folder, then renamed
over the target (`os.replace`), so a reader sees the old file or the whole new one, never half.

An interrupt (SIGINT, SIGTERM raised by a Python signal handler) may land at any bytecode,
including inside `contextlib`'s `__exit__` before it resumes `atomic_path` to rename or remove
the temporary file: the file then outlives the block until the generator is collected, which a
process ending with `os._exit` never does. So every temporary file is also recorded until its
write has ended, and `remove_unfinished` removes those an interrupt left (the command line calls
it before the process ends). Each write gets its own temporary name, so two writes of the same
file (an interrupted one, then the partial outputs' one) never share, or remove, each other's.
"""

from __future__ import annotations

import contextlib
import itertools
import os
import threading
from collections.abc import Iterator
from pathlib import Path

# Temporary files of writes not yet ended -> (process id, thread id) of their writer.
_unfinished: dict[Path, tuple[int, int]] = {}
# Files this process has written whole (absolute paths, with the process id that wrote them:
# a forked worker inherits the set, not the writes).
_written: set[tuple[int, str]] = set()
_serial = itertools.count()


def _owner() -> tuple[int, int]:
    return os.getpid(), threading.get_ident()


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path beside `path` (same suffix, so writers that read the suffix still work)
    that replaces `path` when the block ends normally; removed if the block raises or is
    interrupted (or, if the interrupt cut this cleanup, by `remove_unfinished`)."""
    path = Path(path)
    tmp = path.with_name(f".{path.stem}.{os.getpid()}-{next(_serial)}.tmp{path.suffix}")
    _unfinished[tmp] = _owner()  # before the file exists: no instant leaves it unrecorded
    try:
        yield tmp
        done = (os.getpid(), os.path.abspath(path))
        _written.add(done)  # before the rename: no instant leaves a renamed file unrecorded
        try:
            os.replace(tmp, path)
        except BaseException:
            _written.discard(done)
            raise
    finally:
        _discard(tmp)


def _discard(tmp: Path) -> bool:
    """Remove tmp if it is still there (not renamed), then forget it; True if it was there."""
    try:
        tmp.unlink()
        removed = True
    except OSError:  # renamed already (or its folder gone): nothing left to remove
        removed = False
    _unfinished.pop(tmp, None)
    return removed


def written_here(path: str | Path) -> bool:
    """True when this process wrote `path` whole (an `atomic_path` write that ended)."""
    return (os.getpid(), os.path.abspath(path)) in _written


def remove_unfinished() -> list[Path]:
    """Remove the temporary files of this thread's writes that an interrupt cut before their
    block could rename or remove them; returns the paths of the files it removed. Call it
    once the interrupted writes are abandoned (the interrupt handled), with signals ignored."""
    me = _owner()
    stale = [tmp for tmp, owner in list(_unfinished.items()) if owner == me]
    return [tmp for tmp in stale if _discard(tmp)]


def write_text(path: str | Path, text: str) -> Path:
    """Write text to path atomically; returns the path."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return Path(path)
