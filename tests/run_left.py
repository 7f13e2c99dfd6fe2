"""What a signalled `rcmplan` process left, against the interrupt promise (docs/report.md, "A
run stopped early"): one classification for the interrupt harnesses of tests/ and benchmarks/.

A run that exits 128 + the signal number must leave summary.json with status "interrupted" and
the signal's name; one ended by the signal (-signal), or exiting 0 because its exit had begun
before the signal (the kernel then drops it), must leave the summary of a finished run. Either
way the records the summary states must be there: a summary that says the run had begun
recording (anything but "before the run" / "before the session") has its log beside it, loadable,
with as many records as it states (`iterations`, a teleop session's `periods`); compare's rows
each have their method's log, sweep's `results_kept` are in its checkpoint, reproduce's message
counts its rows. A summary saying the run stopped before it began has no log beside it.
"""

from __future__ import annotations

import json
import re
import signal
from pathlib import Path
from typing import Any

# The kinds of fault `faults` names (each fault string starts with one), in report order.
KINDS = (
    "no summary",
    "traceback",
    "ignored",
    "wrong exit",
    "status",
    "command",
    "log",
    "records",
    "temporary",
)
NOT_BEGUN = ("before the run", "before the session")


def our_tracebacks(err: str) -> list[str]:
    """Tracebacks on stderr other than "Exception ignored" notes of third-party finalizers
    (llvmlite's, when numba's compiling is cut)."""
    lines = err.splitlines()
    return [
        lines[i - 1] if i else ""
        for i, line in enumerate(lines)
        if line.startswith("Traceback") and not (i and lines[i - 1].startswith("Exception ignored"))
    ]


def faults(out: Path, command: str, code: int, sig: int, err: str = "", late: bool = False
           ) -> list[str]:  # fmt: skip
    """Every way the run in `out` of `command`, sent `sig` and ended with exit `code` (stderr
    `err`; `late`: its exit had begun before the signal), broke the promise; [] if none."""
    found = [f"traceback: {t}" for t in our_tracebacks(err)]
    ended = code in (0, 1)  # the run's own exit: 1 after a run that is not ok (limit_violated)
    if ended and not late:
        found.append(f"ignored: exit {code} after a signal sent before the process's exit began")
    elif not ended and code not in (-sig, 128 + sig):
        found.append(f"wrong exit {code}")
    try:
        doc = json.loads((out / "summary.json").read_text())
    except (OSError, ValueError) as exc:
        return [*found, f"no summary: {exc}"]
    stopped = code == 128 + sig
    status, message = doc.get("status"), str(doc.get("message", ""))
    if stopped and (status != "interrupted" or signal.Signals(sig).name not in message):
        found.append(f"status {status!r} ({message!r}) after exit {code}")
    if not stopped and status == "interrupted":
        found.append(f"status 'interrupted' after exit {code}")
    if ended and late and (code == 1) != (status != "ok"):  # the run's own exit, for its status
        found.append(f"status {status!r} after exit {code}")
    named = command.split("-")[0]  # "inject-mujoco": a run of inject
    if doc.get("command") != named:
        found.append(f"command {doc.get('command')!r} named by the summary of `rcmplan {named}`")
    elif next(iter(doc)) != "command":
        found.append(f"command named after {next(iter(doc))!r} in the summary, not first")
    found += [f"records: {f}" for f in RECORDS.get(command, run_log)(out, doc)]
    found += [f"temporary file {p.name}" for p in out.rglob("*") if ".tmp" in p.name]
    return found


def kind(fault: str) -> str:
    """The kind (KINDS) a fault string names."""
    return next(k for k in KINDS if fault.startswith(k))


def begun(doc: dict[str, Any]) -> bool:
    """False when the summary says the run stopped before it began recording."""
    return not any(p in str(doc.get("message", "")) for p in NOT_BEGUN)


def stated_records(doc: dict[str, Any]) -> int | None:
    """The records the summary says the log holds (`iterations`; a session's `periods`)."""
    n = doc.get("iterations", doc.get("periods"))
    return n if isinstance(n, int) else None


def run_log(out: Path, doc: dict[str, Any]) -> list[str]:
    """A run with one log: none beside a summary saying it stopped before it began; else
    out/log.npz loadable (`rcmplan.view.run_folder.read_log`), with the stated records."""
    from rcmplan.control.log import RunLog
    from rcmplan.view.run_folder import RunFolderError, read_log

    n, path = stated_records(doc), out / "log.npz"
    if not begun(doc):
        return [f"log.npz beside {doc.get('message')!r}"] if path.exists() else []
    if n is None:
        return [f"the summary states no records ({doc.get('message')!r})"]
    if not path.exists():
        return [f"no log.npz beside a summary of {n} records ({doc.get('message')!r})"]
    try:  # the view refuses a log of no records, which a run stopped at its start leaves
        held = len(read_log(path) if n else RunLog.load_npz(path))
    except (RunFolderError, OSError, ValueError, KeyError) as exc:
        return [f"log.npz does not load: {exc}"]
    return [] if held == n else [f"log.npz holds {held} records, the summary states {n}"]


def compare_logs(out: Path, doc: dict[str, Any]) -> list[str]:
    """compare: "after N methods" counts its rows; each row that ran has its method's log."""
    rows = doc.get("methods", [])
    found = []
    if rows and not begun(doc):
        found.append(f"{len(rows)} rows beside {doc.get('message')!r}")
    after = re.search(r"after (\d+) methods", str(doc.get("message", "")))
    if after and int(after.group(1)) != len(rows):
        found.append(f"{len(rows)} rows, the message says {after.group(1)}")
    for row in rows:
        if row.get("iterations"):
            found += [f"{row['method']}: {f}" for f in run_log(out / row["method"], row)]
    return found


def sweep_checkpoint(out: Path, doc: dict[str, Any]) -> list[str]:
    """sweep: the `results_kept` a stopped sweep states are in its checkpoint, each chunk's
    checksum and settings hash checked (`RecordCheckpoint.load`)."""
    from rcmplan.exceptions import RcmplanError
    from rcmplan.sweep.checkpoint import HEADER, Checkpoint

    kept = doc.get("results_kept")
    if not kept:
        return []
    path = Path(doc["checkpoint"])
    try:
        header = json.loads((path / HEADER).read_text())
        checkpoint = Checkpoint.__new__(Checkpoint)  # bound to the header's settings hash
        checkpoint.path, checkpoint.digest = path, header["settings_hash"]
        checkpoint.n_targets = header["n_targets"]
        held = len(checkpoint.load())
    except (OSError, ValueError, KeyError, RcmplanError) as exc:
        return [f"the checkpoint of {kept} results does not load: {exc}"]
    return [] if held == kept else [f"the checkpoint holds {held} results, summary {kept}"]


def reproduce_rows(out: Path, doc: dict[str, Any]) -> list[str]:
    """reproduce: "after N of M experiments" counts its rows."""
    rows = doc.get("experiments", [])
    after = re.search(r"after (\d+) of \d+ experiments", str(doc.get("message", "")))
    if doc.get("status") == "interrupted" and begun(doc) and after is None:
        return [f"the summary does not count its experiments ({doc.get('message')!r})"]
    if after and int(after.group(1)) != len(rows):
        return [f"{len(rows)} rows, the message says {after.group(1)}"]
    return []


RECORDS = {"compare": compare_logs, "sweep": sweep_checkpoint, "reproduce": reproduce_rows}
