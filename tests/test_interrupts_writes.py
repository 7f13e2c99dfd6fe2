"""SIGINT landing at the worst instant of an atomic write in a real `rcmplan compare` process:
in `contextlib`'s exit of the `atomic_path` block, after the file was written whole and before
the block renames or removes it. The command still leaves summary.json "interrupted", exit 130,
the old file or the new one, and no temporary file."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from test_interrupts import SRC, check_left, check_log, our_tracebacks

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="needs POSIX signals")

# Runs `rcmplan ARGV...` as the command (program name "rcmplan"), sending itself SIGINT on
# entering the exit of the n-th `atomic_path` block that wrote a file named NAME.
DRIVER = """
import contextlib, os, signal, sys
name, n = sys.argv[1], int(sys.argv[2])
sys.argv = ["rcmplan", *sys.argv[3:]]
sys.orig_argv = [sys.executable, *sys.argv]  # as the installed script starts
exit_code = contextlib._GeneratorContextManager.__exit__.__code__
seen = []
def tracer(frame, event, arg):
    if frame.f_code is exit_code and frame.f_locals["typ"] is None:
        gen = frame.f_locals["self"].gen
        if gen.gi_code.co_name == "atomic_path" and gen.gi_frame.f_locals["path"].name == name:
            seen.append(1)
            if len(seen) == n:
                os.kill(os.getpid(), signal.SIGINT)
sys.settrace(tracer)
from rcmplan.cli import main
sys.exit(main())
"""


@pytest.mark.parametrize(
    ("name", "n", "kept", "rows"),
    [  # the file, which of its writes, the files of pinv/ left, the methods summary.json lists
        ("log.npz", 1, [], 0),
        ("log.csv", 1, ["log.npz"], 0),
        ("summary.json", 1, ["log.csv", "log.npz"], 0),  # the method's summary
        ("summary.json", 2, ["log.csv", "log.npz", "summary.json"], 1),  # compare's own
    ],
)
def test_sigint_before_an_atomic_write_renames_its_file_leaves_no_temporary_file(
    name: str, n: int, kept: list[str], rows: int, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    argv = ["compare", "--method", "pinv", "--no-plots", "--out", str(out)]
    proc = subprocess.run(
        [sys.executable, "-c", DRIVER, name, str(n), *argv],
        env={**os.environ, "PYTHONPATH": SRC}, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert not our_tracebacks(proc.stderr), proc.stderr
    assert proc.returncode == 128 + signal.SIGINT, proc.stderr
    check_left(out, "compare", proc.returncode, signal.SIGINT)  # no *.tmp* file anywhere
    check_log(out / "pinv")
    assert sorted(p.name for p in (out / "pinv").iterdir()) == kept
    doc = json.loads((out / "summary.json").read_text())
    assert len(doc["methods"]) == rows
