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

`njit(borrows=True)`: a kernel that only borrows the arrays it is given (it allocates none,
returns none and takes none from a call) is compiled without numba's reference counts (numba's
`_nrt=False`). numba otherwise counts a reference to each array argument as a kernel starts
and releases it as it ends, with an atomic add each, unless the kernel calls nothing in
between (numba's reference-count pruning then drops the pair): in the arm's compiled loop
some 97 such adds per iteration, and as many releases, 38 % of its samples under `perf`. The
loop (`algorithm.run_targets`) and every kernel it reaches borrow, the QP's assembly and solve
among them: their scratch comes from the caller (`algorithm.work_arrays`, the QP's
`qp_rows.buffers`), so an iteration counts no reference at all (docs/benchmarks.md). What
such a kernel must not do is checked when it compiles (`check_borrows`): numba refuses an
allocation without reference counts, and an array in its result, or in the result of a call
it makes, raises TypeError. numba compiles a kernel called first from such a kernel without
reference counts as well (and keeps that version for every caller): the same check holds it.

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


def njit(*, borrows: bool = False, **options: Any) -> Callable[[F], F]:
    """`numba.njit(**options)` whose calls from compiled code take plain argument types;
    `borrows`: compiled without reference counts, checked (module docstring)."""
    if borrows:
        options["_nrt"] = False

    def decorate(fn: F) -> F:
        dispatcher = numba.njit(**options)(fn)
        by_type = dispatcher.get_call_template

        def get_call_template(args: tuple, kws: dict) -> tuple:
            plain = tuple(types.unliteral(a) for a in args)
            return by_type(plain, {k: types.unliteral(v) for k, v in kws.items()})

        dispatcher.get_call_template = get_call_template
        compile_new = dispatcher._compiler.compile  # numba's compile of a new version

        def compile_checked(args: tuple, return_type: Any) -> Any:
            cres = compile_new(args, return_type)
            if not cres.target_context.enable_nrt:  # compiled without reference counts
                check_borrows(fn, cres)
            return cres

        dispatcher._compiler.compile = compile_checked
        return dispatcher

    return decorate


def holds_array(t: types.Type) -> bool:
    """True if a value of numba type t is an array or a tuple holding one."""
    if isinstance(t, types.Array):
        return True
    return isinstance(t, types.BaseTuple) and any(holds_array(x) for x in getattr(t, "types", ()))


def check_borrows(fn: Callable[..., Any], cres: Any) -> None:
    """Raise TypeError if the kernel fn, compiled without reference counts (`cres`, one of its
    compiled versions: a kernel with borrows=True, or one that numba compiled first for such a
    kernel's call, which it does without them too), returns an array or takes one from a call:
    its caller would release a reference it was never given, or the array would never be
    released. Run on each new compile; a version loaded from numba's cache was checked when it
    was compiled."""
    name = f"{fn.__module__}.{fn.__qualname__}"
    returned = cres.signature.return_type
    if holds_array(returned):
        raise TypeError(f"{name}: compiled without reference counts but returns {returned}")
    annotation = getattr(cres, "type_annotation", None)
    typemap = getattr(annotation, "typemap", {})
    for expr, sig in getattr(annotation, "calltypes", {}).items():
        if getattr(expr, "op", None) != "call" or sig is None or not holds_array(sig.return_type):
            continue
        callee = typemap.get(expr.func.name)  # another kernel, compiled with its own counts;
        if isinstance(callee, types.Dispatcher):  # a view of an argument (`a.view`) borrows
            raise TypeError(f"{name}: compiled without reference counts but takes an array "
                            f"({sig.return_type}) from the call {expr}")  # fmt: skip


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
