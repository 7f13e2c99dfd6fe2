"""Run every benchmark and print one table: `python benchmarks/run.py [--quick] [--only NAME]`.

Every `benchmarks/bench_*.py` that defines `rows()` contributes rows (see README.md for the
convention); a module with only `main()` is run after the table and prints its own output.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import os
import sys
import time
import traceback
from pathlib import Path
from types import ModuleType
from typing import Any

HERE = Path(__file__).resolve().parent
COLUMNS = ("figure", "rcmplan", "unit", "peer", "peer value", "ratio", "target")


def load(path: Path) -> ModuleType:
    """Import a benchmark module from its file."""
    spec = importlib.util.spec_from_file_location(path.stem, path)
    if spec is None or spec.loader is None:
        raise ImportError(f"cannot load {path}")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def fmt(value: Any) -> str:
    """Numbers with 4 significant digits, everything else as text."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    if isinstance(value, float | int) and not isinstance(value, bool):
        return f"{value:.4g}"
    return str(value)


def print_table(rows: list[dict[str, Any]]) -> None:
    """One aligned text table with the columns COLUMNS."""
    keys = ("figure", "value", "unit", "peer", "peer_value", "ratio", "target")
    cells = [COLUMNS, *[tuple(fmt(r.get(k)) for k in keys) for r in rows]]
    widths = [max(len(c[i]) for c in cells) for i in range(len(COLUMNS))]
    for c in cells:
        print("  ".join(x.ljust(w) for x, w in zip(c, widths, strict=True)).rstrip())


def main(argv: list[str] | None = None) -> int:
    """Run the benchmarks; exit 1 if any module failed."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer repetitions")
    ap.add_argument("--only", action="append", help="module name (bench_speed), repeatable")
    args = ap.parse_args(argv)
    if args.quick:
        os.environ["RCMPLAN_BENCH_QUICK"] = "1"
    sys.path.insert(0, str(HERE))
    rows: list[dict[str, Any]] = []
    mains: list[ModuleType] = []
    failed = 0
    for path in sorted(HERE.glob("bench_*.py")):
        if args.only and path.stem not in args.only:
            continue
        t = time.perf_counter()
        try:
            module = load(path)
            if hasattr(module, "rows"):
                rows += module.rows()
            elif hasattr(module, "main"):
                mains.append(module)
        except Exception:  # one broken benchmark must not hide the others
            failed += 1
            traceback.print_exc()
            rows.append({"figure": f"{path.stem}: FAILED (traceback above)"})
        print(f"[{path.stem}: {time.perf_counter() - t:.1f} s]", file=sys.stderr)
    print_table(rows)
    for module in mains:
        print(f"\n## {module.__name__} (main() only)")
        module.main()
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
