"""Step solvers: zero motion at the target, Newton and DLS steps, argument checks."""

from __future__ import annotations

import numpy as np
import pytest

from rcmplan import Iramis, linalg
from rcmplan.control.augmented import augmented_jacobian, extended_task
from rcmplan.control.solvers import DlsSolver, PinvSolver, TipSolver, Tolerance
from rcmplan.control.tasks import TIP_AND_RCM, stack_jacobian
from rcmplan.exceptions import InvalidInputError

Q = np.array([0.003, 0.1, -0.004, 0.15, 0.01, 0.0])


@pytest.mark.parametrize("solver", [PinvSolver(), PinvSolver(variant="thesis"), DlsSolver()])
def test_task_already_satisfied_gives_zero_motion(robot: Iramis, solver) -> None:
    target = extended_task(robot, Q, 0.8)
    e = solver.error(robot, Q, 0.8, target)
    assert np.all(np.abs(e) <= 1e-15)
    dq, dlam = solver.step(robot, Q, 0.8, target, e)
    assert np.all(dq == 0.0) and dlam == 0.0


def test_tip_solver_at_its_target_gives_zero_motion(robot: Iramis) -> None:
    target = robot.tip(Q)
    e = TipSolver().error(robot, Q, 1.0, target)
    dq, _ = TipSolver().step(robot, Q, 1.0, target, e)
    assert np.all(dq == 0.0)


def test_pinv_step_is_a_newton_step_with_quadratic_error(robot: Iramis) -> None:
    solver = PinvSolver()
    for h in (1e-3, 1e-4):
        target = extended_task(robot, Q, 0.8) + h * np.array([1, 1, 1, 0, 0, 0])
        dq, dlam = solver.step(robot, Q, 0.8, target, solver.error(robot, Q, 0.8, target))
        q1 = Q.copy()
        q1[:5] += dq
        after = np.abs(solver.error(robot, q1, 0.8 + dlam, target)).max()
        assert after < 10 * h * h  # second order in the step


def test_gain_k_scales_the_first_order_error(robot: Iramis) -> None:
    K = (0.5, 0.5, 0.5, 0.5, 0.5, 0.5)
    target = extended_task(robot, Q, 0.8) + 1e-6 * np.ones(6)
    solver = PinvSolver(K=K)
    e = solver.error(robot, Q, 0.8, target)
    dq, dlam = solver.step(robot, Q, 0.8, target, e)
    d = np.r_[dq, dlam]
    np.testing.assert_allclose(augmented_jacobian(robot, Q, 0.8) @ d, 0.5 * e, rtol=1e-9)


def test_dls_step_solves_the_damped_normal_equations(robot: Iramis) -> None:
    J = stack_jacobian(TIP_AND_RCM, robot, Q, 0.8)
    e = np.linspace(-1e-4, 1e-4, 6)
    D = 0.05
    d = linalg.step(J, e, D)
    np.testing.assert_allclose((J.T @ J + D * D * np.eye(6)) @ d, J.T @ e, atol=1e-15)


@pytest.mark.parametrize(
    "K", [(0, 1, 1, 1, 1, 1), (1, 1, 2.0, 1, 1, 1), (1, 10, 12, 1, 2, 2), (1,) * 5]
)
def test_gains_outside_zero_two_raise_and_explain(K) -> None:
    with pytest.raises(InvalidInputError, match=r"\(0, 2\)|shape"):
        PinvSolver(K=K)


@pytest.mark.parametrize("tol", [(0.0, 1e-8), (1e-8, -1.0), (np.nan, 1e-8)])
def test_zero_or_bad_tolerances_raise(tol) -> None:
    with pytest.raises(InvalidInputError, match="tolerance"):
        PinvSolver(tol=Tolerance(*tol))


@pytest.mark.parametrize("D", [0.0, -1.0, np.inf, 1e-12])
def test_damping_must_be_positive_and_resolvable(D) -> None:
    with pytest.raises(InvalidInputError, match="damping"):
        DlsSolver(damping=D)
