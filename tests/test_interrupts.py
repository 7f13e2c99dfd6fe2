"""SIGINT and SIGTERM sent to real `rcmplan` processes at seeded random points: each leaves a
complete summary.json saying why it stopped, exits 130 / 143 (or 0 when the signal came after
the end), leaves the records its summary states in a loadable log (none only when the summary
says the run stopped before it began: `run_left`), no temporary file, and no process of its own
behind."""

from __future__ import annotations

import csv
import json
import os
import random
import signal
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest

from heavy import cases, heavy
from procstat import alive, children_of, exiting
from rcmplan._jit import FirstCompile
from rcmplan.control.log import RunLog
from run_left import KINDS, faults, kind, our_tracebacks

pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")

SRC = str(Path(__file__).resolve().parents[1] / "src")
COMMANDS = {  # command line, and the span [s] after start-up in which the signal lands (None:
    # the duration of an uninterrupted run on this machine, measured first)
    "inject": (["inject"], None),
    "inject-mujoco": (["inject", "--plant", "mujoco", "--no-plots"], None),
    "spiral": (["spiral"], None),
    "compare": (["compare", "--method", "pinv", "--method", "dls"], None),
    "sweep": (["sweep", "--targets", "30000", "--workers", "2", "--no-plots"], 3.0),
    "teleop": (["teleop"], None),
    "subretinal": (["subretinal"], None),
    "render": (
        ["render", "--robot", "ur5", "--frames", "30", "--width", "160", "--height", "120"],
        None,
    ),
}
HEAVY_COMMANDS = ("teleop", "inject-mujoco", "subretinal")  # long: RCMPLAN_HEAVY_TESTS=1 only
SIGNALS = (signal.SIGINT, signal.SIGTERM)
# Interruptions per command: 3 (12 with RCMPLAN_HEAVY_TESTS=1, HEAVY_COMMANDS' only then);
# `benchmarks/bench_interruptions.py` runs 100 per command.
RUNS = int(os.environ.get("RCMPLAN_INTERRUPTIONS", str(cases(3, 12))))


class Stopped(NamedTuple):
    """How a signalled process ended: exit code, stderr, whether its exit had begun before the
    signal (`late`), the processes it had started by then, and the times [s] from its output
    folder to its end (`whole_s`) and from the signal to its end (`exit_s`)."""

    code: int
    err: str
    late: bool
    kids: set[int]
    whole_s: float
    exit_s: float


def interrupt(
    argv: list[str], out: Path, sig: int | None, delay: float, ready: str = ""
) -> Stopped:
    """Start `rcmplan argv --out out`, wait until it made its output folder (or the file
    `ready` in it), then `delay` s, send sig (none if None) and wait for the process's end."""
    env = {**os.environ, "PYTHONPATH": SRC, "MUJOCO_GL": "egl"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "rcmplan", *argv, "--out", str(out)],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
    )  # fmt: skip
    while not (out / ready).exists() and proc.poll() is None:
        time.sleep(0.01)
    start = time.perf_counter()
    time.sleep(delay)
    kids = children_of(proc.pid)
    late = exiting(proc.pid)
    sent = time.perf_counter()
    if sig is not None:
        proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    end = time.perf_counter()
    return Stopped(proc.returncode, err.decode(), late, kids, end - start, end - sent)


def check_log(out: Path) -> None:
    """A log, if any, loads whole: NPZ arrays of one length, CSV rows as wide as its header."""
    if (out / "log.npz").exists():
        log = RunLog.load_npz(out / "log.npz")
        assert all(getattr(log, k).shape[0] == len(log) for k in ("tip", "rcm", "phase"))
        assert np.all(np.isfinite(log.tip))
    if (out / "log.csv").exists():
        with open(out / "log.csv", newline="") as fh:
            rows = list(csv.reader(fh))
        assert rows and all(len(r) == len(rows[0]) for r in rows)


def check_left(out: Path, command: str, code: int, sig: int, err: str = "") -> None:
    """What the command left in out for its exit code (`run_left.faults`: exit 0 accepted, as
    after a signal that came once the process's exit had begun), its logs loadable whole."""
    assert faults(out, command, code, sig, err, late=True) == []
    check_log(out)


def orphans(kids: set[int]) -> list[int]:
    """The processes of kids still alive after their parent ended (the workers' last exits
    may trail the parent's by a moment: up to 10 s is waited for)."""
    for _ in range(500):
        if not any(alive(p) for p in kids):
            break
        time.sleep(0.02)
    return sorted(p for p in kids if alive(p))


@pytest.mark.parametrize(
    "command",
    [pytest.param(c, marks=heavy) if c in HEAVY_COMMANDS else c for c in sorted(COMMANDS)],
)
def test_signals_at_random_points_leave_a_summary_a_loadable_log_and_no_process(
    command: str, tmp_path: Path
) -> None:
    argv, span = COMMANDS[command]
    if span is None:  # one whole run; if it compiled kernels (a cold cache), the runs after
        # it load them and end sooner: the span is then a second whole run's, so that the
        # signals land inside the runs and not after their end
        whole = interrupt(argv, tmp_path / "whole", None, 0.0)
        assert whole.code in (0, 1), whole.err[-2000:]
        if FirstCompile.LINE in whole.err:
            whole = interrupt(argv, tmp_path / "whole-again", None, 0.0)
            assert whole.code in (0, 1), whole.err[-2000:]
        span = whole.whole_s
    rng = random.Random(18 + sorted(COMMANDS).index(command))
    broken: list[str] = []
    counts = dict.fromkeys(("interrupted", "after the end", "broken", "orphans", *KINDS), 0)
    exits: list[float] = []
    # RUNS runs; when none of them was interrupted (this shared machine ran the measured run
    # slower than the later ones), up to RUNS more, the span shortened each time a run ended
    # before its signal (that run took less than its delay)
    while len(exits) < RUNS or (counts["interrupted"] == 0 and len(exits) < 2 * RUNS):
        k = len(exits)
        sig, delay = SIGNALS[k % 2], rng.uniform(0.0, 0.9 * span)
        out = tmp_path / f"run{k}"
        run = interrupt(argv, out, sig, delay)
        if run.code != 128 + sig:
            span = min(span, delay)
        found = faults(out, command, run.code, sig, run.err, run.late)
        left = orphans(run.kids)
        found += [f"orphans {left}"] * bool(left)
        for f in found:
            counts["orphans" if f.startswith("orphans") else kind(f)] += 1
        counts["interrupted" if run.code == 128 + sig else "after the end"] += 1
        counts["broken"] += bool(found)
        exits.append(run.exit_s)
        broken += [f"run {k} ({signal.Signals(sig).name} at {delay:.3f} s): {f}" for f in found]
    print(f"\n{command}: {len(exits)} runs; " + ", ".join(f"{k} {v}" for k, v in counts.items())
          + f"; signal to exit median {statistics.median(exits):.3f} s, "
          f"max {max(exits):.3f} s")  # fmt: skip
    assert broken == [], "\n".join(broken[:20])
    assert counts["interrupted"] >= 1  # points land inside the run, so the test checks something


# Instants while `rcmplan inject` starts, each named by the module whose import the process
# reports (`python -X importtime`: modules loaded by an import statement, not by
# importlib.import_module) just before it, and a wait after that report [s].
EARLY = {
    "the command line package just loaded": ("rcmplan.cli", 0.0),
    "0.05 s after the command line package loaded": ("rcmplan.cli", 0.05),
    "numpy loading for the parser's subcommands": ("numpy", 0.0),
    "the parser importing its first subcommand": ("rcmplan.cli.common", 0.0),
    "the parser importing its subcommand's run code": ("rcmplan.job", 0.0),
    "numba loading for the run": ("numba", 0.0),
}


def interrupt_after_import(
    out: Path, sig: int, module: str, wait: float, command: str = "inject"
) -> tuple[int, str]:
    """Start `rcmplan <command> --out out`, send sig `wait` s after it reports that `module` is
    imported; returns the exit code and stderr."""
    env = {**os.environ, "PYTHONPATH": SRC, "MUJOCO_GL": "egl"}
    argv = ["-X", "importtime", "-m", "rcmplan", command, "--out", str(out)]
    proc = subprocess.Popen([sys.executable, *argv], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True)  # fmt: skip
    assert proc.stderr is not None
    seen = []
    for line in proc.stderr:
        seen.append(line)
        if line.rsplit("|", 1)[-1].strip() == module:
            break
    time.sleep(wait)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode != 0 or len(seen) > 1, "the module was never reported"
    return proc.returncode, "".join(seen) + err


@pytest.mark.parametrize("sig", SIGNALS, ids=lambda s: signal.Signals(s).name)
@pytest.mark.parametrize("instant", sorted(EARLY))
def test_a_signal_while_the_command_starts_leaves_an_interrupted_summary(
    instant: str, sig: int, tmp_path: Path
) -> None:
    stale = tmp_path / "log.npz"
    stale.write_bytes(b"an earlier run's log")
    code, err = interrupt_after_import(tmp_path, sig, *EARLY[instant])
    assert code == 128 + sig, err[-2000:]
    assert not our_tracebacks(err), err[-2000:]
    doc = json.loads((tmp_path / "summary.json").read_text())
    assert doc["status"] == "interrupted" and doc["command"] == "inject"
    assert doc["message"].startswith(f"interrupted by {signal.Signals(sig).name}")
    assert not stale.exists() or stale.read_bytes() != b"an earlier run's log"  # not beside it
    assert f"rcmplan inject: interrupted by {signal.Signals(sig).name}" in err


# An interrupt that lands in a weakref callback (as in the import machinery's module locks)
# is dropped by Python with an "Exception ignored" note; the command must still stop.
SWALLOWED = """
import os, signal, weakref
from rcmplan.cli import interrupts

interrupts.install(["robot"])
class Box: pass
def callback(_ref):
    os.kill(os.getpid(), signal.SIGINT)
    for _ in range(1000): pass  # the handler runs here, inside the callback
with interrupts.handled():
    try:
        box = Box()
        ref = weakref.ref(box, callback)
        del box
        for _ in range(10**7): pass
        print("ran to the end")
    except interrupts.Interrupted:
        with interrupts.shielded():
            print("interrupted")
"""


@pytest.mark.parametrize(
    "command", ["spiral", "compare", "sweep", "teleop", "subretinal", "reproduce", "render"]
)
def test_every_run_command_leaves_its_stop_file_when_interrupted_while_starting(
    command: str, tmp_path: Path
) -> None:
    code, err = interrupt_after_import(tmp_path, signal.SIGTERM, "numpy", 0.0, command)
    assert code == 143 and not our_tracebacks(err), err[-2000:]
    doc = json.loads((tmp_path / "summary.json").read_text())
    assert doc["command"] == command and doc["status"] == "interrupted"
    assert doc["message"].startswith("interrupted by SIGTERM")


def test_an_interrupt_python_drops_in_a_callback_is_raised_again() -> None:
    env = {**os.environ, "PYTHONPATH": SRC}
    done = subprocess.run([sys.executable, "-c", SWALLOWED], env=env, capture_output=True,
                          text=True, timeout=120)  # fmt: skip
    assert done.stdout.strip() == "interrupted", done.stderr
    assert done.returncode == 0 and "Exception ignored" not in done.stderr


def test_importing_rcmplan_as_a_library_leaves_the_signal_handlers_alone() -> None:
    # The handlers before and after the import, in one process: what the process started with
    # depends on its parent (a pytest-xdist worker ignores SIGINT, and its children inherit it).
    code = ("import signal; s = (signal.SIGINT, signal.SIGTERM); "
            "before = [signal.getsignal(n) for n in s]; import rcmplan, rcmplan.cli; "
            "print(*[b is signal.getsignal(n) for b, n in zip(before, s)])")  # fmt: skip
    env = {**os.environ, "PYTHONPATH": SRC}
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert done.stdout.split() == ["True", "True"], done.stderr


@pytest.mark.parametrize(
    ("orig_argv", "argv0", "expected"),
    [
        (["python", "-m", "rcmplan", "inject"], "-m", True),
        (["python", "-X", "importtime", "-W", "ignore", "-mrcmplan"], "-m", True),
        (["python", "-m", "pytest", "-q"], "-m", False),
        (["python", "-c", "import rcmplan"], "-c", False),
        (["python", "script.py", "-m", "rcmplan"], "script.py", False),
        (["python", "/venv/bin/rcmplan", "inject"], "/venv/bin/rcmplan", True),
        # a sweep's forkserver worker: the command's sys.argv, its own interpreter line
        (
            ["python", "-c", "from multiprocessing.forkserver import main; main(3, 4, [])"],
            "/venv/bin/rcmplan",
            False,
        ),
        ([], "/venv/bin/rcmplan", True),  # an interpreter without orig_argv
    ],
)
def test_the_process_is_the_command_only_when_started_as_it(
    orig_argv: list[str], argv0: str, expected: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    from rcmplan.cli.interrupts import is_command

    monkeypatch.setattr(sys, "orig_argv", orig_argv)
    monkeypatch.setattr(sys, "argv", [argv0])
    assert is_command() is expected


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["inject", "--no-plots"], ("inject", "rcmplan-out/inject")),
        (["inject", "--out", "a", "--out=b"], ("inject", "b")),
        (["spiral", "--ou", "c"], ("spiral", "c")),
        (["compare", "--method", "pinv"], ("compare", "rcmplan-out/compare")),
        (["robot", "--out", "d"], ("robot", "d")),
        (["robot"], ("robot", None)),
        (["--version"], ("", None)),
    ],
)
def test_the_output_folder_is_read_from_the_command_line_before_the_parser_exists(
    argv: list[str], expected: tuple[str, str | None]
) -> None:
    from rcmplan.cli.interrupts import command_and_out

    assert command_and_out(argv) == expected


def test_every_stop_file_command_writes_where_its_parser_says() -> None:
    from rcmplan.cli import build_parser
    from rcmplan.cli.interrupts import STOP_FILES, command_and_out

    parser = build_parser()
    for command in STOP_FILES:
        args = parser.parse_args([command])
        assert args.out == command_and_out([command])[1]


@heavy
def test_an_interrupted_sweep_resumes_to_the_results_of_an_uninterrupted_one(
    tmp_path: Path,
) -> None:
    argv = ["sweep", "--targets", "4000", "--workers", "2", "--no-plots"]
    cut = interrupt(argv, tmp_path / "cut", signal.SIGTERM, 1.0)
    assert cut.code == 143, cut.err[-2000:]
    kept = json.loads((tmp_path / "cut" / "summary.json").read_text())["results_kept"]
    env = {**os.environ, "PYTHONPATH": SRC}
    for out, extra in (("cut", ["--resume"]), ("whole", [])):
        subprocess.run([sys.executable, "-m", "rcmplan", *argv, *extra, "--out",
                        str(tmp_path / out)], env=env, check=True,
                       stdout=subprocess.DEVNULL)  # fmt: skip
    resumed = json.loads((tmp_path / "cut" / "summary.json").read_text())
    assert resumed["status"] == "ok" and resumed["targets"]["resumed_from_checkpoint"] == kept
    assert without_wall_time(tmp_path / "cut") == without_wall_time(tmp_path / "whole")


def without_wall_time(out: Path) -> list[list[str]]:
    """targets.csv without its wall-time column."""
    with open(out / "targets.csv", newline="") as fh:
        return [row[:-1] for row in csv.reader(fh)]


def test_ctrl_c_on_the_installed_script_is_answered_by_the_command_alone(tmp_path: Path) -> None:
    """Ctrl-C reaches the whole foreground process group: the sweep's forkserver workers, which
    run the `rcmplan` script again with the command's argv, leave it to the command (no stop
    line or stop file of theirs)."""
    script = installed_script()
    out = tmp_path / "sweep"
    proc = subprocess.Popen(
        [str(script), "sweep", "--targets", "30000", "--workers", "2", "--no-plots", "--out",
         str(out)], start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
    )  # fmt: skip
    deadline = time.monotonic() + 300
    while len(children_of(proc.pid)) < 3:  # the forkserver and its two workers
        assert proc.poll() is None and time.monotonic() < deadline, "no workers within 300 s"
        time.sleep(0.05)
    time.sleep(1.0)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    text = err.decode()
    assert proc.returncode == 130, text[-2000:]
    assert "before the run" not in text and not our_tracebacks(text), text[-2000:]
    doc = json.loads((out / "summary.json").read_text())
    assert doc["status"] == "interrupted" and "rerun with --resume" in doc["message"]


def installed_script() -> Path:
    """The `rcmplan` console script `pip install` wrote for this interpreter: beside it (a
    virtual environment, a system install), or in the user's scripts folder (`pip install`
    without write access to site-packages), else the one on PATH."""
    import shutil
    import sysconfig

    places = [Path(sys.executable).parent, Path(sysconfig.get_path("scripts")),
              Path(sysconfig.get_path("scripts", f"{os.name}_user"))]  # fmt: skip
    found = [p / "rcmplan" for p in places if (p / "rcmplan").is_file()]
    on_path = shutil.which("rcmplan")
    assert found or on_path, f"no `rcmplan` script in {places} or on PATH: pip install wrote none"
    return found[0] if found else Path(str(on_path))


def test_a_render_interrupted_while_drawing_keeps_its_runs_summary_and_says_where(
    tmp_path: Path,
) -> None:
    """An interrupt once the run is written (its summary.json appears) and while the frames
    are drawn: exit 130, no traceback, and summary.json keeps the run's figures with status
    `interrupted`, a message naming the drawing and the run's own status, and no image."""
    out = tmp_path / "render"
    argv = ["render", "--robot", "ur5", "--frames", "10000", "--width", "64", "--height", "48"]
    # 0.5 s after the run's summary: drawing 10,000 frames takes far longer
    run = interrupt(argv, out, signal.SIGINT, 0.5, ready="summary.json")
    assert run.code == 130 and not our_tracebacks(run.err), run.err[-2000:]
    doc = json.loads((out / "summary.json").read_text())
    assert (doc["command"], doc["status"], doc["robot"]) == ("render", "interrupted", "ur5")
    assert (
        doc["message"] == "interrupted by SIGINT while rendering (the run ended with status 'ok')"
    )
    assert doc["iterations"] == len(RunLog.load_npz(out / "log.npz"))
    assert not doc.get("figures")  # no image named: none was finished


def test_a_stop_file_over_this_runs_summary_keeps_what_the_summary_states(tmp_path: Path) -> None:
    """An interrupt that reaches no handling of the command's own after the run wrote its
    summary (and log) changes the summary's status and message only; a summary left by an
    earlier process is replaced whole, and that run's log removed."""
    from rcmplan._atomic import write_text
    from rcmplan.cli.interrupts import write_stop_file

    ours, earlier = tmp_path / "ours", tmp_path / "earlier"
    for out in (ours, earlier):
        out.mkdir()
    doc = {"command": "inject", "status": "ok", "message": "", "iterations": 7}
    write_text(ours / "summary.json", json.dumps(doc))  # written by this process
    (earlier / "summary.json").write_text(json.dumps(doc))  # by another: not this run's
    (earlier / "log.npz").write_bytes(b"an earlier run's log")
    stop = {"status": "interrupted", "message": "interrupted by SIGINT during the run"}
    for out in (ours, earlier):
        write_stop_file(out, "inject", stop)
    assert json.loads((ours / "summary.json").read_text()) == {**doc, **stop}
    assert json.loads((earlier / "summary.json").read_text()) == {"command": "inject", **stop}
    assert not (earlier / "log.npz").exists()
