"""DAQP's C solver called from compiled code equals `daqp.solve`, and fails typed."""

from __future__ import annotations

import ctypes
import inspect
from importlib import metadata

import daqp
import numba  # noqa: F401  (the `fast` extra: without it these tests fail, they do not skip)
import numpy as np
import pytest

from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled import daqp_c
from rcmplan.control.qp_problem import QPProblem
from rcmplan.exceptions import QPError

SUPPORTED = metadata.version("daqp") in daqp_c.ABI_VERSIONS


def test_the_installed_daqp_is_bound_or_the_compiled_qp_is_not_used() -> None:
    assert daqp_c.abi_ok() is SUPPORTED
    if not SUPPORTED:
        assert fast_cache.qp_loop() is None


@pytest.mark.skipif(not SUPPORTED, reason="DAQP version without a copied layout: unused")
def test_default_settings_are_the_ones_daqp_solve_passes() -> None:
    settings = daqp_c.DAQPSettings.from_buffer_copy(daqp_c.default_settings().tobytes())
    keywords = inspect.signature(daqp.solve).parameters
    for name, _ in daqp_c.DAQPSettings._fields_:
        assert getattr(settings, name) == keywords[name].default, name
        assert getattr(settings, name) == daqp_c.HEADER_DEFAULTS[name], name


def test_structures_have_the_c_layout_of_the_header() -> None:
    # int n, m, ms; 7 pointers; int nh, problem_type (x86-64 and aarch64: 8-byte pointers).
    assert ctypes.sizeof(daqp_c.DAQPProblem) == 80 and daqp_c.DAQPProblem.nh.offset == 72
    assert ctypes.sizeof(daqp_c.DAQPSettings) == 136 and daqp_c.DAQPSettings.presolve.offset == 132
    assert ctypes.sizeof(daqp_c.DAQPResult) == 64 and daqp_c.DAQPResult.exitflag.offset == 32


def random_qp(rng: np.random.Generator, n: int, n_ineq: int, n_eq: int) -> tuple:
    """daqp.solve's arguments of a random strictly convex QP: n bounds, then rows."""
    M = rng.normal(size=(n, n))
    H = M @ M.T + 1e-2 * np.eye(n)
    A = rng.normal(size=(n_ineq + n_eq, n))
    x0 = rng.uniform(-0.5, 0.5, n)  # a point every constraint admits: feasible by construction
    upper = np.concatenate([rng.uniform(0.5, 2.0, n), A[:n_ineq] @ x0 + rng.uniform(0, 1, n_ineq),
                            A[n_ineq:] @ x0])  # fmt: skip
    lower = np.concatenate([-rng.uniform(0.5, 2.0, n), np.full(n_ineq, -1e30), A[n_ineq:] @ x0])
    sense = np.zeros(n + n_ineq + n_eq, dtype=np.int32)
    sense[n + n_ineq :] = daqp_c.EQUALITY
    return H, rng.normal(size=n) * 3.0, A, upper, lower, sense


@pytest.mark.skipif(not SUPPORTED, reason="DAQP version without a copied layout: unused")
def test_thousands_of_random_feasible_qps_solve_to_daqp_solves_x(
    rng: np.random.Generator,
) -> None:
    solved = 0
    for k in range(3000):
        n = 2 + k % 7
        H, f, A, upper, lower, sense = random_qp(rng, n, k % 5, k % 3 if k % 3 < n else 0)
        x, flag = daqp_c.solve_arrays(H, f, A, upper, lower, sense)
        ref_x, _, ref_flag, _ = daqp.solve(H, f, A, upper, lower, sense.copy())
        assert flag == ref_flag == 1
        np.testing.assert_array_equal(x, ref_x)  # the same C function on the same arrays
        solved += 1
    assert solved == 3000


@pytest.mark.skipif(not SUPPORTED, reason="DAQP version without a copied layout: unused")
def test_infeasible_qp_raises_qperror_naming_the_exit_flag() -> None:
    # x0 >= 1 and x0 + 0 x1 <= -1: no x satisfies both rows.
    problem = QPProblem(P=np.eye(2), q=np.zeros(2), G=np.array([[-1.0, 0.0], [1.0, 0.0]]),
                        h=np.array([-1.0, -1.0]), A=np.zeros((0, 2)), b=np.zeros(0),
                        lb=np.full(2, -10.0), ub=np.full(2, 10.0))  # fmt: skip
    with pytest.raises(QPError, match=r"daqp exit flag -1 \(infeasible\)") as info:
        daqp_c.solve_problem(problem)
    assert info.value.problem is problem
    assert daqp.solve(np.eye(2), np.zeros(2), problem.G, np.array([10, 10, -1, -1.0]),
                      np.array([-10, -10, -1e30, -1e30]))[2] == -1  # fmt: skip
