"""The QP controller: problem builder, limits held, typed failures, runs and constrained scenarios."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import minimize

from rcmplan import Iramis
from rcmplan.analysis.limits import violations
from rcmplan.control import DlsSolver, PinvSolver
from rcmplan.control.augmented import augmented_jacobian, extended_task
from rcmplan.control.methods import MethodSettings, make_solver
from rcmplan.control.qp import QpSolver, make_qp
from rcmplan.control.qp_backends import solve
from rcmplan.control.qp_limits import QpLimits
from rcmplan.control.qp_problem import (
    SCALE,
    QPProblem,
    StepInput,
    build_step,
    kinematics,
    task_jacobian,
    variable_map,
)
from rcmplan.control.targets import rcm_target, solve_pose
from rcmplan.controller import Controller
from rcmplan.exceptions import InvalidInputError, QPError, RcmplanError, UnreachableTargetError
from rcmplan.robot.iramis import IramisParameters
from rcmplan.scene.constrained import near_slider_limit
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.scene.procedures import injection, spiral
from rcmplan.sim import KinematicPlant


@pytest.fixture
def eye(robot: Iramis):  # type: ignore[no-untyped-def]
    return default_eye(robot)


def state_at(robot: Iramis, eye, point):  # type: ignore[no-untyped-def]
    """(q, lam, target) with the robot exactly at the RCM target of `point`."""
    target = rcm_target(point, eye.port)
    pose = solve_pose(robot, target)
    return pose.q, pose.lam, target


def step_input(solver: QpSolver, q, lam, target) -> StepInput:  # type: ignore[no-untyped-def]
    e = solver.task_error(solver.robot, q, lam, target)
    return StepInput(q, lam, target, e, solver.K, solver.damping, solver.dt, solver.weights)


def built(solver: QpSolver, q, lam, target):  # type: ignore[no-untyped-def]
    """The solver's QP at (q, lam) towards target, from its limits."""
    return build_step(solver.robot, step_input(solver, q, lam, target), solver.rows, solver.bounds)


# --- the problem builder ---------------------------------------------------------------------
def test_variable_map_matches_finite_differences_of_the_pcjm(robot: Iramis) -> None:
    q = np.array([0.003, 0.3, -0.002, -0.4, 0.02, 0.0])
    s = robot.actuators_from_joints(q)
    h = 1e-7
    fd = np.array(
        [
            (robot.joints_from_actuators(s + h * e) - robot.joints_from_actuators(s - h * e))
            / (2 * h)
            for e in np.eye(6)
        ]
    ).T
    assert np.allclose(variable_map(robot, q)[:5, :5], fd[:5, :5], atol=1e-6)


def test_task_jacobian_is_the_augmented_jacobian_through_the_slider_map(robot: Iramis) -> None:
    q = np.array([0.003, 0.3, -0.002, -0.4, 0.02, 0.0])
    kin = kinematics(robot, q, 0.7)
    assert np.allclose(
        task_jacobian(kin, robot.needle_angles_jacobian(q)),
        augmented_jacobian(robot, q, 0.7) @ variable_map(robot, q),
        atol=1e-12,
    )


def test_problem_has_six_variables_and_the_listed_rows(robot: Iramis, eye) -> None:  # type: ignore[no-untyped-def]
    q, lam, target = state_at(robot, eye, default_points(eye).p3)
    p = built(make_qp(robot, eye), q, lam, target).problem
    assert p.P.shape == (6, 6) and np.allclose(p.P, p.P.T)
    assert np.all(np.linalg.eigvalsh(p.P) > 0)
    assert p.G.shape == (4 + 1 + 2, 6)  # RCM box (2 normals x 2 sides), retina, singular x2
    assert p.A.shape == (0, 6) and p.lb.shape == p.ub.shape == (6,)
    speed = robot.speed[:5] * 1e-3 / SCALE
    assert np.allclose(p.ub[:5], speed) and np.allclose(p.lb[:5], -speed)


def test_equality_rcm_gives_two_equality_rows_and_no_eye_gives_no_retina_row(
    robot: Iramis, eye
) -> None:  # type: ignore[no-untyped-def]
    q, lam, target = state_at(robot, eye, default_points(eye).p3)
    solver = make_qp(robot, None, rcm_tolerance_um=0.0)
    p = built(solver, q, lam, target).problem
    assert p.A.shape == (2, 6) and p.G.shape == (2, 6)


def test_lambda_at_one_cannot_grow(robot: Iramis, eye) -> None:  # type: ignore[no-untyped-def]
    q, _, target = state_at(robot, eye, default_points(eye).p3)
    p = built(make_qp(robot, eye), q, 1.0, target).problem
    assert p.ub[5] == 0.0 and p.lb[5] < 0.0


# --- steps --------------------------------------------------------------------------------------
def test_task_already_satisfied_gives_zero_motion(robot: Iramis, eye) -> None:  # type: ignore[no-untyped-def]
    q, lam, target = state_at(robot, eye, default_points(eye).p3)
    solver = make_qp(robot, eye)
    e = solver.error(robot, q, lam, target)
    dq, dlam = solver.step(robot, q, lam, target, e)
    assert np.max(np.abs(e)) < 1e-12 and np.max(np.abs(dq)) < 1e-12 and abs(dlam) < 1e-12


def test_far_target_moves_a_slider_exactly_at_its_speed_limit(robot: Iramis, eye) -> None:  # type: ignore[no-untyped-def]
    pts = default_points(eye)
    q, lam, _ = state_at(robot, eye, pts.p3)
    target = rcm_target(pts.p4, eye.port)
    solver = make_qp(robot, eye)
    dq, _ = solver.step(robot, q, lam, target, solver.error(robot, q, lam, target))
    q_new = q.copy()
    q_new[:5] += dq
    ds = np.abs(robot.actuators_from_joints(q_new) - robot.actuators_from_joints(q))[:5]
    assert np.max(ds / (robot.speed[:5] * 1e-3)) == pytest.approx(1.0, abs=1e-9)


def test_singular_margin_stops_q1_at_its_floor(robot: Iramis, eye) -> None:  # type: ignore[no-untyped-def]
    floor = math.cos(0.12)
    solver = make_qp(robot, None, singular_margin=floor, singular_gain=1.0)
    q = np.array([0.0, 0.05, 0.0, 0.0, 0.01, 0.0])
    lam = 0.9
    target = extended_task(robot, q, lam)
    target[1] = 0.3  # ask for q1 = 0.3 rad, beyond the floor's 0.12 rad
    for _ in range(3000):
        e = solver.error(robot, q, lam, target)
        if np.all(np.abs(e) <= solver.tolerance()):
            break
        dq, dlam = solver.step(robot, q, lam, target, e)
        q[:5] += dq
        lam += dlam
    else:
        pytest.fail("the QP did not settle at its closest feasible point")
    assert math.cos(q[1]) >= floor - 1e-9
    assert q[1] == pytest.approx(0.12, abs=1e-6)


# --- failures and bad input -------------------------------------------------------------------
def infeasible_problem() -> QPProblem:
    z = np.zeros(0)
    return QPProblem(np.eye(2), np.zeros(2), np.array([[1.0, 0.0]]), np.array([-5.0]),
                     np.zeros((0, 2)), z, np.zeros(2), np.ones(2))  # fmt: skip


@pytest.mark.parametrize("backend", ["daqp", "quadprog"])
def test_infeasible_qp_raises_qperror_carrying_problem_and_result(backend: str) -> None:
    problem = infeasible_problem()
    with pytest.raises(QPError) as info:
        solve(problem, backend)
    assert info.value.problem is problem
    assert backend == "quadprog" or info.value.result[2] == -1  # daqp's infeasible flag


def test_inconsistent_slider_travel_is_refused_before_motion(eye) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(InvalidInputError, match="slider travel"):
        params = replace(IramisParameters(), slider_lower=(0.01, -0.04, -0.04, -0.04, -0.01, -3.0),
                         slider_upper=(0.01, 0.04, 0.04, 0.04, 0.05, 3.0))  # fmt: skip
        make_qp(Iramis(params), eye)


def test_negative_slider_speed_is_refused(eye) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(InvalidInputError, match="slider speed"):
        params = replace(IramisParameters(), slider_speed=(0.01, -0.01, 0.01, 0.01, 0.01, 1.0))
        make_qp(Iramis(params), eye)


def test_rcm_tolerance_larger_than_the_trocar_radius_is_refused(robot: Iramis, eye) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(InvalidInputError, match="trocar radius"):
        make_qp(robot, eye, rcm_tolerance_um=500.0)


def test_unknown_option_and_solver_are_refused_with_the_valid_choices(robot: Iramis) -> None:
    with pytest.raises(InvalidInputError, match="travel_margin_mm"):
        make_qp(robot, None, travel_margin=1.0)
    with pytest.raises(InvalidInputError, match="daqp"):
        make_qp(robot, None, solver="cvxopt")


def test_target_beyond_the_retina_is_refused_before_motion(robot: Iramis, eye) -> None:  # type: ignore[no-untyped-def]
    pts = default_points(eye)
    beyond = eye.port + 1.05 * (pts.p4 - eye.port)
    solver = make_qp(robot, eye)
    q, lam, _ = state_at(robot, eye, pts.p3)
    with pytest.raises(UnreachableTargetError, match="beyond the retina"):
        solver.error(robot, q, lam, rcm_target(beyond, eye.port))


def test_make_solver_builds_the_qp_from_method_settings(robot: Iramis, eye) -> None:  # type: ignore[no-untyped-def]
    cfg = MethodSettings(extra={"travel_margin_mm": 1.0, "solver": "quadprog"})
    solver = make_solver("qp", cfg, robot, eye=eye, dt=2e-3)
    assert isinstance(solver, QpSolver) and solver.backend == "quadprog"
    assert solver.limits.travel_margin == pytest.approx(1e-3) and solver.dt == 2e-3


# --- runs on the kinematic plant ---------------------------------------------------------------
def final_tip_errors(log) -> list[float]:  # type: ignore[no-untyped-def]
    errs = []
    for pid in range(len(log.phase_names)):
        i = np.flatnonzero(log.phase == pid)[-1]
        errs.append(float(np.linalg.norm(log.tip[i] - log.target_tip[i])))
    return errs


@pytest.mark.parametrize("procedure", [injection, spiral])
def test_default_procedures_hold_the_rcm_within_1um_and_reach_every_phase_end(
    robot: Iramis, eye, procedure
) -> None:  # type: ignore[no-untyped-def]
    log = Controller(KinematicPlant(robot), make_qp(robot, eye)).run(
        procedure(robot, eye, default_points(eye))
    )
    rcm = ~np.isnan(log.trocar[:, 0])
    assert np.max(np.linalg.norm(log.rcm_deviation()[rcm], axis=1)) <= 1e-6
    assert max(final_tip_errors(log)) <= 1e-6
    assert violations(log, robot, eye).total == 0


# --- constrained scenarios ---------------------------------------------------------------------
def run(robot: Iramis, scene, solver):  # type: ignore[no-untyped-def]
    try:
        return Controller(KinematicPlant(robot), solver).run(scene.phases), None
    except RcmplanError as exc:
        return exc.log, exc


@pytest.mark.parametrize("scenario", ["near_slider_limit", "grazing_spiral"])
def test_pinv_and_dls_break_a_limit_where_the_qp_holds_every_one(
    robot: Iramis, scenario: str
) -> None:
    from rcmplan.scene import constrained

    scene = getattr(constrained, scenario)(robot)
    for solver in (PinvSolver(), DlsSolver()):
        log, error = run(robot, scene, solver)
        v = violations(log, robot, scene.eye)
        assert error is not None or (v.travel if scenario == "near_slider_limit" else v.retina) > 0
    log, error = run(robot, scene, make_qp(robot, scene.eye))
    assert error is None
    assert violations(log, robot, scene.eye).total == 0
    assert max(final_tip_errors(log)[-3:]) <= 1e-6  # back on the path after the limit


def weighted_task_error(z: np.ndarray, robot: Iramis, target: np.ndarray, w: np.ndarray) -> float:
    q = np.append(z[:5], 0.0)
    return float(np.sum((w * (target - extended_task(robot, q, z[5])) / SCALE) ** 2))


def test_near_a_slider_limit_the_qp_ends_at_the_closest_feasible_point(robot: Iramis) -> None:
    scene = near_slider_limit(robot)
    log, error = run(robot, scene, make_qp(robot, scene.eye))
    assert error is None
    i = np.flatnonzero(log.phase == log.phase_names.index("p3-p4"))[-1]
    lim = QpLimits()
    assert robot.upper[3] - log.sliders[i, 3] == pytest.approx(lim.travel_margin, abs=1e-12)
    target = rcm_target(scene.points.p4, scene.eye.port)
    w = np.array([1.0, lim.angle_weight, lim.angle_weight, 1.0, 1.0, 1.0])
    z0 = np.append(log.joints[i, :5], log.lam[i])

    def cons(u: np.ndarray) -> np.ndarray:  # soft travel end and RCM tolerance, both >= 0, um
        z = z0 + SCALE * u
        q = np.append(z[:5], 0.0)
        s = robot.actuators_from_joints(q)
        d = robot.needle_point(q, z[5]) - target[3:]
        a = robot.needle_axis(q)
        line = np.linalg.norm(d - (d @ a) * a)
        return np.array(
            [
                (robot.upper[3] - lim.travel_margin - s[3]) / SCALE,
                (lim.rcm_tolerance - line) / SCALE,
            ]
        )

    def f(u: np.ndarray) -> float:  # in um^2, variables in um (or 1e-6 of lambda) from the QP's end
        return weighted_task_error(z0 + SCALE * u, robot, target, w)

    best = minimize(f, np.zeros(6), method="SLSQP", constraints={"type": "ineq", "fun": cons},
                    options={"ftol": 1e-12, "maxiter": 1000})  # fmt: skip
    assert best.success and np.all(cons(best.x) >= -1e-3)
    # within 1 %: the QP's RCM box (tol/sqrt(2) per normal axis) lies inside SLSQP's disc
    assert f(np.zeros(6)) <= best.fun * 1.01
    tip_best = robot.needle_point(np.append((z0 + SCALE * best.x)[:5], 0.0), 1.0)
    assert np.linalg.norm(log.tip[i] - tip_best) <= 1e-6
    assert np.linalg.norm(log.tip[i] - log.target_tip[i]) > 1e-6  # the target itself is infeasible


def test_grazing_path_rides_the_retina_margin_and_never_enters_it(robot: Iramis) -> None:
    from rcmplan.scene.constrained import grazing_spiral

    scene = grazing_spiral(robot)
    log, error = run(robot, scene, make_qp(robot, scene.eye))
    assert error is None
    sp = log.phase == log.phase_names.index("spiral")
    d = scene.eye.retina_radius - np.linalg.norm(log.tip[sp] - scene.eye.center, axis=1)
    margin = QpLimits().retina_margin
    assert np.min(d) >= margin - 1e-8
    assert np.sum(np.abs(d - margin) < 1e-8) > 0  # the margin was active


@pytest.mark.parametrize(
    ("name", "builder"),
    [("near-slider-limit", "near_slider_limit"), ("grazing-spiral", "grazing_spiral")],
)
def test_scenario_files_give_the_python_scenarios_targets(
    robot: Iramis, name: str, builder: str
) -> None:
    from rcmplan.scene import constrained
    from rcmplan.scene.scenario import load_scenario

    scenario = load_scenario(name)
    assert scenario.method == "qp"
    reference = getattr(constrained, builder)(robot).phases
    phases = scenario.phases(robot)
    assert [p.name for p in phases] == [p.name for p in reference]
    for a, b in zip(phases, reference, strict=True):
        if not callable(a.targets):
            assert np.allclose(a.targets, b.targets, atol=1e-7)  # files give points to 1 nm
