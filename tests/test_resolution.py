"""Loop tolerances derived from a plant's actuator resolution (`control.resolution`)."""

from __future__ import annotations

import numpy as np
import pytest

from rcmplan import Iramis
from rcmplan.control.augmented import extended_task
from rcmplan.control.methods import MethodSettings, make_solver
from rcmplan.control.resolution import (
    MARGIN,
    grid_error_bound,
    met_tolerance,
    quantised,
    resolution_tolerance,
)
from rcmplan.control.solvers import Tolerance
from rcmplan.robot.needle import axis_from_angles
from rcmplan.sim import KinematicPlant

RES = np.array([1e-9] * 5 + [1e-6])  # the MuJoCo plant's slider steps (q5 in rad)


class RoundingPlant:
    """A plant that rounds its commands to RES (the attribute is all that is read)."""

    exact_commands = False
    actuator_resolution = RES


def test_the_nearest_grid_point_stays_within_the_bound(
    robot: Iramis, rng: np.random.Generator
) -> None:
    """Round exact slider settings to the grid: every error component stays within the
    first-order bound (positions of the tip and both needle ends, needle angles), and the
    worst case comes close to it (the bound is not loose)."""
    used = []
    for _ in range(200):
        s = rng.uniform(0.6 * robot.lower, 0.6 * robot.upper)
        grid = np.round(s / RES) * RES
        q, qg = robot.joints_from_actuators(s), robot.joints_from_actuators(grid)
        bound = grid_error_bound(robot, RES, q)
        moved = [robot.tip(qg) - robot.tip(q)]
        moved += [robot.needle_point(qg, lam) - robot.needle_point(q, lam) for lam in (0, 1)]
        assert np.abs(moved).max() <= bound.position * (1 + 1e-6)
        angles = extended_task(robot, qg, 0.5)[1:3] - extended_task(robot, q, 0.5)[1:3]
        assert np.abs(angles).max() <= bound.angle * (1 + 1e-6)
        used.append(np.abs(angles).max() / bound.angle)
    assert max(used) > 0.5


def test_one_nanometre_steps_turn_a_pcjm_by_33_nanoradians(robot: Iramis) -> None:
    bound = grid_error_bound(robot, RES, robot.home)
    # two sliders of a PCJM 30 mm apart, each within half a step: 1 nm / 30 mm at home
    assert bound.angle == pytest.approx(1e-9 / robot.params.pcjm_spacing, rel=1e-6)
    tol = resolution_tolerance(robot, RES)
    assert tol == (MARGIN * bound.position, MARGIN * bound.angle)


def test_a_tolerance_below_the_resolution_is_raised_to_it(robot: Iramis) -> None:
    floor = resolution_tolerance(robot, RES)
    tight = Tolerance(1e-9, 1e-8)
    met = met_tolerance(tight, robot, RoundingPlant())
    assert met == (floor.position, floor.angle)
    loose = Tolerance(1e-6, 1e-5)
    assert met_tolerance(loose, robot, RoundingPlant()) is loose
    mixed = met_tolerance(Tolerance(1e-6, 1e-8), robot, RoundingPlant())
    assert mixed == (1e-6, floor.angle)


def test_a_plant_without_a_resolution_keeps_the_tolerance(robot: Iramis) -> None:
    tight = Tolerance(1e-12, 1e-12)
    assert met_tolerance(tight, robot, KinematicPlant(robot)) is tight
    solver = make_solver("pinv", MethodSettings(tolerance=tight), robot, KinematicPlant(robot))
    np.testing.assert_array_equal(solver.tolerance(), tight.x_ext())


@pytest.mark.parametrize("method", ["pinv", "dls", "qp"])
def test_make_solver_meets_the_plants_resolution(robot: Iramis, method: str) -> None:
    settings = MethodSettings(tolerance=Tolerance(1e-9, 1e-8))
    solver = make_solver(method, settings, robot, RoundingPlant())
    floor = resolution_tolerance(robot, RES)
    assert solver.tolerance().min() == pytest.approx(floor.position)
    if method != "dls":  # DLS has position rows only
        assert solver.tolerance().max() == pytest.approx(floor.angle)


def test_the_angle_rows_measure_the_needle_direction(robot: Iramis) -> None:
    """The bound's angle rows are X_ext's (phi, psi): the direction they give is the axis."""
    q = robot.home
    x = extended_task(robot, q, 0.5)
    np.testing.assert_allclose(axis_from_angles(x[1], x[2]), robot.needle_axis(q), atol=1e-12)


def test_a_command_is_rounded_to_whole_steps_ties_to_even_and_a_zero_step_keeps_it() -> None:
    res = np.array([1e-9, 1e-9, 1e-9, 2.0, 0.0, 1e-3])
    s = np.array([1.49e-9, -2.6e-9, 0.0, 3.0, 0.123456789, 0.5e-3])
    out = np.full(6, np.nan)
    assert quantised(s, res, out) is None  # into out
    got = out
    # 3.0 / 2.0 = 1.5 and 0.5e-3 / 1e-3 = 0.5 are exact ties: to the even step (2 and 0 steps)
    np.testing.assert_allclose(got, [1e-9, -3e-9, 0.0, 4.0, 0.123456789, 0.0], rtol=0, atol=1e-21)
    assert got[4] == s[4]  # a zero step: the command exactly as it is
    steps = np.array([1e-9] * 5 + [1e-6])
    many = np.random.default_rng(3).uniform(-1e-3, 1e-3, (200, 6))
    for x in many:  # whole steps, within half a step of the command
        y = np.empty(6)
        quantised(x, steps, y)
        assert np.all(np.abs(y - x) <= 0.5 * steps * (1 + 1e-9))
        np.testing.assert_allclose(y / steps, np.round(y / steps), rtol=0, atol=1e-6)


def test_lengths_that_differ_are_refused_not_read_past() -> None:
    with pytest.raises(ValueError, match="same length"):
        quantised(np.zeros(6), np.full(5, 1e-9), np.empty(6))
    with pytest.raises(ValueError, match="same length"):
        quantised(np.zeros(6), np.full(6, 1e-9), np.empty(5))
