"""Many subretinal episodes on segmented B-scans: success, RPE breaches and tracking per
compensation method, and the batch's wall time, beside the published ex vivo figures.

Run alone: python benchmarks/bench_subretinal_batch.py [--episodes N] [--methods all|kalman]
[--workers W] (1,000 episodes, every method, 2 processes by default; `rows()` for run.py takes
40 episodes, 8 under --quick). It runs `rcmplan subretinal --episodes N --no-plots --json` in a
new process (seed 0, the default draw ranges: docs/subretinal.md) and prints one row per method
and figure. The published figures are ex vivo hardware results under other conditions, printed
for scale only (docs/subretinal.md, sources S:15-18): subretinal blebs in 90 % of
trials with a deformation-aware virtual layer (Arikan et al., arXiv 2411.06557), RPE
penetration in 10.5 % of robot injections (RESCAN study, 84 porcine eyes). The wall-time row
holds the batch to 10 minutes per 1,000 episodes of one method on 2 processes, scaled to the
episodes and methods run.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from typing import Any

from _common import quick, row

PUBLISHED_BLEB_SUCCESS = 0.90  # Arikan et al., arXiv 2411.06557, ex vivo
PUBLISHED_RPE_PENETRATION = 0.105  # RESCAN study, robot, ex vivo
BUDGET_S_PER_1000 = 600.0  # 10 min per 1,000 episodes of one method on 2 processes


def run_batch(episodes: int, methods: str, workers: int) -> tuple[dict[str, Any], float]:
    """summary.json of one `rcmplan subretinal --episodes` run in a new process, and its wall
    time from process start to end [s]."""
    with tempfile.TemporaryDirectory() as out:
        cmd = [sys.executable, "-m", "rcmplan", "subretinal", "--episodes", str(episodes),
               "--workers", str(workers), "--no-plots", "--json", "--out", out]  # fmt: skip
        if methods != "all":
            cmd += ["--compensation", methods]
        t = time.perf_counter()
        done = subprocess.run(cmd, capture_output=True, text=True, check=False)
        wall = time.perf_counter() - t
    if done.returncode != 0:
        raise RuntimeError(f"rcmplan subretinal exited {done.returncode}: {done.stderr[-2000:]}")
    return json.loads(done.stdout), wall


def batch_rows(episodes: int, methods: str = "all", workers: int = 2) -> list[dict[str, Any]]:
    """Per method: success rate, RPE breaches, hover tracking; then the batch's wall time."""
    doc, wall = run_batch(episodes, methods, workers)
    if doc["status"] != "ok":
        raise RuntimeError(f"the batch ended {doc['status']}: {doc.get('message')}")
    out = []
    for name, m in doc["methods"].items():
        n = m["episodes"]
        out.append(row(f"{name}: success rate, {n} episodes on images", m["success_rate"], "",
                       "bleb success, virtual layer (ex vivo, published)",
                       PUBLISHED_BLEB_SUCCESS, ">= 0.98 (kalman)"))  # fmt: skip
        out.append(row(f"{name}: RPE breaches / episodes", m["rpe_breaches"] / n, "",
                       "RPE penetration, robot (ex vivo, published)",
                       PUBLISHED_RPE_PENETRATION, "0 (kalman)"))  # fmt: skip
        out.append(row(f"{name}: hover tracking RMS, median", 1e6 * m["tracking_rms_m_median"],
                       "um", target="<= 5 um (kalman)"))  # fmt: skip
    runs = episodes * len(doc["methods"])
    budget = BUDGET_S_PER_1000 * runs / 1000.0
    out.append(row(f"wall time of {runs} episode runs, {workers} processes", wall, "s",
                   "10 min per 1,000 runs", budget, f"<= {budget:.0f} s"))  # fmt: skip
    load = os.getloadavg()[0]
    out.append(row("machine", f"load average {load:.1f} (1 min) on {os.cpu_count()} cores", ""))
    return out


def rows() -> list[dict[str, Any]]:
    """run.py's rows: a short batch with every method."""
    return batch_rows(8 if quick() else 40)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=1000)
    ap.add_argument("--methods", choices=("all", "none", "hold", "fft", "kalman"), default="all")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    for r in batch_rows(args.episodes, args.methods, args.workers):
        print(json.dumps(r))


if __name__ == "__main__":
    main()
