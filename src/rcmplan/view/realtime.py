"""Real-time scheduling for the live control thread, where the operating system grants it.

A 1 kHz loop that sleeps between periods is woken by the scheduler; on a busy machine a
thread of normal priority waits its turn behind every other runnable thread, and periods are
missed (docs/view.md: a fifth to a third of them at a load average of 5 to 7 on 2 cores,
none with the thread at a real-time priority). Linux grants SCHED_FIFO to root, to a process
with CAP_SYS_NICE, or within RLIMIT_RTPRIO; elsewhere the thread keeps normal scheduling and
says so. The control loop sleeps until its next period after every step, also when it runs
late, so it never holds a core: a real-time priority cannot starve the machine.
"""

from __future__ import annotations

import os

PRIORITY = 10  # of 1..99: above every normal thread, below the kernel's own real-time threads


def request_realtime(priority: int = PRIORITY) -> str:
    """Ask for SCHED_FIFO at `priority` for the calling thread; what was granted, as text."""
    setter = getattr(os, "sched_setscheduler", None)
    if setter is None or not hasattr(os, "SCHED_FIFO"):
        return "normal scheduling (no real-time scheduling on this system)"
    try:
        setter(0, os.SCHED_FIFO, os.sched_param(priority))
    except OSError as exc:
        return f"normal scheduling (real-time refused: {exc.strerror or exc})"
    return f"real-time scheduling (SCHED_FIFO {priority})"
