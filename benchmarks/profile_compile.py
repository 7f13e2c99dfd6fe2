"""Where a cold compile of every kernel goes: `compile_kernels()` under numba's compile-event
recorder, each dispatcher's exclusive and inclusive time (its own typing, lowering and LLVM
work, and with its callees') and the time spent holding LLVM's lock.

Run it in fresh caches, else it measures cache loads:

    NUMBA_CACHE_DIR=$(mktemp -d) XDG_CACHE_HOME=$(mktemp -d) python benchmarks/profile_compile.py

Two trees compared: run it once per tree at the same time (`PYTHONPATH=TREE/src`), so that the
two share the machine's load (docs/benchmarks.md, the cold compile rows).

With arguments it profiles one command line instead, what its first run compiles:

    NUMBA_CACHE_DIR=$(mktemp -d) XDG_CACHE_HOME=$(mktemp -d) \
        python benchmarks/profile_compile.py inject --no-plots --out /tmp/first-run
"""

from __future__ import annotations

import collections
import sys
import time

from numba.core import event


def main(argv: list[str], top: int = 25) -> None:
    """Profile `compile_kernels()`, or the command line `rcmplan *argv` if argv is not empty."""
    from rcmplan.cli import main as command
    from rcmplan.warmup import compile_kernels

    t0 = time.perf_counter()
    with (
        event.install_recorder("numba:compile") as rc,
        event.install_recorder("numba:llvm_lock") as rl,
    ):
        if argv:
            print(f"rcmplan {' '.join(argv)}: exit {command(argv)}")
        else:
            compile_kernels()
    total = time.perf_counter() - t0
    excl: collections.Counter[str] = collections.Counter()
    incl: collections.Counter[str] = collections.Counter()
    count: collections.Counter[str] = collections.Counter()
    stack: list[list] = []
    for ts, e in rc.buffer:
        f = e.data["dispatcher"].py_func
        name = f"{f.__module__}.{f.__qualname__}"
        if e.is_start:
            stack.append([name, ts, 0.0])
            continue
        n, start, child = stack.pop()
        incl[n] += ts - start
        excl[n] += ts - start - child
        count[n] += 1
        if stack:
            stack[-1][2] += ts - start
    llvm, start = 0.0, 0.0
    for ts, e in rl.buffer:
        if e.is_start:
            start = ts
        else:
            llvm += ts - start
    print(f"total {total:.1f} s, compile events {sum(excl.values()):.1f} s "
          f"({len(rc.buffer) // 2}), holding LLVM's lock {llvm:.1f} s")  # fmt: skip
    print("exclusive s  inclusive s  specialisations  function")
    for name, t in excl.most_common(top):
        print(f"{t:11.1f}  {incl[name]:11.1f}  {count[name]:15d}  {name}")


if __name__ == "__main__":
    main(sys.argv[1:])
