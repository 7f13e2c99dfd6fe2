"""numba's `njit` for rcmplan's kernels: one compiled version per set of argument types, not
one per set of constants.

Inside compiled code numba types a constant as a literal (`Literal[int](6)`, not `int64`), and
a call to another kernel with constant arguments compiles that kernel once per distinct set of
constants: `loop.put(row, 1, s, 0, 6)` and `loop.put(row, 7, q, 0, 6)` were two compiles of
`put`, and a warm-up with the test stage after it left 68 such copies in numba's cache
(`linalg.lu_solve` 7 times for one type signature). Here a kernel called from compiled code is
compiled for its arguments' plain types (`numba.types.unliteral`), once: a cold compile of
every kernel took 0.84 of the CPU time, the loops' speed unchanged within this machine's noise
(docs/benchmarks.md).

A kernel that needs a constant argument as a literal (an index into a heterogeneous tuple,
say) cannot use this decorator; none does.

numba compiles a kernel at its first call with a set of argument types and keeps it in its cache
(`cache=True`); a later process loads it. The first compile of one of rcmplan's kernels in a
process prints one line on stderr (`FirstCompile`, a listener of numba's compile events: a load
from the cache sends none), so a run that compiles says so, whether it is the first run of the
installation or the first of a kind not run before (another robot, method or plant).
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any, TypeVar

import numba
from numba.core import event, types

from rcmplan._kernel_cache import check_once

check_once()  # before any kernel is compiled or loaded from numba's cache

F = TypeVar("F", bound=Callable[..., Any])


def njit(**options: Any) -> Callable[[F], F]:
    """`numba.njit(**options)` whose calls from compiled code take plain argument types."""

    def decorate(fn: F) -> F:
        dispatcher = numba.njit(**options)(fn)
        by_type = dispatcher.get_call_template

        def get_call_template(args: tuple, kws: dict) -> tuple:
            plain = tuple(types.unliteral(a) for a in args)
            return by_type(plain, {k: types.unliteral(v) for k, v in kws.items()})

        dispatcher.get_call_template = get_call_template
        return dispatcher

    return decorate


class FirstCompile(event.Listener):
    """Prints one line on stderr at the first compile of one of rcmplan's kernels in this
    process (nothing for other packages' functions, nor for kernels loaded from the cache, nor
    in a worker process of multiprocessing: a sweep's command says it once, not once more per
    worker)."""

    LINE = ("rcmplan: numba compiles kernels that this kind of run uses for the first time; "
            "it caches them, and later runs load them at once")  # fmt: skip

    def __init__(self) -> None:
        self.said = False

    def on_start(self, ev: event.Event) -> None:
        if self.said:
            return
        fn = getattr(ev.data.get("dispatcher"), "py_func", None)
        if getattr(fn, "__module__", "").startswith("rcmplan."):
            self.said = True
            mp = sys.modules.get("multiprocessing")  # loaded in any worker it started
            if mp is None or mp.parent_process() is None:
                print(self.LINE, file=sys.stderr, flush=True)

    def on_end(self, ev: event.Event) -> None:
        """Nothing at the end of a compile."""


event.register("numba:compile", FirstCompile())
