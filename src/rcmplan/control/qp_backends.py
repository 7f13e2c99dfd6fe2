"""QP solver back ends: DAQP through its own API, the others through qpsolvers.

DAQP's own `daqp.solve` is called directly because on these 6-variable problems the qpsolvers
wrapper's checks and conversions cost more than the solve (benchmarks/bench_qp.py measures both).
A failed or infeasible solve raises QPError carrying the problem and the raw result.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.control.qp_problem import QPProblem
from rcmplan.exceptions import InvalidInputError, QPError, require_extra

BACKENDS = ("daqp", "daqp-qpsolvers", "quadprog", "proxqp", "osqp", "clarabel", "piqp")
DEFAULT_BACKEND = "daqp"
DAQP_EXIT = {
    1: "optimal",
    2: "soft optimal",
    -1: "infeasible",
    -2: "cycling",
    -3: "unbounded",
    -4: "iteration limit",
    -5: "nonconvex",
    -6: "overdetermined initial active set",
}
# Iterative solvers are run to tolerances near the active-set solvers' accuracy (x in um).
SETTINGS: dict[str, dict[str, Any]] = {
    "osqp": {"eps_abs": 1e-7, "eps_rel": 1e-7},
    "proxqp": {"eps_abs": 1e-9},
    "clarabel": {},
    "piqp": {},
    "quadprog": {},
    "daqp-qpsolvers": {},
}


class QpResult(NamedTuple):
    """A solution: x, the back end's name and its raw result."""

    x: FloatArray
    backend: str
    raw: Any


def check_backend(name: str) -> str:
    """Return name if it is a known back end, else raise."""
    if not isinstance(name, str) or name not in BACKENDS:
        raise InvalidInputError("backend", name, f"one of {BACKENDS}")
    return name


def solve(problem: QPProblem, backend: str = DEFAULT_BACKEND) -> QpResult:
    """Solve the problem with a back end; QPError if it fails or is infeasible."""
    if backend == "daqp":
        return solve_daqp(problem)
    return solve_qpsolvers(problem, check_backend(backend))


def daqp_arrays(p: QPProblem) -> tuple[FloatArray, FloatArray, FloatArray, Any]:
    """DAQP's (A, bupper, blower, sense): bounds first, then G x <= h, then A x = b."""
    n_g, n_a = p.G.shape[0], p.A.shape[0]
    A = np.vstack([p.G, p.A])
    upper = np.concatenate([p.ub, p.h, p.b])
    lower = np.concatenate([p.lb, np.full(n_g, -1e30), p.b])
    sense = np.zeros(p.lb.shape[0] + n_g + n_a, dtype=np.int32)
    sense[p.lb.shape[0] + n_g :] = 5  # equality
    return A, upper, lower, sense


def solve_daqp(problem: QPProblem) -> QpResult:
    """DAQP (dual active set) through its own API."""
    import daqp  # a core dependency

    A, upper, lower, sense = daqp_arrays(problem)
    x, fval, flag, info = daqp.solve(problem.P, problem.q, A, upper, lower, sense)
    if flag != 1:
        state = DAQP_EXIT.get(int(flag), "unknown exit flag")
        raise QPError(
            f"QP solve failed: daqp exit flag {flag} ({state})",
            problem=problem,
            result=(x, fval, flag, info),
        )
    return QpResult(np.asarray(x, dtype=float), "daqp", (x, fval, flag, info))


def solve_qpsolvers(problem: QPProblem, backend: str) -> QpResult:
    """Any other back end through qpsolvers' Problem / solve_problem."""
    qpsolvers = require_extra("qpsolvers", "qp")
    name = "daqp" if backend == "daqp-qpsolvers" else backend
    p = problem
    qp = qpsolvers.Problem(
        p.P,
        p.q,
        p.G if p.G.shape[0] else None,
        p.h if p.G.shape[0] else None,
        p.A if p.A.shape[0] else None,
        p.b if p.A.shape[0] else None,
        p.lb,
        p.ub,
    )
    try:
        sol = qpsolvers.solve_problem(qp, solver=name, **SETTINGS[backend])
    except Exception as exc:  # a back end's own failure, re-raised typed with the problem
        raise QPError(f"QP solve failed in {name}: {exc}", problem=problem) from exc
    if not sol.found or sol.x is None or not np.all(np.isfinite(sol.x)):
        raise QPError(f"QP infeasible or unsolved by {name}", problem=problem, result=sol)
    return QpResult(np.asarray(sol.x, dtype=float), backend, sol)
