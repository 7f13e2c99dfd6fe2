"""Robustness figures: how fast bad input is refused, and how fast an interrupted run ends.

Run alone: python benchmarks/bench_robustness.py
Each row: figure, value, unit, target. Times are wall times of real `rcmplan` processes (the
interpreter's start-up included), medians over the cases listed.
"""

from __future__ import annotations

import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

BAD_FILES = {  # name -> content: each must exit 2 with one line, within 1 s
    "binary": bytes(range(256)),
    "non-UTF-8": 'name = "caf\xe9"\n'.encode("latin-1"),
    "nested 5000 deep": b"a = " + b"[" * 5000 + b"]" * 5000 + b"\n",
    "wrong type": b'[qp]\ncontacts_mm = "abc"\n',
    "NaN": b"[eye]\nradius_mm = nan\n",
    "huge number": b"[eye]\nradius_mm = 1" + b"0" * 400 + b"\n",
    "unknown key": b"[eye]\nfoo = 1\n",
    "truncated": b"[eye\nradius",
}
SLOW_FILES = {  # schema-valid settings refused before motion (exit 1, status plan_too_large)
    "angle_mrad = 0.001": b"[steps]\nangle_mrad = 0.001\n",
    "position_mm = 0.0001": b"[steps]\nposition_mm = 0.0001\n",
}


def rcmplan(*argv: str) -> subprocess.Popen[bytes]:
    """Start `python -m rcmplan argv`."""
    return subprocess.Popen([sys.executable, "-m", "rcmplan", *argv],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)  # fmt: skip


def refusal(folder: Path, name: str, data: bytes) -> tuple[float, int, int]:
    """(wall time [s], exit code, stderr lines) of `inject` on a scenario file."""
    path = folder / f"{len(list(folder.iterdir()))}.toml"
    path.write_bytes(data)
    start = time.perf_counter()
    proc = rcmplan("inject", "--no-plots", "--scenario", str(path), "--out", str(folder / "o"))
    _, err = proc.communicate()
    return time.perf_counter() - start, proc.returncode, len(err.decode().splitlines())


def interrupt_latency(folder: Path, argv: list[str], sig: int, after_s: float) -> tuple[float, int]:
    """(time [s] from the signal to the process's exit, exit code)."""
    out = folder / f"run{time.monotonic_ns()}"
    proc = rcmplan(*argv, "--out", str(out))
    while not out.exists() and proc.poll() is None:
        time.sleep(0.01)
    time.sleep(after_s)
    start = time.perf_counter()
    proc.send_signal(sig)
    proc.communicate()
    return time.perf_counter() - start, proc.returncode


def main() -> None:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for name, data in {**BAD_FILES, **SLOW_FILES}.items():
            t, code, lines = refusal(folder, name, data)
            rows.append((f"scenario file, {name}: exit {code}, {lines} stderr line(s)", t, "s",
                         "< 1 s"))  # fmt: skip
        cases = [
            (["sweep", "--targets", "30000", "--workers", "2", "--no-plots"], 2.0),
            (["inject"], 0.5),
            (["compare", "--method", "pinv", "--method", "dls"], 0.3),
        ]
        for argv, after in cases:
            for sig in (signal.SIGINT, signal.SIGTERM):
                times = [interrupt_latency(folder, argv, sig, after) for _ in range(3)]
                codes = sorted({c for _, c in times})
                rows.append((f"{argv[0]} {signal.Signals(sig).name} to exit (codes {codes})",
                             statistics.median(t for t, _ in times), "s", "< 5 s"))  # fmt: skip
    width = max(len(r[0]) for r in rows)
    for figure, value, unit, target in rows:
        print(f"{figure:<{width}}  {value:8.3f} {unit}  {target}")


if __name__ == "__main__":
    main()
