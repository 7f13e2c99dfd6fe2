"""The QP on a plant whose servos follow its commands over several periods: steps planned from
the last command (rounded to the resolution), synchronised sub-goals, the lead in the error."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from rcmplan import Iramis
from rcmplan.control.augmented import extended_task
from rcmplan.control.qp import QpSolver, synchronised_step
from rcmplan.control.qp_backends import solve
from rcmplan.control.qp_problem import SCALE, StepInput, build_step
from rcmplan.control.targets import rcm_target, solve_pose
from rcmplan.exceptions import InvalidInputError
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.sim import KinematicPlant


class ServoPlant:
    """What the QP reads of a servo plant: its last command and its resolution."""

    exact_commands = False

    def __init__(self, command: np.ndarray, resolution: float = 1e-9) -> None:
        self.command = command
        self.actuator_resolution = np.array([resolution] * 5 + [1e-6])


Scene = tuple[Any, np.ndarray, float, np.ndarray]


@pytest.fixture
def scene(robot: Iramis) -> Scene:
    """(eye, q at p3, lambda there, the RCM target of p4 seen from the trocar)."""
    eye = default_eye(robot)
    pts = default_points(eye)
    start = solve_pose(robot, rcm_target(pts.p3, eye.port))
    return eye, start.q, start.lam, rcm_target(pts.p4, eye.port)


def test_a_plant_with_exact_commands_leaves_the_qp_as_it_was(robot: Iramis, scene: Scene) -> None:
    eye, q, lam, target = scene
    plain = QpSolver(robot, eye)
    served = QpSolver(robot, eye, servo=KinematicPlant(robot))
    assert served.servo is None
    np.testing.assert_array_equal(
        plain.error(robot, q, lam, target), served.error(robot, q, lam, target)
    )


def test_steps_are_planned_from_the_rounded_last_command_within_its_speed_window(
    robot: Iramis, scene: Scene
) -> None:
    eye, q, lam, target = scene
    s = robot.actuators_from_joints(q)
    pts = default_points(eye)
    ahead = pts.p3 + 0.2 * (pts.p4 - pts.p3)  # the command leads, the RCM held there too
    command = robot.actuators_from_joints(solve_pose(robot, rcm_target(ahead, eye.port)).q)
    assert np.abs(command - s)[:5].max() > 100e-6  # the measured sliders lag far behind
    plant = ServoPlant(command)
    qp = QpSolver(robot, eye, servo=plant)
    rounded = np.round(command / plant.actuator_resolution) * plant.actuator_resolution
    np.testing.assert_allclose(
        robot.actuators_from_joints(qp.planned_joints(robot, q)), rounded, rtol=0, atol=1e-15
    )
    e = qp.error(robot, q, lam, target)
    dq, _ = qp.step(robot, q, lam, target, e)
    q_new = q.copy()
    q_new[:5] += dq
    moved = robot.actuators_from_joints(q_new) - rounded
    window = robot.speed * qp.dt
    assert np.all(np.abs(moved[:5]) <= window[:5] * (1 + 1e-9))
    assert np.abs(moved[:5]).max() > 0.5 * window[0]  # the target is far: it moves


def test_the_error_adds_the_commands_lead_over_the_measured_pose(
    robot: Iramis, scene: Scene
) -> None:
    eye, q, _, target = scene
    goal = solve_pose(robot, target)
    command = robot.actuators_from_joints(goal.q)  # the command is at the target already
    qp = QpSolver(robot, eye, servo=ServoPlant(command, resolution=1e-15))
    at_goal = qp.error(robot, goal.q, goal.lam, target)
    assert np.abs(at_goal).max() < 1e-9  # arrived: nothing left
    lagging = qp.error(robot, q, goal.lam, target)  # the measured pose is still at p3
    expected = target - extended_task(robot, q, goal.lam)
    np.testing.assert_allclose(lagging, expected, rtol=0, atol=1e-9)


def test_a_synchronised_sub_goal_fits_the_speed_window_and_moves_along_the_error(
    robot: Iramis, scene: Scene
) -> None:
    eye, q, lam, target = scene
    qp = QpSolver(robot, eye)
    e = qp.task_error(robot, q, lam, target)
    inp = StepInput(q, lam, target, e, qp.K, qp.damping, qp.dt, qp.weights)
    step = build_step(robot, inp, qp.rows, qp.bounds)
    sub = synchronised_step(robot, step, qp.dt)
    x_free = -np.linalg.solve(step.problem.P, step.problem.q)
    x_sub = -np.linalg.solve(sub.problem.P, sub.problem.q)
    window = robot.speed[:5] * qp.dt / SCALE
    assert np.abs(x_free[:5] / window).max() > 1.0  # the step alone would leave the window
    assert np.abs(x_sub[:5] / window).max() == pytest.approx(1.0)
    np.testing.assert_allclose(x_sub / np.linalg.norm(x_sub), x_free / np.linalg.norm(x_free))
    result = solve(sub.problem)  # and the QP itself stays within it
    assert np.all(np.abs(result.x[:5]) <= window * (1 + 1e-9))


def test_a_sub_goal_within_the_window_is_the_step_itself(robot: Iramis, scene: Scene) -> None:
    eye, q, lam, _ = scene
    near = extended_task(robot, q, lam) + np.array([1e-6, 0, 0, 0, 0, 0])
    qp = QpSolver(robot, eye)
    e = qp.task_error(robot, q, lam, near)
    inp = StepInput(q, lam, near, e, qp.K, qp.damping, qp.dt, qp.weights)
    step = build_step(robot, inp, qp.rows, qp.bounds)
    assert synchronised_step(robot, step, qp.dt) is step


def test_a_servo_resolution_of_the_wrong_length_is_refused_naming_it(
    robot: Iramis, scene: Scene
) -> None:
    plant = ServoPlant(robot.home_actuators.copy())
    plant.actuator_resolution = plant.actuator_resolution[:5]  # one per actuator but q5's
    with pytest.raises(InvalidInputError, match=r"servo\.actuator_resolution.*shape \(6,\)"):
        QpSolver(robot, scene[0], servo=plant)
