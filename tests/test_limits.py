"""Limit objects: every row is the exact gradient of its quantity, on every shipped robot."""

from __future__ import annotations

import numpy as np
import pytest

from rcmplan.control.limits import (
    ActuatorLimit,
    RcmLimit,
    RetinaBarrier,
    SingularMargin,
    StepInput,
    TipSpeed,
    kinematics,
)
from rcmplan.control.limits.base import SCALE
from rcmplan.control.limits.rcm import normal_basis
from rcmplan.control.qp_limits import QpLimits
from rcmplan.control.targets import rcm_target, solve_pose
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.registry import make_robot
from rcmplan.scene.eye import default_eye, default_points

from fd import fd_jacobian


@pytest.fixture(scope="module", params=["iramis", "ur5", "panda"])
def state(request: pytest.FixtureRequest):
    robot = make_robot(request.param)
    eye = default_eye(robot)
    target = rcm_target(default_points(eye).p4, eye.port)
    pose = solve_pose(robot, target)
    inp = StepInput(pose.q, pose.lam, target, np.zeros(6), np.ones(6), 1e-4, 1e-3,
                    QpLimits().weights(6))  # fmt: skip
    return robot, eye, inp


def moved(robot, inp: StepInput, x: np.ndarray) -> tuple[np.ndarray, float]:
    """Joints and lambda after the step x (QP units) from the state."""
    active = list(robot.active)
    s = robot.actuators_from_joints(inp.q)
    s[active] += x[:-1] * SCALE
    return robot.joints_from_actuators(s), inp.lam + x[-1] * SCALE / robot.needle_length


def test_rcm_rows_are_the_gradient_of_the_normal_offset(state) -> None:
    robot, _, inp = state
    kin = kinematics(robot, inp.q, inp.lam)
    N = np.empty((2, 3))
    normal_basis(kin.axis, N)

    def offset(x: np.ndarray) -> np.ndarray:
        q, lam = moved(robot, inp, x)
        return N @ (robot.needle_point(q, lam) - inp.target[3:]) / SCALE

    G = RcmLimit().constraint(robot, inp, kin).G
    assert G[:2] == pytest.approx(fd_jacobian(offset, np.zeros(kin.T.shape[1]), 1e-3), abs=1e-6)
    assert G[2:] == pytest.approx(-G[:2], abs=0.0)


def test_retina_row_is_the_gradient_of_the_distance_to_the_retina(state) -> None:
    robot, eye, inp = state
    kin = kinematics(robot, inp.q, inp.lam)

    def distance(x: np.ndarray) -> np.ndarray:
        q, _ = moved(robot, inp, x)
        return np.array([eye.distance_to_retina(robot.tip(q)) / SCALE])

    G = RetinaBarrier(eye).constraint(robot, inp, kin).G
    assert G.shape[0] == 1
    assert pytest.approx(fd_jacobian(distance, np.zeros(kin.T.shape[1]), 1e-3), abs=1e-6) == -G


def test_singular_rows_are_the_gradients_of_the_singular_terms(state) -> None:
    robot, _, inp = state
    kin = kinematics(robot, inp.q, inp.lam)

    def terms(x: np.ndarray) -> np.ndarray:
        q, _ = moved(robot, inp, x)
        return robot.singular_terms(q)[0] / SCALE

    G = SingularMargin().constraint(robot, inp, kin).G
    fd = fd_jacobian(terms, np.zeros(kin.T.shape[1]), 1e-2)
    assert pytest.approx(fd, abs=1e-5 * max(1.0, float(np.abs(fd).max()))) == -G


def test_actuator_bounds_keep_every_actuator_within_speed_and_travel(state) -> None:
    robot, _, inp = state
    kin = kinematics(robot, inp.q, inp.lam)
    lb, ub = ActuatorLimit().bounds(robot, inp, kin)
    active = list(robot.active)
    speed = robot.speed[active] * inp.dt / SCALE
    assert np.all(ub[:-1] <= speed + 1e-9)
    assert np.all(lb[:-1] >= -speed - 1e-9)
    for x in (lb, ub):
        q, lam = moved(robot, inp, x)
        s = robot.actuators_from_joints(q)
        assert np.all(s >= robot.lower - 1e-12)
        assert np.all(s <= robot.upper + 1e-12)
        assert -1e-12 <= lam <= 1.0 + 1e-12


def test_an_rcm_tolerance_of_zero_makes_the_rcm_an_equality(state) -> None:
    robot, _, inp = state
    c = RcmLimit(0.0).constraint(robot, inp, kinematics(robot, inp.q, inp.lam))
    assert c.equality
    assert c.G.shape[0] == 2


@pytest.mark.parametrize(
    ("make", "name"),
    [
        (lambda: RcmLimit(-1e-6), "tolerance"),
        (lambda: RcmLimit(True), "tolerance"),
        (lambda: SingularMargin(floor=1.0), "floor"),
        (lambda: SingularMargin(gain=0.0), "gain"),
        (lambda: TipSpeed(float("nan")), "speed"),
        (lambda: ActuatorLimit(margin=-1.0), "margin"),
        (lambda: RetinaBarrier("eye"), "eye"),
        (lambda: RetinaBarrier(default_eye(make_robot("iramis")), margin=0.5), "margin"),
    ],
)
def test_each_limit_checks_its_own_parameters(make, name: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(InvalidInputError, match=name):
        make()


def test_the_settings_build_limits_that_hold_their_values() -> None:
    robot = make_robot("iramis")
    eye = default_eye(robot)
    lim = QpLimits(rcm_tolerance=0.2e-6, retina_margin=0.1e-3, singular_margin=0.3,
                   tip_speed=0.02, eye_gain=0.4)  # fmt: skip
    rcm, retina, singular, speed = lim.rows(eye, 1e-3)
    assert rcm == RcmLimit(0.2e-6)
    assert isinstance(retina, RetinaBarrier) and retina.margin == 0.1e-3 and retina.gain == 0.4
    assert retina.recovery == max(1e-6, 0.4 * 0.02 * 1e-3)
    assert singular == SingularMargin(0.3, 0.5) and speed == TipSpeed(0.02)
    assert [type(x) for x in QpLimits().rows(None, 1e-3)] == [RcmLimit, SingularMargin]


@pytest.mark.parametrize("gain", [0.1, 0.5, 1.0])
def test_a_damper_approaches_its_floor_at_its_gain_and_returns_past_it_at_once(gain) -> None:
    """value + grad x >= floor + (1 - gain)(value - floor) above the floor; past it the row asks
    for the whole way back (at most `recovery`), so a second-order loss each step (a point
    sliding along a sphere) stays within one step's loss instead of settling at loss / gain."""
    from rcmplan.control.limits.rows import SCALE as ROW_SCALE
    from rcmplan.control.limits.rows import damper_bound

    floor, recovery = 2.0e-4, 1e-6
    # -grad x <= h: the value may fall by at most h * SCALE this step
    assert damper_bound(floor + 8e-6, floor, gain, recovery) * ROW_SCALE == pytest.approx(
        gain * 8e-6, rel=1e-12
    )
    assert damper_bound(floor - 4e-9, floor, gain, recovery) * ROW_SCALE == pytest.approx(
        -4e-9, rel=1e-12
    )
    assert damper_bound(floor - 5e-6, floor, gain, recovery) * ROW_SCALE == pytest.approx(
        -recovery, rel=1e-12
    )
