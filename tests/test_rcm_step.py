"""The controller bounds its own step from the stated RCM tolerance (`control.rcm_step`): the
rule itself, and the default injection on the shipped arms, which holds the RCM within 1 um
without smaller target steps."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rcmplan.control.phase import LoopSettings
from rcmplan.control.rcm_step import (
    AGAIN,
    BOX_GROWTH,
    HELD,
    SHRINK_FLOOR,
    STUCK,
    box_margin,
    next_bounds,
    retina_lift,
    step_scale,
)
from rcmplan.exceptions import InvalidInputError
from rcmplan.job import run_scenario
from rcmplan.scene.procedures import Steps
from rcmplan.scene.scenario import load_scenario

from paths import use_path

nan = float("nan")
UM = 1e-6


def test_a_step_within_the_bound_is_kept() -> None:
    assert step_scale(0.5 * UM, 0.0, 0.8 * UM, 1.0) == 1.0


def test_a_step_that_leaves_the_needle_no_farther_than_before_is_kept() -> None:
    assert step_scale(2.0 * UM, 3.0 * UM, 0.8 * UM, 1.0) == 1.0


def test_a_step_beyond_the_bound_is_scaled_so_a_second_order_deviation_lands_under_it() -> None:
    f = step_scale(3.2 * UM, 0.0, 0.8 * UM, 1.0)
    assert f == pytest.approx(math.sqrt(0.9 * 0.8 / 3.2))
    assert 3.2 * UM * f * f == pytest.approx(0.9 * 0.8 * UM)  # the square of the step's scale


def dev(f: float, before: float, c: float) -> float:
    """The deviation the rule assumes after a step scaled by f: (1 - f) before + f^2 c."""
    return (1.0 - f) * before + f * f * c


def test_a_long_step_from_near_the_bound_is_scaled_for_its_first_order_part_too() -> None:
    """The needle 0.779 um from the trocar and a step whose second-order part is 12.737 um (a
    step of Baxter's left arm with 0.99 mm target steps): the square-root rule's 0.226 would leave 1.25 um
    (0.60 of it the first-order part left over); this rule takes the floor, then at that scale
    the step that brings the needle nearest, 0.767 um, within the 0.8 um bound."""
    b, c, bound = 0.779 * UM, 12.737 * UM, 0.8 * UM
    assert dev(0.9 * math.sqrt(bound / c), b, c) > 1.2 * UM
    f1 = step_scale(dev(1.0, b, c), b, bound, 1.0)
    assert f1 == SHRINK_FLOOR  # the nearest point, f = b / 2c = 0.0306, lies below the floor
    f2 = step_scale(dev(f1, b, c), b, bound, f1)
    assert f1 * f2 == pytest.approx(b / (2.0 * c))
    assert dev(f1 * f2, b, c) == pytest.approx(b - b * b / (4.0 * c)) and dev(f1 * f2, b, c) < bound


def test_a_step_from_within_the_bound_lands_at_nine_tenths_of_it() -> None:
    b, c, bound = 0.3 * UM, 5.0 * UM, 0.8 * UM
    f = step_scale(dev(1.0, b, c), b, bound, 1.0)
    assert dev(f, b, c) == pytest.approx(0.9 * bound)


def test_a_far_deviation_shrinks_the_step_by_at_most_the_floor_per_try() -> None:
    assert step_scale(1.0, 0.0, 0.8 * UM, 1.0) == SHRINK_FLOOR
    assert step_scale(float("nan"), 0.0, 0.8 * UM, 1.0) == SHRINK_FLOOR


def test_a_qp_step_inside_its_box_or_no_farther_than_before_needs_no_margin() -> None:
    assert box_margin(0.5 * UM, 0.0, 0.5 * UM, 0.0, 0.5 * UM) == 0.0
    assert box_margin(0.7 * UM, 0.9 * UM, 0.5 * UM, 0.0, 0.5 * UM) == 0.0
    assert (
        box_margin(0.4 * UM, 0.0, 0.5 * UM, 0.1 * UM, 0.5 * UM) == 0.0
    )  # held after a narrower solve


def test_a_qp_step_beyond_its_box_narrows_the_box_by_more_than_the_excess() -> None:
    first = box_margin(0.6 * UM, 0.0, 0.5 * UM, 0.0, 0.5 * UM)
    assert first == pytest.approx(BOX_GROWTH * 0.1 * UM) and first > 0.1 * UM
    assert box_margin(0.52 * UM, 0.0, 0.5 * UM, first, 0.5 * UM) == pytest.approx(
        first + BOX_GROWTH * 0.02 * UM
    )


def test_the_box_margin_stops_at_the_tolerance_an_equality() -> None:
    assert box_margin(2.0 * UM, 0.0, 0.5 * UM, 0.0, 0.5 * UM) == 0.5 * UM
    assert (
        box_margin(0.7 * UM, 0.0, 0.5 * UM, 0.5 * UM, 0.5 * UM) == 0.5 * UM
    )  # no narrower box left
    assert box_margin(float("nan"), 0.0, 0.5 * UM, 0.0, 0.5 * UM) == 0.5 * UM


def test_a_qp_step_past_the_retina_floor_raises_it_by_more_than_the_excess() -> None:
    floor, cap = 250.0 * UM, 1.0 * UM
    assert retina_lift(250.0 * UM, 0.0, floor, 0.0, cap) == 0.0  # on the floor
    assert retina_lift(249.9 * UM, 249.8 * UM, floor, 0.0, cap) == 0.0  # no nearer than before
    first = retina_lift(249.95 * UM, 250.0 * UM, floor, 0.0, cap)
    assert first == pytest.approx(BOX_GROWTH * 0.05 * UM) and first > 0.05 * UM
    assert retina_lift(249.99 * UM, 250.0 * UM, floor, first, cap) == pytest.approx(
        first + BOX_GROWTH * 0.01 * UM
    )
    assert retina_lift(240.0 * UM, 250.0 * UM, floor, 0.0, cap) == cap  # at most the recovery


def test_the_hold_solves_again_until_both_bounds_hold_or_neither_can_narrow() -> None:
    tol, floor, rec = 0.5 * UM, 250.0 * UM, 1.0 * UM
    inf = float("inf")
    assert next_bounds(0.4 * UM, 0.0, inf, nan, tol, floor, rec, 0.0, 0.0) == (HELD, 0.0, 0.0)
    # the box beyond, the retina held: the box narrows, the floor keeps its lift
    status, narrower, higher = next_bounds(0.6 * UM, 0.0, inf, nan, tol, floor, rec, 0.0, 0.2 * UM)
    assert status == AGAIN and narrower == pytest.approx(BOX_GROWTH * 0.1 * UM)
    assert higher == 0.2 * UM
    # the retina past its floor, the box held: the floor rises, the box keeps its margin
    status, narrower, higher = next_bounds(0.4 * UM, nan, 249.9 * UM, 250.0 * UM, tol, floor, rec,
                                           0.1 * UM, 0.0)  # fmt: skip
    assert status == AGAIN and narrower == 0.1 * UM
    assert higher == pytest.approx(BOX_GROWTH * 0.1 * UM)
    # both at their caps: nothing narrower is left
    assert next_bounds(0.7 * UM, 0.0, 240.0 * UM, 250.0 * UM, tol, floor, rec, tol, rec) == (
        STUCK,
        tol,
        rec,
    )
    # an equality (tol 0) has no box: only the retina decides
    assert next_bounds(0.0, nan, inf, nan, 0.0, floor, rec, 0.0, 0.0)[0] == HELD


def test_the_loop_settings_refuse_a_tolerance_that_is_not_positive() -> None:
    with pytest.raises(InvalidInputError, match="rcm_tolerance"):
        LoopSettings(rcm_tolerance=0.0)


def deviations(robot: str, method: str, tolerance: float | None) -> tuple[str, float, float]:
    """(status, max RCM deviation inside the eye, max tip error) of the default injection."""
    sc = load_scenario("default").with_robot(robot).with_method(method)
    sc = replace(sc, loop=replace(sc.loop, rcm_tolerance=tolerance))
    result = run_scenario(sc)
    log = result.log
    inside = np.isfinite(log.trocar[:, 0])
    dev = float(np.linalg.norm(log.rcm_deviation(), axis=1)[inside].max())
    tip = max(p.final_tip_error_m for p in result.phases if p.inside_eye)
    return result.status, dev, tip


@pytest.mark.parametrize("robot", ["ur5", "panda"])
@pytest.mark.parametrize("method", ["pinv", "dls"])
def test_the_default_injection_holds_the_rcm_within_a_micrometre_on_the_arms(
    robot: str, method: str
) -> None:
    status, dev, tip = deviations(robot, method, LoopSettings().rcm_tolerance)
    assert status == "ok"
    assert dev <= LoopSettings().rcm_tolerance  # type: ignore[operator]
    assert tip < 1.0 * UM


def test_without_the_bound_the_ur5_leaves_the_rcm_farther_than_a_micrometre() -> None:
    """The bound is what holds it: the same plan with the solver's steps as they are."""
    status, dev, _ = deviations("ur5", "pinv", None)
    assert status == "ok" and dev > 1.0 * UM


@pytest.mark.parametrize("mode", ["off", "on"])
def test_five_times_longer_target_steps_keep_the_rcm_within_the_tolerance(mode: str) -> None:
    """0.99 mm and 10 mrad between targets on the UR5, in the Python loop and the compiled
    one: each step scaled for the deviation it starts from too (`step_scale`) holds the
    0.8 um tolerance; scaled for its second-order part alone the run ended `limit_violated`
    at 1.05 um."""
    sc = load_scenario("default").with_robot("ur5")
    sc = replace(sc, steps=Steps(0.99e-3, 10e-3))
    use_path(mode)
    try:
        result = run_scenario(sc)
    finally:
        use_path(None)
    log = result.log
    inside = np.isfinite(log.trocar[:, 0])
    dev = float(np.linalg.norm(log.rcm_deviation(), axis=1)[inside].max())
    assert result.status == "ok" and dev <= LoopSettings().rcm_tolerance  # type: ignore[operator]
    assert result.extra["execution_path"] == ("reference" if mode == "off" else "compiled")


@pytest.mark.parametrize("mode", ["off", "on"])
def test_both_loops_bound_the_step_alike(mode: str) -> None:
    """The Python loop (any solver, any plant) and the compiled arm loop shorten the same
    steps: the same record count and the same deviations."""
    use_path(mode)
    try:
        status, dev, _ = deviations("ur5", "pinv", LoopSettings().rcm_tolerance)
    finally:
        use_path(None)
    reference = deviations("ur5", "pinv", LoopSettings().rcm_tolerance)
    assert status == reference[0] == "ok"
    assert dev == pytest.approx(reference[1], abs=1e-12)


@pytest.mark.parametrize("name", ["iramis", "ur5"])
def test_the_compiled_bound_shortens_a_step_as_the_python_rule_does(name: str) -> None:
    """`rcm_bound.bound_step`, the compiled loops' bound for both robot families, gives the
    step `bounded_step` gives on the robot model, on a step whose second-order part carries
    the needle past the bound."""
    from rcmplan.compiled.arm import FastArm
    from rcmplan.compiled.rcm_bound import bound_step
    from rcmplan.compiled.records import robot_params
    from rcmplan.control.rcm_step import bounded_step
    from rcmplan.robot.iramis import Iramis
    from rcmplan.robot.shipped import shipped_arm

    robot = Iramis() if name == "iramis" else shipped_arm(name)
    q = robot.home.copy()
    trocar = robot.needle_point(q, 0.5)
    active = list(robot.active)
    dq = np.full(len(active), 0.02)  # rad (and m for iRAM!S's prismatic joints: scaled below)
    if name == "iramis":
        dq *= 1e-2
    bound = 0.1 * UM
    ref_dq, ref_dlam = bounded_step(robot, q, dq, 0.01, trocar, bound)
    d, x, w = np.array([*dq, 0.01]), np.empty(q.shape[0]), np.empty(6)
    if name == "iramis":
        f = bound_step(robot_params(robot), None, q, d, 0, 5, trocar, math.nan, bound, x, w)
    else:
        fast = FastArm(robot)
        arm = (fast.A, fast.ix, fast.W)
        f = bound_step(None, arm, q, d, 2 + fast.n, fast.m, trocar, math.nan, bound, x, w)
    assert f < 1.0  # the bound acted
    assert d[:-1] == pytest.approx(ref_dq, rel=1e-12, abs=0.0)
    assert d[-1] == pytest.approx(ref_dlam, rel=1e-12, abs=0.0)
    assert d[-1] == pytest.approx(0.01 * f, rel=1e-12)


@given(
    after=st.floats(0.0, 2e-6), now=st.floats(0.0, 2e-6), gap=st.floats(240e-6, 260e-6),
    gap_now=st.floats(240e-6, 260e-6), margin_f=st.floats(0.0, 1.0), lift_f=st.floats(0.0, 1.0),
)  # fmt: skip
@settings(max_examples=500, deadline=None)
def test_the_holds_next_bounds_only_grow_within_their_caps(
    after: float, now: float, gap: float, gap_now: float, margin_f: float, lift_f: float
) -> None:
    tol, floor, rec = 0.5 * UM, 250.0 * UM, 1.0 * UM
    margin, lift = margin_f * tol, lift_f * rec
    status, narrower, higher = next_bounds(after, now, gap, gap_now, tol, floor, rec, margin, lift)
    box_held = after <= tol or after <= now
    retina_held = gap >= floor or gap >= gap_now
    assert (status == HELD) == (box_held and retina_held)
    assert margin <= narrower <= tol and lift <= higher <= rec
    if status == AGAIN:
        assert narrower > margin or higher > lift
        assert box_held or narrower > 0.0  # a box beyond its tolerance narrows
    if status != AGAIN:
        assert (narrower, higher) == (margin, lift)
