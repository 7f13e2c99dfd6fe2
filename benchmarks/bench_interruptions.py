"""Lost logs over many random interruptions of each long command (issue floor: 0 over 100).

Run alone: python benchmarks/bench_interruptions.py [--runs N]
Runs tests/test_interrupts.py's harness with RCMPLAN_INTERRUPTIONS=N (default 100; 10 with
--quick through benchmarks/run.py): per command (inject, spiral, compare, sweep, teleop), N real
processes each get SIGINT or SIGTERM at a seeded random point; each must leave a summary
saying why it stopped, a loadable log or none, no temporary file and no process behind. One row
per command: the interruptions that broke any of these (the lost logs), out of N.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from _common import quick, row

ROOT = Path(__file__).resolve().parents[1]
COMMANDS = ("compare", "inject", "spiral", "sweep", "teleop")


def run_command(command: str, runs: int) -> tuple[int | str, float]:
    """(failed interruptions: 0, or ">= 1" when the harness stopped at one; wall time [s])."""
    env = {**os.environ, "RCMPLAN_INTERRUPTIONS": str(runs), "MUJOCO_GL": "egl"}
    start = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
         str(ROOT / "tests" / "test_interrupts.py"), "-k", f"random_points and {command}",
         "--maxfail=1000"],
        env=env, cwd=ROOT, capture_output=True, text=True,
    )  # fmt: skip
    wall = time.perf_counter() - start
    if proc.returncode == 0:
        return 0, wall
    # The harness stops a command at its first broken interruption: report the assertion (the
    # remaining runs of that command are not made).
    failed = re.findall(r"^E\s+(.*)$", proc.stdout, flags=re.M)
    print(f"{command}: {failed[:3] or proc.stdout[-2000:]}", file=sys.stderr)
    return ">= 1", wall


def rows(runs: int | None = None) -> list[dict[str, Any]]:
    """One row per command."""
    n = runs or (10 if quick() else 100)
    out = []
    for command in COMMANDS:
        lost, wall = run_command(command, n)
        out.append(row(f"{command}: interruptions losing the log or summary, of {n} "
                       f"({wall:.0f} s)", lost, "", target="0"))  # fmt: skip
    return out


def main() -> None:
    """Print the rows."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=100, help="interruptions per command")
    args = ap.parse_args()
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from run import print_table

    print_table(rows(args.runs))


if __name__ == "__main__":
    main()
