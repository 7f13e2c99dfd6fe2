"""Lost logs over many random interruptions of each long command (floor: 0 over 100), what an
interrupt at any instant of `rcmplan inject`, from the process's start, leaves, and how long
the process runs before it handles SIGINT and SIGTERM at all.

Run alone: python benchmarks/bench_interruptions.py [--runs N] [--from-start M] [--handler K]
Runs tests/test_interrupts.py's harness with RCMPLAN_INTERRUPTIONS=N (default 100; 10 with
--quick through benchmarks/run.py): per command (inject, inject on the MuJoCo plant, spiral,
compare, sweep, teleop, one subretinal episode, render on the UR5), N real processes each get
SIGINT or SIGTERM at a seeded random point of the run (within the shorter of two uninterrupted
runs); each must leave a summary saying why it stopped, the records it states in a loadable log
(none only when it says the run stopped before it began), no temporary file and no process
behind (`tests/run_left.py`).
One row per command: the interruptions that broke any of these, out of N; the harness's count
of each kind of fault goes to stderr.

Then M processes of `rcmplan inject --no-plots` (default 100; 20 with --quick) each get SIGINT
or SIGTERM at a seeded instant drawn uniformly from 0 to 1.2 times an uninterrupted run's
duration (the median of 3), counted from the process's start (interpreter start-up and imports
included). A run alive at the signal is answered when `tests/run_left.py` (the harness's
classification) finds no fault: exit 128 + the signal number with summary.json saying
"interrupted" and the signal's name, or, when the signal came after its outputs were final,
ended by the signal with summary.json "ok"; either way the records its summary states in a
loadable log, no traceback, no temporary file; anything else is counted and printed. A run
whose exit had begun when the signal was sent is not alive: Linux drops that signal (the
process ends with the code it chose, 0 after a run that ended "ok"), though `waitpid` still
reports the process running for the few milliseconds its memory takes to be freed
(`tests/procstat.py`, `exiting`). Rows: the share answered, the time from the signal to the
process's end (median and largest), the share that ended "interrupted".

Then K starts (default 30; 10 with --quick) of `python -m rcmplan inject --no-plots` (python:
this interpreter, or --python, e.g. a venv's with nothing installed: its `site` runs no .pth
file, and the handler comes before any import beyond the standard library), each
timed from just before its fork to the moment it handles SIGTERM (its handler seen in
/proc/PID/status, SigCgt; polled every 0.2 ms), beside K starts of a Python that installs a
SIGTERM handler as its first statement (the interpreter's own start-up, `site` included, which
no package can shorten); byte code compiled once beforehand (PYTHONPYCACHEPREFIX in a temporary
folder), as an installed package has it. Until then a SIGINT ends the process with Python's
KeyboardInterrupt traceback and a SIGTERM ends it silently, neither with a summary.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from _common import quick, row

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from procstat import catches, exiting  # noqa: E402  (tests/ holds the /proc readers)
from run_left import faults  # noqa: E402  (and the classification the harness shares)

COMMANDS = (
    "compare",
    "inject",
    "inject-mujoco",
    "render",
    "spiral",
    "subretinal",
    "sweep",
    "teleop",
)


def run_command(command: str, runs: int) -> tuple[int | str, float]:
    """(interruptions that broke the promise, as the harness counted them, or "?" when it
    printed no count; wall time [s])."""
    env = {
        **os.environ,
        "RCMPLAN_INTERRUPTIONS": str(runs),
        "MUJOCO_GL": "egl",
        "RCMPLAN_HEAVY_TESTS": "1",
    }  # teleop's, inject-mujoco's and subretinal's cases are heavy tests
    start = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-s", "-p", "no:cacheprovider",
         str(ROOT / "tests" / "test_interrupts.py") + "::test_signals_at_random_points_leave_a"
         f"_summary_a_loadable_log_and_no_process[{command}]"],
        env=env, cwd=ROOT, capture_output=True, text=True,
    )  # fmt: skip
    wall = time.perf_counter() - start
    # The harness prints one line per command: its runs and every kind of fault counted.
    tally = re.search(rf"^{re.escape(command)}: \d+ runs; .*$", proc.stdout, flags=re.M)
    if tally is not None:
        print(tally.group(0), file=sys.stderr)
    if proc.returncode != 0:
        failed = re.findall(r"^E\s+(.*)$", proc.stdout, flags=re.M)
        print(f"{command}: {failed[:3] or proc.stdout[-2000:]}", file=sys.stderr)
    broken = re.search(r"broken (\d+)", tally.group(0)) if tally is not None else None
    return (int(broken.group(1)) if broken else "?"), wall


def rows(
    runs: int | None = None, from_start: int | None = None, handler: int | None = None
) -> list[dict[str, Any]]:
    """One row per command, the rows of interrupts from the process's start, then the time
    to the handler."""
    n = runs or (10 if quick() else 100)
    out = []
    for command in COMMANDS:
        lost, wall = run_command(command, n)
        out.append(row(f"{command}: interruptions that broke the promise, of {n} "
                       f"({wall:.0f} s)", lost, "", target="0"))  # fmt: skip
    out += start_rows(from_start or (20 if quick() else 100))
    return out + handler_rows(handler or (10 if quick() else 30))


def inject(out: Path, sig: int | None, delay: float) -> tuple[bool, int, float, str, str]:
    """Start `rcmplan inject --no-plots --out out`, send sig `delay` s after the start (none if
    None): (alive at the signal: not ended, its exit not begun; exit code, time [s] from the
    signal (or start) to the end, summary status, stderr)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "MUJOCO_GL": "egl"}
    start = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-m", "rcmplan", "inject", "--no-plots", "--out", str(out)],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    time.sleep(max(0.0, delay - (time.perf_counter() - start)))
    alive = proc.poll() is None and not exiting(proc.pid)
    sent = time.perf_counter()
    if sig is not None and alive:
        proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    took = time.perf_counter() - (sent if sig is not None else start)
    try:
        status = str(json.loads((out / "summary.json").read_text())["status"])
    except (OSError, ValueError, KeyError):
        status = "none"
    return alive, proc.returncode, took, status, err


def start_rows(n: int, seed: int = 7) -> list[dict[str, Any]]:
    """Rows of n interrupts at random instants from the start of `rcmplan inject`."""
    rng = random.Random(seed)
    with tempfile.TemporaryDirectory() as tmp:
        whole = statistics.median(inject(Path(tmp) / f"whole{k}", None, 0.0)[2] for k in range(3))
        exits, alive_runs, good, stopped = [], 0, 0, 0
        for k in range(n):
            sig = (signal.SIGINT, signal.SIGTERM)[k % 2]
            delay = rng.uniform(0.0, 1.2 * whole)
            out = Path(tmp) / f"run{k}"
            alive, code, took, status, err = inject(out, sig, delay)
            if not alive:
                continue
            alive_runs += 1
            exits.append(took)
            stopped += status == "interrupted"
            found = faults(out, "inject", code, sig, err)
            good += not found
            if found:
                print(f"at {delay:.3f} s {signal.Signals(sig).name}: exit {code}, {found}, "
                      f"stderr {err[-300:]!r}", file=sys.stderr)  # fmt: skip
    if not alive_runs:
        return [row(f"inject from its start: no run alive at its signal, of {n}", 0, "")]
    what = f"of {alive_runs} alive at the signal, instants 0-{1.2 * whole:.2f} s from the start"
    return [
        row(f"inject from its start: interrupts answered, {what}", good / alive_runs, "",
            target="1"),
        row("inject from its start: time from the signal to the end, median",
            statistics.median(exits), "s"),
        row("inject from its start: time from the signal to the end, largest", max(exits), "s",
            target="< 1"),
        row(f"inject from its start: runs that ended 'interrupted', {what}",
            stopped / alive_runs, ""),
    ]  # fmt: skip


FIRST_STATEMENT = (
    "import signal, sys, time; signal.signal(signal.SIGTERM, lambda *_: sys.exit(0)); "
    "time.sleep(60)"
)


def until_handled(argv: list[str], env: dict[str, str]) -> float:
    """Time [s] from just before starting argv to its SIGTERM handler; then SIGTERM ends it."""
    start = time.perf_counter()
    proc = subprocess.Popen(argv, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    while not catches(proc.pid, signal.SIGTERM):
        if proc.poll() is not None:
            raise RuntimeError(f"{argv} ended (exit {proc.returncode}) without a handler")
        time.sleep(0.0002)
    took = time.perf_counter() - start
    proc.send_signal(signal.SIGTERM)
    proc.communicate(timeout=120)
    return took


def handler_rows(n: int, python: str = sys.executable) -> list[dict[str, Any]]:
    """Rows of the time to the SIGTERM handler: `rcmplan inject`'s and a bare Python's, both
    started by the interpreter `python` (rcmplan from this checkout's src)."""
    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "PYTHONPYCACHEPREFIX": tmp}
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        command = [python, "-m", "rcmplan", "inject", "--no-plots", "--out", tmp]
        bare = [python, "-c", FIRST_STATEMENT]
        until_handled(command, env)  # compiles the byte code
        ours, python = [], []
        for _ in range(n):  # alternated: a change of load weighs on both alike
            ours.append(until_handled(command, env))
            python.append(until_handled(bare, env))
    return [
        row(f"rcmplan inject: start to its SIGTERM handler, {stat.__name__} of {n}", stat(ours),
            "s", "python, handler its first statement", stat(python))
        for stat in (statistics.median, max)
    ]  # fmt: skip


def main() -> None:
    """Print the rows."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=100, help="interruptions per command")
    ap.add_argument("--from-start", type=int, default=100,
                    help="interrupts of inject at instants from the process's start")  # fmt: skip
    ap.add_argument("--handler", type=int, default=30,
                    help="starts timed to the SIGTERM handler")  # fmt: skip
    ap.add_argument("--only-start", action="store_true", help="skip the per-command harness")
    ap.add_argument("--only-handler", action="store_true", help="only the time to the handler")
    ap.add_argument("--python", default=sys.executable,
                    help="interpreter timed to the handler (a bare venv: no .pth)")  # fmt: skip
    args = ap.parse_args()
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from run import print_table

    if args.only_handler:
        print_table(handler_rows(args.handler, args.python))
    elif args.only_start:
        print_table(start_rows(args.from_start) + handler_rows(args.handler, args.python))
    else:
        print_table(rows(args.runs, args.from_start, args.handler))


if __name__ == "__main__":
    main()
