"""SIGINT and SIGTERM in the `rcmplan` command: one handler, from the first lines of the command
line package (`rcmplan.cli`, imported by `python -m rcmplan` and the `rcmplan` script before any
numerical library or subcommand) to the process's end, whose action follows how far the command
has got:

- starting (importing, reading the command line): nothing is open or half-written, so the
  handler writes the command's stop file (`summary.json`) in its output folder
  with status "interrupted" and ends the process at once (a signal that comes while `install`
  imports what that write needs waits for the imports: a module half imported cannot write);
- running (inside `handled()`): it raises Interrupted or Terminated (a KeyboardInterrupt), so
  every `finally` runs, pool workers are stopped and the command writes its partial outputs
  (inside `shielded()`, which marks the interrupt as answered);
- finished (`finished()`, or after `handled()`): the outputs are final, and the signal ends the
  process by its default action; what the command wrote stays as written.

Python drops an exception raised where it cannot propagate (a weakref callback of the import
machinery, a `__del__`) with an "Exception ignored" note; an interrupt dropped so is sent again
(`sys.unraisablehook`, a timer a millisecond later). An interrupt some code swallowed (numpy
clears an exception raised in a class's `__getattr__` while it looks up a special method) is
sent again the same way as it is freed unanswered (a weak reference to it); should any still be
lost, it ends the process once the command returns, so no signal is ignored.

An interrupted command exits 128 + the signal number (130, 143), as shells report a command
killed by that signal. Called in-process (`rcmplan.cli.main` from Python), `handled()` installs
the handler for its block only and puts the previous handlers back after it.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import weakref

from rcmplan._signals import wrapped_interrupt

# This module is the command's first import, before its handler exists: it imports what the
# handler needs at once and the rest (json, pathlib, rcmplan._atomic) in `install`, after the
# handler is in place; `typing` is not imported at all (typing.TYPE_CHECKING, spelled out).
TYPE_CHECKING = False
if TYPE_CHECKING:
    from collections.abc import Iterator, Sequence
    from pathlib import Path
    from types import FrameType
    from typing import Any, NoReturn

CAUGHT = (signal.SIGINT, signal.SIGTERM)
# The file each run command writes when it stops early, and the files of an earlier run that a
# stop before any result removes (so no stale log sits beside the new status).
STOP_FILES: dict[str, tuple[str, tuple[str, ...]]] = {
    "inject": ("summary.json", ("log.npz", "log.csv", "report.html")),
    "spiral": ("summary.json", ("log.npz", "log.csv", "report.html")),
    "teleop": ("summary.json", ("log.npz", "log.csv", "teleop.npz")),
    "subretinal": (
        "summary.json",
        ("log.npz", "episode.npz", "bscans.npz", "episodes.csv", "episodes.json"),
    ),
    "sweep": ("summary.json", ()),
    "compare": ("summary.json", ()),
    "reproduce": ("summary.json", ()),
    "render": ("summary.json", ("log.npz", "log.csv")),
}


class Interrupted(KeyboardInterrupt):
    """SIGINT as a subclass of KeyboardInterrupt: code that handles Ctrl-C handles it. (Not
    KeyboardInterrupt itself: CPython kills itself with SIGINT at exit, whatever the exit code,
    once a bare KeyboardInterrupt has left code run through its C API, as some compiled
    dependencies do, even when rcmplan caught it later.)"""

    signal_name = "SIGINT"
    signum = signal.SIGINT


class Terminated(Interrupted):
    """SIGTERM, raised like Ctrl-C's KeyboardInterrupt so the same code handles both."""

    signal_name = "SIGTERM"
    signum = signal.SIGTERM


class _State:
    """The process's command (None until `install`), its stage and the last interrupt."""

    command: str | None = None
    out: str | None = None
    stage = "running"  # "starting", "running" or "finished"
    ready = False  # True once the modules that write the stop file are imported
    pending = 0  # a signal that came while they were imported
    answered = True  # False from an interrupt raised until the code handling it answers
    signum = 0  # the last interrupt's signal
    watch: Any = None  # a weak reference to the last interrupt raised (`_watched`)


_state = _State()


def is_command() -> bool:
    """True when this process runs the `rcmplan` command: `python [options] -m rcmplan ...` or
    the installed `rcmplan` script, read from the interpreter's own command line
    (`sys.orig_argv`). A multiprocessing worker of the command is not the command: it is
    started with `-c`, and runs the script again (as `__mp_main__`) with the command's
    `sys.argv`, which is why `sys.argv` is read only when `sys.orig_argv` is empty."""
    argv = list(getattr(sys, "orig_argv", []))
    i = 1
    while i < len(argv):
        arg = argv[i]
        if arg.startswith("-m"):
            return (arg[2:] or (argv[i + 1] if i + 1 < len(argv) else "")) == "rcmplan"
        if arg in ("-c", "-"):
            return False  # a command string or standard input
        if not arg.startswith("-"):
            return os.path.basename(arg) == "rcmplan"  # the script
        i += 2 if arg in ("-X", "-W") else 1  # the two options whose value may stand apart
    return not argv and bool(sys.argv) and os.path.basename(sys.argv[0]) == "rcmplan"


def install_if_command() -> None:
    """`install` for this process's command line when it is the `rcmplan` command; imported
    as a library, rcmplan leaves the process's signal handlers alone."""
    if is_command():
        install(sys.argv[1:])


def install(argv: Sequence[str]) -> None:
    """Handle SIGINT and SIGTERM for the `rcmplan` process started with argv (without the
    program name), from now to the process's end. The command and its --out folder are read
    from argv directly: the parser is not built yet."""
    if threading.current_thread() is not threading.main_thread():
        return
    _state.command, _state.out = command_and_out(argv)
    _state.stage = "starting"
    for s in CAUGHT:
        signal.signal(s, _on_signal)
    previous = sys.unraisablehook

    def raise_again(unraisable: Any) -> None:
        if not isinstance(unraisable.exc_value, Interrupted):
            previous(unraisable)
        else:
            _send_again()

    sys.unraisablehook = raise_again
    _load_writers()


def _load_writers() -> None:
    """Import what the stop file's write needs, then act on a signal that came meanwhile (the
    handler waits for these imports: it would find a module half imported)."""
    import json  # noqa: F401
    import pathlib  # noqa: F401

    import rcmplan._atomic  # noqa: F401

    _state.ready = True
    if _state.pending and _state.stage == "starting":
        _stop_now(_state.pending)


def _send_again() -> None:
    """Raise the unanswered interrupt again a millisecond from now, from the main thread's next
    Python instruction (not from here: an exception raised in a hook or a weak reference's
    callback would be dropped the same way)."""
    if threading.current_thread() is threading.main_thread() and not _state.answered:
        signal.signal(signal.SIGALRM, _on_alarm)
        signal.setitimer(signal.ITIMER_REAL, 0.001)


def _watched(interrupt: Interrupted) -> Interrupted:
    """The interrupt, watched in the command's process: freed while unanswered, it was
    swallowed, and it is raised again (`_send_again`)."""
    if _state.command is not None:
        _state.watch = weakref.ref(interrupt, lambda _ref: _send_again())
    return interrupt


def _on_alarm(signum: int, frame: FrameType | None) -> None:
    """The dropped interrupt, raised again (or, once the command finished, its signal)."""
    if not _state.answered:
        _on_signal(_state.signum, frame)


def command_and_out(argv: Sequence[str]) -> tuple[str, str | None]:
    """The command named in argv ("" if none) and its output folder: the last `--out DIR` or
    `--out=DIR` (or an abbreviation argparse accepts, `--ou`), else rcmplan-out/<command>."""
    command = next((a for a in argv if not a.startswith("-")), "")
    out = f"rcmplan-out/{command}" if command in STOP_FILES else None
    for i, arg in enumerate(argv):
        name, eq, value = arg.partition("=")
        if len(name) >= 4 and "--out".startswith(name):
            out = value if eq else (argv[i + 1] if i + 1 < len(argv) else out)
    return command, out


def _on_signal(signum: int, frame: FrameType | None) -> None:
    if _state.stage == "starting":
        if not _state.ready:
            _state.pending = _state.pending or signum  # `_load_writers` acts on it
            return
        _stop_now(signum)
    if _state.stage == "finished" and _state.command is not None:
        signal.signal(signum, signal.SIG_DFL)  # the default action: the process ends
        os.kill(os.getpid(), signum)
        return
    _state.answered, _state.signum = False, signum
    # No local name holds it: a frame of its own traceback would keep it alive once swallowed.
    raise _watched(Terminated() if signum == signal.SIGTERM else Interrupted())


def _stop_now(signum: int) -> NoReturn:
    """Write the stop file, say why on stderr and end the process (start-up: nothing to undo)."""
    from pathlib import Path

    for s in CAUGHT:
        signal.signal(s, signal.SIG_IGN)
    name = signal.Signals(signum).name
    message = f"interrupted by {name} before the run"
    command = _state.command or ""
    if _state.out is not None and command in STOP_FILES:
        with contextlib.suppress(OSError):
            write_stop_file(Path(_state.out), command, {"status": "interrupted",
                                                        "message": message})  # fmt: skip
    os.write(2, f"rcmplan {command}: {message}\n".encode())
    os._exit(128 + signum)


def write_stop_file(out: Path, command: str, doc: dict[str, Any]) -> Path:
    """The stop file of `command` in out (created if needed) holding doc with the command's
    name, written atomically; the files of an earlier run's log are removed first (those this
    process wrote, this run's records, stay). A stop file this process wrote already (the
    run's summary, written before the interrupt reached the command's own handling) keeps what
    it states, its status and message replaced by doc's."""
    import json

    from rcmplan._atomic import write_text, written_here

    name, stale = STOP_FILES[command]
    out.mkdir(parents=True, exist_ok=True)
    for old in stale:
        if not written_here(out / old):
            (out / old).unlink(missing_ok=True)
    kept: Any = {}
    if written_here(out / name):
        with contextlib.suppress(OSError, ValueError):
            kept = json.loads((out / name).read_text())
    body = {"command": command, **(kept if isinstance(kept, dict) else {}), **doc}
    if command == "compare":
        body.setdefault("methods", [])
    return write_text(out / name, json.dumps(body, indent=2))


def wrote_outputs(out: Path, command: str) -> bool:
    """True when this process wrote the stop file or a log file of `command` in out."""
    from rcmplan._atomic import written_here

    name, logs = STOP_FILES[command]
    return any(written_here(out / f) for f in (name, *logs))


def signal_name(exc: BaseException) -> str:
    """ "SIGTERM" or "SIGINT" for an interrupt."""
    return getattr(exc, "signal_name", "SIGINT")


def exit_code(exc: BaseException) -> int:
    """128 + the signal number: 143 for SIGTERM, 130 for SIGINT."""
    return 128 + int(getattr(exc, "signum", signal.SIGINT))


def leave(code: int) -> int:
    """End the interrupted command's process now with `code`, its outputs written and its
    workers stopped: the temporary files of writes the interrupt cut are removed
    (`rcmplan._atomic.remove_unfinished`), stdout and stderr are flushed and Python's teardown
    is skipped (the collection of a process that loaded numba and LLVM took 0.5 s on a loaded
    machine). Called in-process, it returns the code. Call it inside `shielded()`."""
    from rcmplan._atomic import remove_unfinished

    remove_unfinished()
    if _state.command is None:
        return code
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError):
            stream.flush()
    os._exit(code)


def answered() -> bool:
    """False when the last interrupt raised has reached no `shielded()` block: the command did
    not write what it leaves (it came before the command's own handling began)."""
    return _state.answered


@contextlib.contextmanager
def handled() -> Iterator[None]:
    """SIGTERM raises Terminated and SIGINT Interrupted (both KeyboardInterrupt) inside the
    block (main thread only). In the command's process the stage is "finished" after it;
    called in-process, the previous handlers come back. An interrupt leaving the block is
    the caller's to answer (`shielded()`); one the block swallowed ends the process."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    ours = _state.command is not None
    old = {} if ours else {s: signal.signal(s, _on_signal) for s in CAUGHT}
    _state.stage, _state.answered = "running", True
    leaving = False  # an interrupt propagates out of the block
    try:
        yield
    except KeyboardInterrupt:
        leaving = True
        raise
    finally:
        if ours:
            finished()
            if not _state.answered and not leaving:  # swallowed: the signal ends the process
                from rcmplan._atomic import remove_unfinished

                remove_unfinished()
                os.kill(os.getpid(), _state.signum)
        for s, handler in old.items():
            signal.signal(s, handler)


def finished() -> None:
    """The command's outputs are final: from now on a signal ends the process by its default
    action (the outputs stay as written: a late signal does not make a finished run
    "interrupted"). The operating system's default, not a Python handler: Python runs no
    handler once its shutdown has begun, and would drop a signal that came then."""
    if _state.command is not None:
        _state.stage = "finished"  # first: a signal that `signal.signal` runs late sees it
        for s in CAUGHT:
            signal.signal(s, signal.SIG_DFL)


@contextlib.contextmanager
def shielded() -> Iterator[None]:
    """SIGINT and SIGTERM ignored inside the block: a second signal cannot cut the writing of
    an interrupted run's partial outputs (which are short and written atomically anyway).
    Entering it answers the pending interrupt (see `answered`)."""
    _state.answered = True
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = {s: signal.signal(s, signal.SIG_IGN) for s in CAUGHT}
    try:
        yield
    finally:
        for s, handler in old.items():
            signal.signal(s, handler)


@contextlib.contextmanager
def surfaced() -> Iterator[None]:
    """Inside the block, an exception that wraps an interrupt is raised as the interrupt, so
    the command's own interrupt handling writes the partial outputs."""
    try:
        yield
    except Exception as exc:
        interrupt = wrapped_interrupt(exc)
        if interrupt is None:
            raise
        raise interrupt from exc
