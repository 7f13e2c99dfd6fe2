"""DAQP's C solver called from compiled code: `daqp_quadprog` without Python in between.

The `daqp` wheel is one Cython extension module that also exports DAQP's C functions. This
module finds it through `daqp.__file__`, registers the address of `daqp_quadprog` with the
JIT linker under a name of its own (`rcmplan_daqp_quadprog`, so that no other library's symbol
can stand in for it), and declares it to numba as an external function: kernels compiled with
`cache=True` refer to the symbol by name and are linked again in every process.

The structures passed by pointer, DAQPProblem, DAQPSettings and DAQPResult, are copied below
field by field from DAQP's `include/types.h` and `include/api.h` of the version in
`ABI_VERSIONS` (read from its source distribution); ctypes lays them out as the C compiler
does, and the kernels fill numpy buffers at those offsets. Another DAQP version may reorder
or add fields, so the binding is used only for the versions listed, after a probe: the
default settings land where the header puts them and nothing beyond, and probe problems solve
to the same x as `daqp.solve` (`abi_ok`). Otherwise the compiled QP path is not used.

`daqp_quadprog` is the function `daqp.solve` calls (with the same default settings), so the
solutions equal `daqp.solve`'s bit for bit on the same arrays (tests/test_daqp_c.py).
"""

from __future__ import annotations

import ctypes
import math
from importlib import metadata
from typing import Any

import llvmlite.binding as llvm
import numpy as np
from numba import types

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.exceptions import QPError

ABI_VERSIONS = ("0.11.0",)  # DAQP versions whose headers the structures below copy
SYMBOL = "rcmplan_daqp_quadprog"
INF = 1e30  # DAQP_INF: a bound at or beyond it is absent
EQUALITY = 5  # sense of an equality row: DAQP_ACTIVE | DAQP_IMMUTABLE
EXIT = {1: "optimal", 2: "soft optimal", 3: "constrained point", 4: "optimal inexact",
        5: "feasible", -1: "infeasible", -2: "cycling", -3: "unbounded", -4: "iteration limit",
        -5: "nonconvex", -6: "overdetermined initial active set", -7: "time limit",
        -8: "unsupported"}  # fmt: skip


class DAQPProblem(ctypes.Structure):
    """types.h: min 0.5 x'Hx + f'x s.t. blower <= [x[:ms]; A x] <= bupper (A row-major)."""

    _fields_ = [("n", ctypes.c_int), ("m", ctypes.c_int), ("ms", ctypes.c_int),
                ("H", ctypes.c_void_p), ("f", ctypes.c_void_p), ("A", ctypes.c_void_p),
                ("bupper", ctypes.c_void_p), ("blower", ctypes.c_void_p),
                ("sense", ctypes.c_void_p), ("break_points", ctypes.c_void_p),
                ("nh", ctypes.c_int), ("problem_type", ctypes.c_int)]  # fmt: skip


class DAQPSettings(ctypes.Structure):
    """types.h: the solver's settings (filled by `daqp_default_settings`)."""

    _fields_ = [("primal_tol", ctypes.c_double), ("dual_tol", ctypes.c_double),
                ("zero_tol", ctypes.c_double), ("pivot_tol", ctypes.c_double),
                ("progress_tol", ctypes.c_double), ("cycle_tol", ctypes.c_int),
                ("iter_limit", ctypes.c_int), ("fval_bound", ctypes.c_double),
                ("eps_prox", ctypes.c_double), ("eta_prox", ctypes.c_double),
                ("rho_soft", ctypes.c_double), ("rel_subopt", ctypes.c_double),
                ("abs_subopt", ctypes.c_double), ("sing_tol", ctypes.c_double),
                ("refactor_tol", ctypes.c_double), ("time_limit", ctypes.c_double),
                ("w_soft", ctypes.c_double), ("eq_reduction", ctypes.c_int),
                ("presolve", ctypes.c_int)]  # fmt: skip


class DAQPResult(ctypes.Structure):
    """api.h: the solution x (n,), the duals lam (m,), and the solve's figures."""

    _fields_ = [("x", ctypes.c_void_p), ("lam", ctypes.c_void_p), ("fval", ctypes.c_double),
                ("soft_slack", ctypes.c_double), ("exitflag", ctypes.c_int),
                ("iter", ctypes.c_int), ("nodes", ctypes.c_int),
                ("solve_time", ctypes.c_double), ("setup_time", ctypes.c_double)]  # fmt: skip


# Settings as DAQP's constants.h sets them (DAQP_DEFAULT_*; time limit 0, eq_reduction AUTO,
# presolve on): what daqp.solve passes when given no keyword, checked against the library.
HEADER_DEFAULTS = {"primal_tol": 1e-6, "dual_tol": 1e-12, "zero_tol": 1e-11, "pivot_tol": 1e-8,
                   "progress_tol": 1e-14, "cycle_tol": 10, "iter_limit": 10000,
                   "fval_bound": 1e30, "eps_prox": -1e-6, "eta_prox": -1.0, "rho_soft": 1e-6,
                   "rel_subopt": 0.0, "abs_subopt": 0.0, "sing_tol": 3.7e-11,
                   "refactor_tol": 1e-9, "time_limit": 0.0, "w_soft": 0.0, "eq_reduction": 0,
                   "presolve": 1}  # fmt: skip


def _words(struct: type[ctypes.Structure]) -> int:
    """Size of a structure in 8-byte words (buffers are int64 or float64 arrays)."""
    size = ctypes.sizeof(struct)
    if size % 8:
        raise ImportError(f"{struct.__name__} is {size} bytes, not a multiple of 8")
    return size // 8


def _index(struct: type[ctypes.Structure], field: str, width: int) -> int:
    """Index of a field in a buffer viewed as `width`-byte items (its natural alignment)."""
    offset = int(getattr(struct, field).offset)
    if offset % width:
        raise ImportError(f"{struct.__name__}.{field} at byte {offset} is not {width}-aligned")
    return offset // width


PROBLEM_WORDS, SETTINGS_WORDS, RESULT_WORDS = (
    _words(DAQPProblem), _words(DAQPSettings), _words(DAQPResult)
)  # fmt: skip
# int32 indices (ints) and int64 indices (pointers) of the fields the kernels write and read.
P_N, P_M, P_MS = (_index(DAQPProblem, f, 4) for f in ("n", "m", "ms"))
P_NH, P_TYPE = _index(DAQPProblem, "nh", 4), _index(DAQPProblem, "problem_type", 4)
P_H, P_F, P_A, P_UP, P_LO, P_SENSE, P_BREAK = (
    _index(DAQPProblem, f, 8) for f in ("H", "f", "A", "bupper", "blower", "sense", "break_points")
)
R_X, R_LAM = _index(DAQPResult, "x", 8), _index(DAQPResult, "lam", 8)
R_EXIT, R_ITER = _index(DAQPResult, "exitflag", 4), _index(DAQPResult, "iter", 4)
R_FVAL = _index(DAQPResult, "fval", 8)


def _library() -> ctypes.CDLL:
    """The DAQP extension module as a C library (already loaded by `import daqp`)."""
    import daqp  # a core dependency

    return ctypes.CDLL(daqp.__file__)


_lib = _library()
llvm.add_symbol(SYMBOL, ctypes.cast(_lib.daqp_quadprog, ctypes.c_void_p).value)
# void daqp_quadprog(DAQPResult*, DAQPProblem*, DAQPSettings*): pointers passed as addresses.
daqp_quadprog: Any = types.ExternalFunction(
    SYMBOL, types.void(types.uintp, types.uintp, types.uintp)
)


def default_settings() -> FloatArray:
    """DAQP's default settings (`daqp_default_settings`) in a float64 buffer of DAQPSettings."""
    buf = np.zeros(SETTINGS_WORDS, dtype=np.float64)
    _lib.daqp_default_settings(ctypes.c_void_p(buf.ctypes.data))
    return buf


@njit(cache=True, borrows=True)
def quadprog(
    H: FloatArray, f: FloatArray, A: FloatArray, upper: FloatArray, lower: FloatArray,
    sense: np.ndarray, n_bounds: int, n_rows: int, x: FloatArray, lam: FloatArray,
    problem: np.ndarray, result: np.ndarray, settings: FloatArray,
) -> int:  # fmt: skip
    """Solve min 1/2 x'Hx + f'x s.t. lower <= (x[:n_bounds], A[:n_rows] x) <= upper with
    DAQP; returns DAQP's exit flag (1: optimal), x (n,) and the duals lam written in place.

    H (n, n) and A (>= n_rows, n) C-contiguous float64; upper, lower (>= n_bounds + n_rows);
    sense int32 (>= n_bounds + n_rows): 0 inequality, EQUALITY for an equality row; lam
    (>= n_bounds + n_rows); problem, result int64 buffers of PROBLEM_WORDS, RESULT_WORDS;
    settings from `default_settings`.
    """
    pi = problem.view(np.int32)
    pi[P_N] = H.shape[0]
    pi[P_M] = n_bounds + n_rows
    pi[P_MS] = n_bounds
    pi[P_NH] = 0
    pi[P_TYPE] = 0
    problem[P_H] = H.ctypes.data
    problem[P_F] = f.ctypes.data
    problem[P_A] = A.ctypes.data
    problem[P_UP] = upper.ctypes.data
    problem[P_LO] = lower.ctypes.data
    problem[P_SENSE] = sense.ctypes.data
    problem[P_BREAK] = 0
    result[R_X] = x.ctypes.data
    result[R_LAM] = lam.ctypes.data
    daqp_quadprog(result.ctypes.data, problem.ctypes.data, settings.ctypes.data)
    return result.view(np.int32)[R_EXIT]


class Workspace:
    """The buffers of one solve with at most n variables and `rows` constraints in all."""

    def __init__(self, n: int, rows: int) -> None:
        self.x, self.lam = np.empty(n), np.empty(rows)
        self.problem = np.zeros(PROBLEM_WORDS, dtype=np.int64)
        self.result = np.zeros(RESULT_WORDS, dtype=np.int64)
        self.settings = default_settings()


def solve_arrays(
    H: FloatArray, f: FloatArray, A: FloatArray, upper: FloatArray, lower: FloatArray,
    sense: np.ndarray,
) -> tuple[FloatArray, int]:  # fmt: skip
    """daqp.solve's arguments (bounds first: len(upper) - len(A) simple bounds) -> (x, flag)."""
    H, A = np.ascontiguousarray(H, dtype=np.float64), np.ascontiguousarray(A, dtype=np.float64)
    n, n_rows = H.shape[0], A.shape[0]
    n_bounds = upper.shape[0] - n_rows
    ws = Workspace(n, max(upper.shape[0], 1))
    flag = quadprog(H, np.ascontiguousarray(f, dtype=np.float64),
                    A if n_rows else np.zeros((1, n)),
                    np.ascontiguousarray(upper, dtype=np.float64),
                    np.ascontiguousarray(lower, dtype=np.float64),
                    np.ascontiguousarray(sense, dtype=np.int32), n_bounds, n_rows, ws.x, ws.lam,
                    ws.problem, ws.result, ws.settings)  # fmt: skip
    return ws.x, int(flag)


def solve_problem(problem: Any) -> tuple[FloatArray, int]:
    """Solve a QPProblem (`rcmplan.control.qp_problem`) as `qp_backends.solve_daqp` does,
    through the compiled call; QPError naming the exit flag if it is not optimal."""
    from rcmplan.control.qp_backends import daqp_arrays

    A, upper, lower, sense = daqp_arrays(problem)
    x, flag = solve_arrays(problem.P, problem.q, A, upper, lower, sense)
    if flag != 1:
        raise QPError(f"QP solve failed: daqp exit flag {flag} ({exit_name(flag)})",
                      problem=problem, result=(x, flag))  # fmt: skip
    return x, flag


def exit_name(flag: int) -> str:
    """DAQP's name of an exit flag (constants.h)."""
    return EXIT.get(int(flag), "unknown exit flag")


def abi_ok() -> bool:
    """True if the installed DAQP is a version whose layout this module copies and a probe
    agrees: the defaults at the header's offsets, nothing written past DAQPSettings, and probe
    QPs (bounds, inequalities, equalities) solved to daqp.solve's x and exit flag."""
    if metadata.version("daqp") not in ABI_VERSIONS:
        return False
    probe = np.full(SETTINGS_WORDS + 4, -7.0)
    _lib.daqp_default_settings(ctypes.c_void_p(probe.ctypes.data))
    seen = DAQPSettings.from_buffer_copy(probe.tobytes()[: ctypes.sizeof(DAQPSettings)])
    for name, value in HEADER_DEFAULTS.items():
        if not math.isclose(getattr(seen, name), value, rel_tol=1e-15, abs_tol=0.0):
            return False
    if not np.all(probe[SETTINGS_WORDS:] == -7.0):
        return False
    return _probe_solves()


def _probe_solves() -> bool:
    """Random QPs with 6 bounds, 4 inequalities and 2 equalities, as daqp.solve solves them."""
    import daqp

    rng = np.random.default_rng(14)
    for k in range(20):
        M = rng.normal(size=(6, 6))
        H, f, A = M @ M.T + 0.1 * np.eye(6), rng.normal(size=6), rng.normal(size=(6, 6))
        upper = np.concatenate([rng.uniform(0.1, 2.0, 6), rng.uniform(0.0, 1.0, 6)])
        lower = np.concatenate([-rng.uniform(0.1, 2.0, 6), np.full(6, -INF)])
        sense = np.zeros(12, dtype=np.int32)
        if k % 2:
            sense[-2:], lower[-2:] = EQUALITY, upper[-2:]
        x, flag = solve_arrays(H, f, A, upper, lower, sense)
        ref = daqp.solve(H, f, A, upper, lower, sense.copy())
        if flag != ref[2] or (flag == 1 and not np.array_equal(x, ref[0])):
            return False
    return True
