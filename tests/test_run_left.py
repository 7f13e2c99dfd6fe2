"""The interrupt harnesses' classification (`run_left.faults`) on folders made by hand: a summary
that says the run had begun recording needs its log with the records it states; one that says
the run stopped before it began may have none."""

from __future__ import annotations

import json
import signal
from pathlib import Path
from typing import Any

from run_left import faults, kind
from test_atomic import small_log

TERM = signal.SIGTERM


def folder(path: Path, doc: dict[str, Any] | None, records: int | None = None,
           command: str = "inject") -> Path:  # fmt: skip
    """path with summary.json holding doc (none if None) as `command` writes it, and a log of
    `records` records."""
    path.mkdir(parents=True)
    if doc is not None:
        (path / "summary.json").write_text(json.dumps({"command": command, **doc}))
    if records is not None:
        small_log(records, 0.0).save_npz(path / "log.npz")
    return path


def kinds(out: Path, command: str, code: int = 143, err: str = "", late: bool = False
          ) -> list[str]:  # fmt: skip
    return [kind(f) for f in faults(out, command, code, TERM, err, late)]


def interrupted(where: str, **extra: Any) -> dict[str, Any]:
    return {"status": "interrupted", "message": f"interrupted by SIGTERM {where}", **extra}


def test_a_run_interrupted_during_the_run_needs_its_log_with_the_stated_records(
    tmp_path: Path,
) -> None:
    doc = interrupted("during the run", iterations=3)
    assert kinds(folder(tmp_path / "whole", doc, 3), "inject") == []
    assert kinds(folder(tmp_path / "none", doc), "inject") == ["records"]
    assert kinds(folder(tmp_path / "short", doc, 2), "inject") == ["records"]
    unstated = interrupted("during the run")
    assert kinds(folder(tmp_path / "unstated", unstated, 3), "inject") == ["records"]
    session = interrupted("during the session", periods=4)
    assert kinds(folder(tmp_path / "session", session, 4, "teleop"), "teleop") == []


def test_a_run_stopped_before_it_began_may_leave_no_log_but_must_say_so(tmp_path: Path) -> None:
    before = interrupted("before the run")
    assert kinds(folder(tmp_path / "before", before), "inject") == []
    assert kinds(folder(tmp_path / "log beside", before, 2), "inject") == ["records"]


def test_the_exit_code_the_status_and_the_stderr_must_agree(tmp_path: Path) -> None:
    ok = folder(tmp_path / "ok", {"status": "ok", "message": "", "iterations": 2}, 2)
    assert kinds(ok, "inject", code=-TERM) == []
    assert kinds(ok, "inject", code=0, late=True) == []
    assert kinds(ok, "inject", code=0) == ["ignored"]
    assert kinds(ok, "inject", code=1) == ["ignored"]
    assert kinds(ok, "inject", code=1, late=True) == ["status"]  # exit 1 beside "ok"
    assert kinds(ok, "inject", code=2) == ["wrong exit"]
    assert kinds(ok, "spiral", code=-TERM) == ["command"]  # the summary of another command
    assert kinds(ok, "inject-mujoco", code=-TERM) == []  # a harness's name for a run of inject
    broke = {"status": "limit_violated", "message": "max RCM deviation ...", "iterations": 2}
    beyond = folder(tmp_path / "beyond", broke, 2)
    assert kinds(beyond, "inject", code=1, late=True) == []  # a finished run's own exit 1
    assert kinds(beyond, "inject", code=0, late=True) == ["status"]
    assert kinds(ok, "inject") == ["status"]  # exit 143 beside a finished run's summary
    wrong_signal = {"status": "interrupted", "message": "interrupted by SIGINT before the run"}
    assert kinds(folder(tmp_path / "sigint", wrong_signal), "inject") == ["status"]
    err = "Traceback (most recent call last):\n  ...\nKeyboardInterrupt\n"
    before = folder(tmp_path / "before", interrupted("before the run"))
    assert kinds(before, "inject", err=err) == ["traceback"]
    assert kinds(tmp_path / "missing", "inject") == ["no summary"]
    (before / ".summary.1-0.tmp.json").write_text("{}")
    assert kinds(before, "inject") == ["temporary"]


def test_compare_and_reproduce_rows_agree_with_their_message_and_logs(tmp_path: Path) -> None:
    row = {"method": "pinv", "status": "ok", "message": "", "iterations": 2}
    doc = interrupted("after 1 methods", methods=[row])
    out = folder(tmp_path / "compare", doc, command="compare")
    assert kinds(out, "compare") == ["records"]  # pinv/ has no log
    folder(out / "pinv", row, 2)
    assert kinds(out, "compare") == []
    miscounted = interrupted("after 2 methods", methods=[row])
    (out / "summary.json").write_text(json.dumps({"command": "compare", **miscounted}))
    assert kinds(out, "compare") == ["records"]
    rows = [{"experiment": "pivot"}]
    good = interrupted("during the run, after 1 of 3 experiments", experiments=rows)
    assert kinds(folder(tmp_path / "reproduce", good, command="reproduce"), "reproduce") == []
    bare = interrupted("during the run", experiments=rows)
    assert kinds(folder(tmp_path / "bare", bare, command="reproduce"), "reproduce") == ["records"]
