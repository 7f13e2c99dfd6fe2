"""Curved-needle control: the task X_c = (tip, roll, RCM), pinv and DLS, lateral targets."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rcmplan.control.curved import (
    CURVED_TASKS,
    CurvedDlsSolver,
    CurvedPinvSolver,
    NeedleRoll,
    task_jacobian,
)
from rcmplan.control.curved_targets import lateral_target, solve_curved_pose
from rcmplan.control.phase import LoopSettings, Phase
from rcmplan.control.runner import ReferenceRunner
from rcmplan.control.solvers import PinvSolver
from rcmplan.controller import Controller
from rcmplan.exceptions import InvalidInputError, UnreachableTargetError
from rcmplan.robot.curved import CurvedTipRobot, curved_robot
from rcmplan.robot.curved_needle import CurvedNeedle
from rcmplan.robot.registry import make_robot
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.scene.procedures import injection
from rcmplan.sim.kinematic import KinematicPlant

from fd import fd_jacobian


def _curved(name: str, arc_angle: float = 0.4) -> CurvedTipRobot:
    base = make_robot(name)
    return curved_robot(base, CurvedNeedle(base.needle_length, 12e-3, arc_angle))


def _lateral(robot: CurvedTipRobot):
    """A start pose (tip at p3) and a lateral target at p4 tilted sideways."""
    eye = default_eye(robot)
    pts = default_points(eye)
    c = eye.port
    side = np.cross(eye.axis, [0.0, 0.0, 1.0])
    target = lateral_target(robot, pts.p4, pts.p4 - c + 0.02 * side, c, 1.0)
    start = np.array([*pts.p3, robot.roll(robot.home), *c])
    return start, target


def test_the_roll_task_jacobian_equals_finite_differences(rng) -> None:
    robot = _curved("ur5")
    act = list(robot.active)
    q0 = robot.home + 0.05 * rng.standard_normal(6)

    def f(x: np.ndarray) -> np.ndarray:
        q = q0.copy()
        q[act] = x[:-1]
        return NeedleRoll().value(robot, q, float(x[-1]))

    J = NeedleRoll().jacobian(robot, q0, 0.5)
    assert pytest.approx(fd_jacobian(f, np.append(q0[act], 0.5)), abs=2e-7) == J


@pytest.mark.parametrize("name", ["iramis", "ur5"])
def test_the_curved_task_is_square_and_regular_at_a_lateral_pose(name) -> None:
    robot = _curved(name)
    _, target = _lateral(robot)
    pose = solve_curved_pose(robot, target.x)
    J = task_jacobian(CURVED_TASKS, robot, pose.q, pose.lam)
    assert J.shape == (7, 7)
    sv = np.linalg.svd(J, compute_uv=False)
    assert sv[-1] / sv[0] > 1e-4


@pytest.mark.parametrize(
    "name, solver", [("iramis", CurvedPinvSolver()), ("iramis", CurvedDlsSolver()),
                     ("ur5", CurvedPinvSolver()), ("ur5", CurvedDlsSolver())],
)  # fmt: skip
def test_pinv_and_dls_reach_a_lateral_target_holding_the_rcm(name, solver) -> None:
    robot = _curved(name)
    start, target = _lateral(robot)
    plant = KinematicPlant(robot)
    plant.reset(robot.actuators_from_joints(solve_curved_pose(robot, start).q))
    steps = 400
    k = np.linspace(0.0, 1.0, steps + 1)[1:, None]
    ctl = Controller(plant, solver, settings=LoopSettings(rcm_bound=1e-6))
    ctl.run([Phase("visit", start + k * (target.x - start))])
    q = robot.joints_from_actuators(plant.read_actuators())
    assert (
        np.linalg.norm(robot.tip(q) - target.x[:3]) <= 2e-8
    )  # the loop tolerance, 1e-8 m per axis
    assert math.acos(min(1.0, float(robot.tip_direction(q) @ target.direction))) <= 1e-6


def test_the_qp_reaches_a_lateral_target_within_its_rcm_tolerance() -> None:
    pytest.importorskip("qpsolvers")
    from rcmplan.control.qp import make_qp

    robot = _curved("iramis")
    start, target = _lateral(robot)
    plant = KinematicPlant(robot)
    plant.reset(robot.actuators_from_joints(solve_curved_pose(robot, start).q))
    k = np.linspace(0.0, 1.0, 101)[1:, None]
    solver = make_qp(robot)
    assert solver.tolerance().shape == (7,)
    ctl = Controller(plant, solver, settings=LoopSettings(rcm_bound=1e-6))
    log = ctl.run([Phase("visit", start + k * (target.x - start))])
    q = robot.joints_from_actuators(plant.read_actuators())
    assert np.linalg.norm(robot.tip(q) - target.x[:3]) <= 2e-8
    assert math.acos(min(1.0, float(robot.tip_direction(q) @ target.direction))) <= 1e-6
    assert np.nanmax(np.linalg.norm(log.rcm_deviation(), axis=1)) <= 0.5e-6 + 1e-9


def test_a_direction_the_needle_cannot_take_raises_naming_the_angles() -> None:
    robot = _curved("iramis")
    eye = default_eye(robot)
    p4 = default_points(eye).p4
    with pytest.raises(UnreachableTargetError, match="rad from the trocar-to-tip line"):
        lateral_target(robot, p4, p4 - eye.port, eye.port, 0.01)  # along the line: beta away


def test_a_tip_too_near_the_trocar_for_the_arc_raises() -> None:
    robot = _curved("iramis")
    c = default_eye(robot).port
    with pytest.raises(UnreachableTargetError, match="shaft's end"):
        lateral_target(robot, c + [-1e-3, 0.0, 0.0], [-1.0, 0.0, 0.0], c, 1.0)


def test_curved_solvers_refuse_gains_out_of_range_and_straight_needles() -> None:
    with pytest.raises(InvalidInputError, match="seven gains"):
        CurvedPinvSolver(K=(1.0,) * 6 + (2.0,))
    with pytest.raises(InvalidInputError, match="curved needle"):
        NeedleRoll().value(_curved("iramis", 0.0), np.zeros(6), 0.5)


def test_a_needle_with_alpha_zero_gives_the_straight_needles_records() -> None:
    logs = []
    for robot in (make_robot("iramis"), _curved("iramis", 0.0)):
        eye = default_eye(robot)
        plant = KinematicPlant(robot)
        plant.reset(robot.home_actuators)
        ctl = Controller(plant, PinvSolver(), runner=ReferenceRunner())
        logs.append(ctl.run(injection(robot, eye, default_points(eye), visits=("p4",))))
    for key in ("sliders", "joints", "lam", "tip", "rcm", "error"):
        assert np.array_equal(getattr(logs[0], key), getattr(logs[1], key), equal_nan=True)


def test_a_roll_beyond_the_joint_travel_is_refused_naming_the_slider_and_its_range() -> None:
    robot = _curved("iramis")
    start, _ = _lateral(robot)
    pose = solve_curved_pose(robot, start)
    q = pose.q.copy()
    q[5] = math.pi - 1e-3  # near q5's travel end, then ask for 2 mrad more
    target = np.array([*robot.tip(q), robot.roll(q), *start[4:]])
    seed = solve_curved_pose(robot, target, q).q
    beyond = target.copy()
    beyond[3] = math.pi + 1e-3 - 2.0 * math.pi  # the same roll, 2 mrad further round
    with pytest.raises(UnreachableTargetError, match=r"q5 = 3.142.* beyond its travel \[-3.14159"):
        solve_curved_pose(robot, beyond, seed)


def test_the_qp_free_phases_on_a_curved_needle_hold_the_actuator_speed_and_travel() -> None:
    """The QP's free-space solver on a curved needle is the pose step shortened to speed x dt
    per actuator (the controller's and make_free_solver's choice); a plain pose step from the
    same state moves the actuators several times faster."""
    from rcmplan.control.curved import CurvedPoseSolver, LimitedPoseSolver
    from rcmplan.control.methods import make_free_solver
    from rcmplan.control.qp import make_qp

    robot = _curved("iramis")
    qp = make_qp(robot)
    free = make_free_solver(robot, None, qp)
    assert isinstance(free, LimitedPoseSolver) and free.dt == qp.dt
    assert isinstance(Controller(KinematicPlant(robot), qp).free_solver, LimitedPoseSolver)
    eye = default_eye(robot)
    start, _ = _lateral(robot)
    q = solve_curved_pose(robot, start).q
    far = np.array([*(default_points(eye).p3 + [0.0, 0.0, 3e-3]), start[3], *start[4:]])
    pose = CurvedPoseSolver()
    s = robot.actuators_from_joints(q)
    active = list(robot.active)
    moves = []
    for solver in (pose, free):
        dq, _ = solver.step(robot, q, 1.0, far, solver.error(robot, q, 1.0, far))
        q1 = q.copy()
        q1[active] += dq
        moves.append(np.abs(robot.actuators_from_joints(q1) - s))
    limit = robot.speed * qp.dt
    assert np.any(moves[0] > 2.0 * limit)  # the plain pose step outruns the actuators
    assert np.all(moves[1] <= limit * (1.0 + 1e-9))
    assert np.max(moves[1] / limit) == pytest.approx(1.0)  # at full speed, not stopped
