"""The `rcmplan` command's start: its signal handler comes before any import it does not need,
and a signal that lands while the handler's own modules load waits for them, then stops the
command with its stop file."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from test_interrupts import SRC, our_tracebacks

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="needs POSIX signals")

# Imported by the command line package, none needed before its handler is installed.
AFTER_THE_HANDLER = {"typing", "argparse", "json", "pathlib", "re", "rcmplan.exceptions",
                     "rcmplan._atomic"}  # fmt: skip


def test_the_handler_is_installed_before_the_imports_it_does_not_need() -> None:
    # -S: no `site`, whose .pth files may import any of these first in some installations.
    code = (
        "import sys; sys.argv = ['rcmplan']; sys.orig_argv = [sys.executable, 'rcmplan']; "
        "import rcmplan.cli"
    )
    done = subprocess.run([sys.executable, "-S", "-X", "importtime", "-c", code],
                          env={**os.environ, "PYTHONPATH": SRC}, capture_output=True,
                          text=True, timeout=120)  # fmt: skip
    names = [line.rsplit("|", 1)[-1].strip() for line in done.stderr.splitlines()]
    assert done.returncode == 0 and "rcmplan.cli.interrupts" in names, done.stderr[-2000:]
    before = set(names[: names.index("rcmplan.cli.interrupts")])
    assert before & AFTER_THE_HANDLER == set()
    assert set(names) >= AFTER_THE_HANDLER  # each is imported, after the handler


# Starts `rcmplan inject --out OUT` and sends itself SIGTERM as `install` imports
# rcmplan._atomic, one of the modules the stop file's write needs.
DRIVER = """
import os, signal, sys
sys.argv = ["rcmplan", "inject", "--out", sys.argv[1]]
sys.orig_argv = [sys.executable, *sys.argv]  # as the installed script starts
class SignalOnImport:
    def find_spec(self, name, path=None, target=None):
        if name == "rcmplan._atomic":
            os.kill(os.getpid(), signal.SIGTERM)
        return None
sys.meta_path.insert(0, SignalOnImport())
import rcmplan.cli
print("not stopped")
"""


def run_driver(driver: str, out: Path, timeout: float) -> subprocess.CompletedProcess[str]:
    """Run a driver script (its output folder its one argument) in a new Python process."""
    return subprocess.run([sys.executable, "-c", driver, str(out)],
                          env={**os.environ, "PYTHONPATH": SRC}, capture_output=True,
                          text=True, timeout=timeout)  # fmt: skip


def test_a_signal_while_the_handler_s_modules_load_waits_for_them_and_stops_the_command(
    tmp_path: Path,
) -> None:
    done = run_driver(DRIVER, tmp_path, 120)
    assert done.returncode == 143 and not our_tracebacks(done.stderr), done.stderr[-2000:]
    assert done.stdout == ""
    doc = json.loads((tmp_path / "summary.json").read_text())
    assert doc == {"command": "inject", "status": "interrupted",
                   "message": "interrupted by SIGTERM before the run"}  # fmt: skip
    assert "rcmplan inject: interrupted by SIGTERM before the run" in done.stderr


# Runs `rcmplan inject --out OUT` as the command, sending itself SIGINT as `interrupts.handled`
# yields to its block: the handler runs at the next instruction, before the command's own code.
AT_THE_BLOCK = """
import os, signal, sys
sys.argv = ["rcmplan", "inject", "--no-plots", "--out", sys.argv[1]]
sys.orig_argv = [sys.executable, *sys.argv]  # as the installed script starts
from rcmplan.cli import interrupts, main
target, sent = interrupts.handled.__wrapped__.__code__, []
def tracer(frame, event, arg):
    if frame.f_code is target and event == "return" and not sent:
        sent.append(1)
        os.kill(os.getpid(), signal.SIGINT)
    return tracer if frame.f_code is target else None
sys.settrace(tracer)
sys.exit(main())
"""


def test_a_signal_as_the_run_block_begins_stops_the_command_with_its_stop_file(
    tmp_path: Path,
) -> None:
    done = run_driver(AT_THE_BLOCK, tmp_path, 300)
    assert done.returncode == 130 and not our_tracebacks(done.stderr), done.stderr[-2000:]
    doc = json.loads((tmp_path / "summary.json").read_text())
    assert doc["status"] == "interrupted"
    assert doc["message"] == "interrupted by SIGINT before the run"
    assert "rcmplan inject: interrupted by SIGINT" in done.stderr
