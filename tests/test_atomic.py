"""Atomic writes under interrupts: whatever bytecode SIGINT lands on, the folder holds the old
file or the whole new one and no temporary file once the command line's interrupt handling
(`interrupts.leave`) has run."""

from __future__ import annotations

import os
import signal
import sys
import traceback
from collections.abc import Callable
from pathlib import Path
from types import FrameType
from typing import Any, NamedTuple

import numpy as np
import pytest

from rcmplan import _atomic
from rcmplan._atomic import atomic_path, write_text
from rcmplan.cli import interrupts
from rcmplan.control.log import RunLog

TRACED = ("contextlib.py", "_atomic.py", "log.py")  # the frames a write goes through


def temporaries(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.rglob("*") if ".tmp" in p.name)


def small_log(n: int, value: float) -> RunLog:
    """A log of n records whose floats all equal value."""
    f = lambda *shape: np.full((n, *shape), value)  # noqa: E731
    i = np.zeros(n, dtype=np.int64)
    return RunLog(time=f(), sliders=f(6), joints=f(6), lam=f(), tip=f(3), rcm=f(3), trocar=f(3),
                  base=f(3), target_tip=f(3), error=f(6), step=i, iteration=i, solver=i, phase=i,
                  phase_names=("p",), solver_names=("pinv",))  # fmt: skip


class Outcome(NamedTuple):
    """What a write left: the opcodes traced, where the signal landed, the file's text and
    the temporary files in its folder."""

    opcodes: int
    landed: list[str]
    text: str
    temporaries: list[str]


def interrupted_at(k: int, path: Path, write: Callable[[], object]) -> Outcome:
    """Run write (of path) with SIGINT sent to this process at its k-th traced opcode (counted
    in the frames of `TRACED`; none if it has fewer), handled as the `rcmplan` command handles
    it: Interrupted raised, then `interrupts.leave`. The folder is read while the exception is
    still alive: the command ends with os._exit, so nothing the exception holds is collected."""
    count, landed = [0], []

    def local(frame: FrameType, event: str, arg: Any) -> Any:
        if event == "opcode":
            count[0] += 1
            if count[0] == k:
                landed.append(f"{Path(frame.f_code.co_filename).name}:{frame.f_lineno}")
                os.kill(os.getpid(), signal.SIGINT)
        return local

    def scope(frame: FrameType, event: str, arg: Any) -> Any:
        if not frame.f_code.co_filename.endswith(TRACED):
            return None
        frame.f_trace_opcodes = True
        return local

    previous = sys.gettrace()
    with interrupts.handled():
        try:
            sys.settrace(scope)
            try:
                write()
            finally:
                sys.settrace(previous)
        except interrupts.Interrupted as exc:
            with interrupts.shielded():
                assert interrupts.leave(130) == 130
                left = Outcome(count[0], landed, path.read_text(), temporaries(path.parent))
                # The abandoned write closes now, not while a later call is traced.
                traceback.clear_frames(exc.__traceback__)
            return left
    return Outcome(count[0], landed, path.read_text(), temporaries(path.parent))


@pytest.mark.parametrize("writer", ["text", "csv"])
def test_sigint_at_any_bytecode_of_a_write_leaves_the_old_or_the_new_file_and_no_temporary(
    writer: str, tmp_path: Path
) -> None:
    path = tmp_path / ("summary.json" if writer == "text" else "log.csv")
    if writer == "text":
        write: Callable[[], object] = lambda: write_text(path, "new")  # noqa: E731
        put_old: Callable[[], object] = lambda: path.write_text("old")  # noqa: E731
    else:
        old, new = small_log(1, 1.0), small_log(2, 2.0)
        write, put_old = lambda: new.save_csv(path), lambda: old.save_csv(path)
    put_old()
    before = path.read_text()
    whole = interrupted_at(0, path, write)
    outcomes: dict[str, list[str]] = {"old": [], "new": []}
    for k in range(1, whole.opcodes + 1):
        put_old()
        left = interrupted_at(k, path, write)
        assert left.text in (before, whole.text), f"half-written after SIGINT at {left.landed}"
        assert left.temporaries == [], f"left after SIGINT at {left.landed}"
        outcomes["new" if left.text == whole.text else "old"] += left.landed
    # Signals landed before and after the rename, and in contextlib's exit of the block.
    assert outcomes["old"] and outcomes["new"]
    assert any(w.startswith("contextlib.py") for w in outcomes["old"])


def test_a_sigint_that_cuts_the_cleanup_of_an_interrupted_write_leaves_no_temporary(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The first interrupt lands while the log is half written; a second one lands in the
    # block's removal of the temporary file.
    path = tmp_path / "log.csv"
    small_log(2, 1.0).save_csv(path)
    before = path.read_text()
    real_unlink = Path.unlink

    def write_half(self: RunLog, tmp: Path) -> None:
        tmp.write_text("time_s,phase\n0.0,")
        raise interrupts.Interrupted()

    def unlink_cut(self: Path, missing_ok: bool = False) -> None:
        monkeypatch.setattr(Path, "unlink", real_unlink)
        raise interrupts.Interrupted()

    monkeypatch.setattr(RunLog, "_write_csv", write_half)
    monkeypatch.setattr(Path, "unlink", unlink_cut)
    with pytest.raises(interrupts.Interrupted):
        small_log(3, 2.0).save_csv(path)
    assert temporaries(tmp_path)  # the cut cleanup left it: what the handling must remove
    with interrupts.shielded():
        interrupts.leave(130)
    assert path.read_text() == before
    assert temporaries(tmp_path) == []


def test_an_abandoned_write_removed_late_spares_a_later_write_of_the_same_file(
    tmp_path: Path,
) -> None:
    # An interrupted write whose block is only closed (collected) while the partial outputs
    # write the same file: each has its own temporary file.
    path = tmp_path / "summary.json"
    abandoned = atomic_path(path)
    tmp = abandoned.__enter__()
    tmp.write_text("cut")
    with atomic_path(path) as later:
        later.write_text("partial outputs")
        abandoned.__exit__(interrupts.Interrupted, interrupts.Interrupted(), None)
    assert path.read_text() == "partial outputs"
    assert temporaries(tmp_path) == []


def test_remove_unfinished_leaves_the_writes_of_other_threads_and_processes(
    tmp_path: Path,
) -> None:
    mine, theirs = tmp_path / ".a.tmp.json", tmp_path / ".b.tmp.json"
    for p in (mine, theirs):
        p.write_text("x")
    _atomic._unfinished[mine] = _atomic._owner()
    _atomic._unfinished[theirs] = (os.getpid() + 1, _atomic._owner()[1])
    try:
        assert _atomic.remove_unfinished() == [mine]
        assert not mine.exists() and theirs.exists()
    finally:
        _atomic._unfinished.pop(theirs, None)
