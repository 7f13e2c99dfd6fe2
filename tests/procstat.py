"""What Linux says of a process in /proc: its descendants, whether it runs, whether its exit has
begun, whether it catches a signal, the CPU time it has used (for the interrupt harnesses of
tests/ and benchmarks/)."""

from __future__ import annotations

import os
from pathlib import Path

PF_EXITING = 0x4  # include/linux/sched.h: the task is in do_exit(); a signal sent now is dropped


def stat_fields(pid: int) -> list[str] | None:
    """/proc/PID/stat from its third field (state) on; None once the process is reaped."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None


def children_of(pid: int) -> set[int]:
    """Every live descendant of pid."""
    parents: dict[int, int] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            fields = stat_fields(int(entry.name))
            if fields is not None:
                parents[int(entry.name)] = int(fields[1])
    found, frontier = set(), {pid}
    while frontier:
        frontier = {c for c, p in parents.items() if p in frontier} - found
        found |= frontier
    return found


def alive(pid: int) -> bool:
    """True while pid runs (a zombie counts as gone)."""
    fields = stat_fields(pid)
    return fields is not None and fields[0] != "Z"


def exiting(pid: int) -> bool:
    """True once pid's exit has begun: the kernel drops any signal sent from then on (exit code
    as the process chose), while `waitpid` still reports it running for the few milliseconds
    its memory takes to be freed. The flags are field 9."""
    fields = stat_fields(pid)
    return fields is None or fields[0] in ("Z", "X") or bool(int(fields[6]) & PF_EXITING)


def cpu_seconds(pid: int) -> float | None:
    """The CPU time [s] pid has used, user and system (fields 14 and 15); None once reaped."""
    fields = stat_fields(pid)
    if fields is None:
        return None
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def catches(pid: int, signum: int) -> bool:
    """True when pid has a handler installed for signum (SigCgt in /proc/PID/status)."""
    try:
        lines = Path(f"/proc/{pid}/status").read_text().splitlines()
    except OSError:
        return False
    mask = next((int(line.split()[1], 16) for line in lines if line.startswith("SigCgt:")), 0)
    return bool(mask >> (signum - 1) & 1)
