"""SIGINT and SIGTERM sent to a real `rcmplan reproduce` process while it runs the thesis's
experiments and while it draws them: it leaves summary.json with status "interrupted", the
signal, the rows of the experiments that finished and the figures it drew, exit 130 / 143, and
no traceback or temporary file."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from test_interrupts import SRC, check_left, our_tracebacks

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="needs POSIX signals")

# Runs `rcmplan ARGV...` as the command (program name "rcmplan"), sending itself the signal
# SIGNAL at the EVENT ("call" or "return") of the CALL-th call (from 1) of the function NAME of
# module MODULE.
DRIVER = """
import os, signal, sys
module, name, event_, call, signum = *sys.argv[1:4], int(sys.argv[4]), int(sys.argv[5])
sys.argv = ["rcmplan", *sys.argv[6:]]
sys.orig_argv = [sys.executable, *sys.argv]  # as the installed script starts
from rcmplan.cli import main
calls = []
def tracer(frame, event, arg):
    if frame.f_code.co_name != name or frame.f_globals.get("__name__") != module:
        return None
    if event == "call":
        calls.append(1)
    if event == event_ and len(calls) == call and os.getpid() == parent:
        os.kill(os.getpid(), signum)
    return tracer
parent = os.getpid()
sys.settrace(tracer)
sys.exit(main())
"""

INSTANTS = {  # where the signal lands: the function, the event, its call, and the options
    "running the second experiment's thesis setting": (
        "rcmplan.analysis.thesis", "move_p3_p7", "call", 1, ["--no-plots"]),
    "running the second experiment's hypothesis": (
        "rcmplan.cli.thesis_hypothesis", "move_p3_p7", "call", 1, ["--no-plots"]),
    # the second figure's child has started (the parent's return from forking it)
    "drawing the second experiment": (
        "rcmplan.analysis.parallel", "_fork", "return", 2, []),
}  # fmt: skip
# The experiments whose rows the summary must hold, and the figures drawn, at each instant.
EXPECTED = {
    "running the second experiment's thesis setting": (["pivot"], []),
    "running the second experiment's hypothesis": (["pivot"], []),
    "drawing the second experiment": (["pivot", "p3-p7"], ["pivot"]),
}


def interrupt_at(out: Path, sig: int, instant: str) -> subprocess.CompletedProcess[str]:
    """`rcmplan reproduce --out out` signalled at `instant` (INSTANTS)."""
    module, name, event, call, options = INSTANTS[instant]
    argv = [module, name, event, str(call), str(int(sig)), "reproduce", *options, "--out",
            str(out)]  # fmt: skip
    return subprocess.run(
        [sys.executable, "-c", DRIVER, *argv], env={**os.environ, "PYTHONPATH": SRC},
        capture_output=True, text=True, timeout=900,
    )  # fmt: skip


@pytest.mark.parametrize(
    ("instant", "sig"),
    [
        ("running the second experiment's thesis setting", signal.SIGTERM),
        ("running the second experiment's hypothesis", signal.SIGINT),
        ("drawing the second experiment", signal.SIGTERM),
    ],
    ids=lambda v: signal.Signals(v).name if isinstance(v, signal.Signals) else v,
)
def test_an_interrupted_reproduce_keeps_the_experiments_that_finished(
    instant: str, sig: int, tmp_path: Path
) -> None:
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    if INSTANTS[instant][1] == "_fork" and (cores or 1) < 2:  # the command's own process (not
        # this one) draws its figures in forked children only on two cores or more
        pytest.skip("figures are drawn in the command's process (one core): no child to signal")
    out = tmp_path / "out"
    proc = interrupt_at(out, sig, instant)
    assert proc.returncode == 128 + sig and not our_tracebacks(proc.stderr), proc.stderr[-2000:]
    check_left(out, "reproduce", proc.returncode, sig)
    doc = json.loads((out / "summary.json").read_text())
    rows, drawn = EXPECTED[instant]
    assert [r["experiment"] for r in doc["experiments"]] == rows
    assert sorted(doc["figures"]) == drawn
    assert all(Path(doc["figures"][k]).is_file() for k in drawn)
    assert f"during the run, after {len(rows)} of 3 experiments" in doc["message"]
    for row in doc["experiments"]:
        assert {row[s]["status"] for s in ("thesis", "rcmplan", "hypothesis")} == {"ok"}
