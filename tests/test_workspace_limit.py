"""The workspace bound: exact gradients of the box gaps, damper rows, and a QP that keeps the
tip in the box when the target lies outside it."""

from __future__ import annotations

import numpy as np
import pytest

from rcmplan.control.limits import StepInput, WorkspaceBound, kinematics
from rcmplan.control.limits.base import SCALE
from rcmplan.control.qp import QpSolver
from rcmplan.control.qp_limits import QpLimits
from rcmplan.control.targets import rcm_target, solve_pose
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.registry import make_robot
from rcmplan.scene.eye import default_eye, default_points, eye_frame

from fd import fd_jacobian


def box_about(eye, half: float = 2e-3, gain: float = 0.5) -> WorkspaceBound:
    R = eye_frame(eye)
    centre = (default_points(eye).p3 - eye.center) @ R  # p3 in the eye frame
    return WorkspaceBound(tuple(eye.center), tuple(map(tuple, R)), tuple(centre - half),
                          tuple(centre + half), gain)  # fmt: skip


STEPS = 800  # QP steps: enough to cross the box at the sliders' speed


@pytest.fixture(scope="module", params=["iramis", "ur5", "panda"])
def state(request: pytest.FixtureRequest):
    robot = make_robot(request.param)
    eye = default_eye(robot)
    target = rcm_target(default_points(eye).p3 + 0.3e-3, eye.port)
    pose = solve_pose(robot, target)
    inp = StepInput(pose.q, pose.lam, target, np.zeros(6), np.ones(6), 1e-4, 1e-3,
                    QpLimits().weights(6))  # fmt: skip
    return robot, eye, inp


def test_workspace_rows_are_the_gradients_of_the_gaps_to_the_faces(state) -> None:
    robot, eye, inp = state
    box = box_about(eye)
    kin = kinematics(robot, inp.q, inp.lam)
    active = list(robot.active)

    def gaps(x: np.ndarray) -> np.ndarray:
        s = robot.actuators_from_joints(inp.q)
        s[active] += x[:-1] * SCALE
        c = box.coordinates(robot.tip(robot.joints_from_actuators(s)))
        lo, hi = np.asarray(box.lower), np.asarray(box.upper)
        return np.ravel(np.column_stack([c - lo, hi - c])) / SCALE

    con = box.constraint(robot, inp, kin)
    assert con.G.shape == (6, kin.T.shape[1])
    assert pytest.approx(fd_jacobian(gaps, np.zeros(kin.T.shape[1]), 1e-3), abs=1e-6) == -con.G


def test_workspace_rows_let_each_gap_shrink_by_the_gain_at_most(state) -> None:
    robot, eye, inp = state
    box = box_about(eye, gain=0.25)
    kin = kinematics(robot, inp.q, inp.lam)
    c = box.coordinates(kin.tip)
    gaps = np.ravel(np.column_stack([c - np.asarray(box.lower), np.asarray(box.upper) - c]))
    assert box.constraint(robot, inp, kin).h == pytest.approx(0.25 * gaps / SCALE)


def test_a_qp_with_the_box_stops_the_tip_at_the_face(state) -> None:
    robot, eye, inp = state
    box = box_about(eye, half=0.5e-3)
    R = eye_frame(eye)
    outside = eye.center + R @ (np.asarray(box.upper) + [0.0, 0.0, 0.5e-3])  # past the z face
    target = rcm_target(outside, eye.port)
    solver = QpSolver(robot, eye, 1e-3, extra_limits=(box,))
    q, lam = inp.q.copy(), inp.lam
    active = list(robot.active)
    for _ in range(STEPS):
        e = solver.task_error(robot, q, lam, target)
        dq, dlam = solver.step(robot, q, lam, target, e)
        q[active] += dq
        lam += dlam
    depth = float(box.depth(robot.tip(q))[0])
    assert -1e-9 <= depth < 5e-6  # at the face, not past it
    free = QpSolver(robot, eye, 1e-3)
    q2, lam2 = inp.q.copy(), inp.lam
    for _ in range(STEPS):
        dq, dlam = free.step(robot, q2, lam2, target, free.task_error(robot, q2, lam2, target))
        q2[active] += dq
        lam2 += dlam
    assert box.depth(robot.tip(q2))[0] < -0.4e-3  # without the box the tip goes past it


def test_a_box_must_be_ordered_and_rotated_properly() -> None:
    eye = default_eye()
    R = eye_frame(eye)
    with pytest.raises(InvalidInputError, match="lower < upper"):
        WorkspaceBound(tuple(eye.center), tuple(map(tuple, R)), (0, 0, 0), (1, -1, 1))
    with pytest.raises(InvalidInputError, match="proper rotation"):
        WorkspaceBound(tuple(eye.center), tuple(map(tuple, -R)), (0, 0, 0), (1, 1, 1))


def test_a_cube_is_the_axis_aligned_box_of_its_half_width_about_its_centre() -> None:
    c = np.array([0.1, -0.2, 0.3])
    cube = WorkspaceBound.cube(c, 0.025, gain=0.4)
    assert cube == WorkspaceBound(tuple(c), tuple(map(tuple, np.eye(3))), (-0.025,) * 3,
                                  (0.025,) * 3, 0.4)  # fmt: skip
    corners = c + np.array([[0.025, -0.025, 0.0], [0.0, 0.0, 0.026]])
    assert cube.depth(corners) == pytest.approx([0.0, -0.001], abs=1e-15)
    for bad in (0.0, 2.0, np.nan):
        with pytest.raises(InvalidInputError, match=r"workspace\.half_width"):
            WorkspaceBound.cube(c, bad)
    with pytest.raises(InvalidInputError, match=r"workspace\.center"):
        WorkspaceBound.cube([0.0, 1.0], 0.01)
