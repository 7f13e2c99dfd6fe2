"""Objectives (a task with its target, gain and weight) as extra terms of the QP's cost, and the
Configuration they read."""

from __future__ import annotations

import numpy as np
import pytest

import rcmplan as rp
from rcmplan.control.limits.base import kinematics
from rcmplan.control.qp_problem import StepInput, build_step
from rcmplan.exceptions import InvalidInputError


@pytest.fixture(scope="module")
def ur5() -> rp.RobotModel:
    return rp.make_robot("ur5")


def test_the_configuration_caches_the_step_kinematics_and_integrates(ur5) -> None:  # type: ignore[no-untyped-def]
    cfg = rp.Configuration(ur5, ur5.home, 0.4)
    kin = cfg.kinematics
    assert cfg.kinematics is kin  # computed once
    np.testing.assert_array_equal(kin.tip, kinematics(ur5, ur5.home, 0.4).tip)
    dq = np.full(len(ur5.active), 1e-3)
    moved = cfg.integrate(dq, 0.1)
    np.testing.assert_allclose(moved.q[list(ur5.active)] - ur5.home[list(ur5.active)], dq)
    assert moved.lam == pytest.approx(0.5) and cfg.lam == 0.4  # a new configuration


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"lam": 1.5}, "lam"),
        ({"q": [0.0, 1.0]}, "q"),
        ({"robot": "ur5"}, "robot"),
    ],
)
def test_a_configuration_refuses_bad_state(ur5, kwargs, name: str) -> None:  # type: ignore[no-untyped-def]
    args = {"robot": ur5, "q": ur5.home, "lam": 0.5, **kwargs}
    with pytest.raises(InvalidInputError, match=name):
        rp.Configuration(args["robot"], args["q"], args["lam"])


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"gain": 2.0}, "gain"),
        ({"gain": [0.5, 0.5]}, "gain"),
        ({"weight": 0.0}, "weight"),
        ({"weight": float("nan")}, "weight"),
        ({"target": [[1.0]]}, "target"),
        ({"task": "posture"}, "task"),
    ],
)
def test_an_objective_refuses_bad_settings(kwargs, name: str) -> None:  # type: ignore[no-untyped-def]
    args = {"task": rp.Posture(), "target": np.zeros(6), **kwargs}
    with pytest.raises(InvalidInputError, match=name):
        rp.Objective(**args)


def test_an_objective_of_the_wrong_size_is_refused_at_its_first_use(ur5) -> None:  # type: ignore[no-untyped-def]
    cfg = rp.Configuration(ur5, ur5.home, 0.5)
    with pytest.raises(InvalidInputError, match="target"):
        rp.Objective(rp.Posture(), np.zeros(3)).cost(cfg)


def test_an_objective_adds_its_weighted_least_squares_term(ur5) -> None:  # type: ignore[no-untyped-def]
    """H and f of the term are those of 1/2 |W (J T x SCALE - K e)|^2 / SCALE^2."""
    active = list(ur5.active)
    cfg = rp.Configuration(ur5, ur5.home + 0.01, 0.5)
    obj = rp.Objective(rp.Posture(), ur5.home[active], gain=0.3, weight=2.0)
    H, f = obj.cost(cfg)
    J = rp.Posture().jacobian(ur5, cfg.q, cfg.lam) @ cfg.kinematics.T
    e = ur5.home[active] - cfg.q[active]
    np.testing.assert_allclose(H, 4.0 * J.T @ J, rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(f, -4.0 * J.T @ (0.3 * e) / 1e-6, rtol=1e-12)


def test_a_posture_objective_pulls_a_redundant_arm_while_the_needle_holds() -> None:
    """Panda moves six joints and lambda for the six X_ext rows: at its target the plain QP
    takes no step; with a posture objective the step moves the arm towards the posture, under
    the same limits."""
    arm = rp.make_robot("panda")
    eye = rp.default_eye(arm)
    target = rp.rcm_target(rp.default_points(eye).p4, eye.port)
    pose = rp.solve_pose(arm, target)
    active = list(arm.active)
    posture = pose.q[active] + np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.05])
    plain = rp.QpSolver(arm, eye)
    pulled = rp.QpSolver(arm, eye, objectives=(rp.Objective(rp.Posture(), posture, 0.5, 1e-4),))
    steps = []
    for solver in (plain, pulled):
        e = solver.task_error(arm, pose.q, pose.lam, target)
        inp = StepInput(pose.q, pose.lam, target, e, solver.K, solver.damping, solver.dt,
                        solver.weights)  # fmt: skip
        problem = build_step(arm, inp, solver.rows, solver.bounds, solver.objectives)
        steps.append(problem)
        dq, _ = solver.step(arm, pose.q, pose.lam, target, e)
        if solver is pulled:
            assert np.dot(dq, posture - pose.q[active]) > 0.0  # towards the posture
        else:
            assert np.linalg.norm(dq) < 1e-9  # at its target: nothing to do
    assert not np.allclose(steps[0].problem.q, steps[1].problem.q)
    assert np.array_equal(steps[0].problem.G, steps[1].problem.G)  # the same limits
