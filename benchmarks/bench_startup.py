"""Process start of the commands that do little (`--version`, `scenario --show`), of a run
(`inject`, warm caches) and of `view` to its address line: each process from start to end,
median of 5 (3 under --quick) after one untimed run, the load average in each figure's name.

Run alone: python benchmarks/bench_startup.py
"""

from __future__ import annotations

import os
import statistics
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from _common import quick, row
from bench_speed import timed_process
from bench_view import cold_start_s

REPEATS = 5  # 3 under --quick


def median_s(once: Callable[[], float], repeats: int) -> float:
    """Median in [s] of `repeats` calls of `once`, after one untimed call."""
    once()
    return statistics.median(once() for _ in range(repeats))


def rows() -> list[dict[str, Any]]:
    """One row per command."""
    rcmplan = [sys.executable, "-m", "rcmplan"]
    env = {"PYTHONPATH": os.pathsep.join(sys.path)}
    out: list[dict[str, Any]] = []

    repeats = 3 if quick() else REPEATS

    def add(what: str, once: Callable[[], float]) -> None:
        value = median_s(once, repeats)
        load = os.getloadavg()[0]
        out.append(row(f"{what}, median of {repeats} (load {load:.1f})", value, "s"))

    with tempfile.TemporaryDirectory() as tmp:
        run = Path(tmp) / "run"
        for argv in (["--version"], ["scenario", "--show", "default"]):
            add(f"`rcmplan {' '.join(argv)}`", lambda a=argv: timed_process([*rcmplan, *a], env))
        inject = [*rcmplan, "inject", "--no-plots", "--out", str(run)]
        add("`rcmplan inject --no-plots` (warm caches)", lambda: timed_process(inject, env))
        add("`rcmplan view RUN --no-browser` to its address line (the inject run)",
            lambda: cold_start_s(run))  # fmt: skip
    return out


if __name__ == "__main__":
    from run import print_table

    print_table(rows())
