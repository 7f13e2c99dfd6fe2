"""SIGTERM at the last instant before a real `rcmplan` process declares its outputs final
(the call of `interrupts.finished`, after every output is written): the command still leaves
summary.json "interrupted" with the signal, the records it wrote in a loadable log, exit 143,
and no temporary file; nothing it wrote is removed as an earlier run's."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from heavy import heavy
from test_interrupts import SRC, check_left, our_tracebacks

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="needs POSIX signals")

# Runs `rcmplan ARGV...` as the command (program name "rcmplan"), sending itself SIGTERM as it
# enters the first call of `interrupts.finished` (every caller looks it up in its module, as
# `interrupts.finished` or, inside the module, `finished`: the wrapper is what they call).
DRIVER = """
import os, signal, sys
sys.argv = ["rcmplan", *sys.argv[1:]]
sys.orig_argv = [sys.executable, *sys.argv]  # as the installed script starts
from rcmplan.cli import interrupts, main
declare, sent = interrupts.finished, []
def finished(*args, **kwargs):
    if not sent:
        sent.append(1)
        os.kill(os.getpid(), signal.SIGTERM)
    return declare(*args, **kwargs)
interrupts.finished = finished
sys.exit(main())
"""

COMMANDS = {  # command line, the files that must be left, a summary key that must be non-empty
    "inject": (["inject", "--no-plots"], ["log.npz"], "phases"),
    "compare": (["compare", "--method", "pinv", "--no-plots"], ["pinv/log.npz"], "methods"),
    "sweep": (
        ["sweep", "--targets", "2", "--max-angle", "5", "--workers", "1", "--no-plots"],
        ["targets.csv"],
        "checkpoint",
    ),
    "reproduce": (["reproduce"], ["figures/pivot.png"], "experiments"),
    "subretinal": (["subretinal", "--no-plots"], ["log.npz", "episode.npz"], "periods"),
    "teleop": (["teleop", "--no-plots"], ["log.npz", "teleop.npz"], "periods"),
}
CSV_SKIPPED = ("inject", "teleop")  # log.csv not written on an interrupt; the summary says so
HEAVY_COMMANDS = ("teleop",)  # a long session: with RCMPLAN_HEAVY_TESTS=1 only


@pytest.mark.parametrize(
    "command",
    [pytest.param(c, marks=heavy) if c in HEAVY_COMMANDS else c for c in sorted(COMMANDS)],
)
def test_sigterm_as_the_outputs_become_final_keeps_them_and_says_interrupted(
    command: str, tmp_path: Path
) -> None:
    argv, kept, key = COMMANDS[command]
    out = tmp_path / "out"
    proc = subprocess.run(
        [sys.executable, "-c", DRIVER, *argv, "--out", str(out)],
        env={**os.environ, "PYTHONPATH": SRC}, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert proc.returncode == 143 and not our_tracebacks(proc.stderr), proc.stderr[-2000:]
    check_left(out, command, proc.returncode, signal.SIGTERM)
    assert [f for f in kept if not (out / f).is_file()] == []
    doc = json.loads((out / "summary.json").read_text())
    assert "before the run" not in doc["message"], doc["message"]
    if key is not None:
        assert doc.get(key), f"summary.json has no {key!r}: {sorted(doc)}"
    if command in CSV_SKIPPED:
        assert not (out / "log.csv").exists() and "interrupted" in doc["log_csv"]
