"""The step solves every solver and loop calls (`rcmplan.linalg`): each solves its equation,
on random systems, against numpy as the oracle; a singular system gives non-finite steps."""

from __future__ import annotations

import numpy as np
import pytest

from rcmplan import linalg

SHAPES = [(3, 5), (6, 6), (6, 7), (7, 7), (6, 9), (7, 8)]


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(7)


def test_lu_solve_equals_numpy_solve(rng: np.random.Generator) -> None:
    for n in (1, 3, 6, 7):
        M, b = rng.normal(size=(n, n)), rng.normal(size=n)
        W = np.vstack([M, b[None, :]])
        linalg.lu_solve(W, 0, n, n)
        np.testing.assert_allclose(W[n], np.linalg.solve(M, b), rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize(("rows", "cols"), SHAPES)
def test_damped_step_solves_the_damped_normal_equations(rows: int, cols: int,
                                                        rng: np.random.Generator) -> None:  # fmt: skip
    J, e, D = rng.normal(size=(rows, cols)), rng.normal(size=rows), 0.3
    d = linalg.step(J, e, D)
    np.testing.assert_allclose((J.T @ J + D * D * np.eye(cols)) @ d, J.T @ e, atol=1e-12)


@pytest.mark.parametrize(("rows", "cols"), SHAPES)
def test_undamped_step_is_the_minimum_norm_solution(rows: int, cols: int,
                                                    rng: np.random.Generator) -> None:  # fmt: skip
    J, e = rng.normal(size=(rows, cols)), rng.normal(size=rows)
    np.testing.assert_allclose(linalg.step(J, e), np.linalg.pinv(J) @ e, atol=1e-11)


@pytest.mark.parametrize(("rows", "cols"), SHAPES)
def test_pinv_step_solves_and_keeps_the_null_space_part(rows: int, cols: int,
                                                        rng: np.random.Generator) -> None:  # fmt: skip
    J, b, z = rng.normal(size=(rows, cols)), rng.normal(size=rows), rng.normal(size=cols)
    d = linalg.step(J, b, z=z)
    np.testing.assert_allclose(J @ d, b, atol=1e-11)
    J_pinv = np.linalg.pinv(J)
    null = np.eye(cols) - J_pinv @ J  # the step's null-space part is z's
    np.testing.assert_allclose(null @ d, null @ z, atol=1e-11)


def test_singular_systems_give_non_finite_steps() -> None:
    J = np.ones((3, 3))
    assert not np.isfinite(linalg.step(J, np.ones(3), z=np.zeros(3))).all()
    assert not np.isfinite(linalg.step(np.ones((3, 5)), np.ones(3))).all()
