"""Limits in every phase and honest tracking: the free-space step that holds actuator speed and
travel, violations counted over every record, and the waypoints a run did not reach."""

from __future__ import annotations

import numpy as np
import pytest

from rcmplan import Iramis
from rcmplan.analysis.limits import reach_bound, violations, waypoints
from rcmplan.control import PinvSolver
from rcmplan.control.limited_tip import LimitedTipSolver, step_fraction
from rcmplan.control.phase import Phase
from rcmplan.control.qp import make_qp
from rcmplan.control.qp_limits import QpLimits
from rcmplan.control.solvers import TipSolver, Tolerance
from rcmplan.control.targets import rcm_target, solve_pose
from rcmplan.controller import Controller
from rcmplan.exceptions import UnreachableTargetError
from rcmplan.job import run_scenario
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.scene.procedures import injection
from rcmplan.scene.scenario import load_scenario
from rcmplan.sim import KinematicPlant


@pytest.fixture(scope="module")
def robot() -> Iramis:
    return Iramis()


# --- the limited free-space step ---------------------------------------------------------------
def scale_factor(robot: Iramis, s: np.ndarray, ds: np.ndarray, dt: float, margin: float) -> float:
    """`step_fraction` with the robot's speed over dt [s] and its travel less the margin."""
    return step_fraction(s, ds, robot.speed * dt, robot.lower, robot.upper, margin, 1.0)


def test_step_fraction_holds_speed_and_travel_and_only_lets_an_actuator_back_into_its_band(
    robot: Iramis,
) -> None:
    s = robot.home_actuators.copy()
    v = robot.speed * 1e-3
    ds = np.zeros_like(s)
    ds[0] = 4.0 * v[0]
    assert scale_factor(robot, s, ds, 1e-3, 0.0) == pytest.approx(0.25)
    ds[0] = 0.5 * v[0]
    assert scale_factor(robot, s, ds, 1e-3, 0.0) == 1.0
    s[0] = robot.upper[0] - 1e-3 - 0.2 * v[0]  # 0.2 of a step from the band's edge
    assert scale_factor(robot, s, ds, 1e-3, 1e-3) == pytest.approx(0.4)
    s[0] = robot.upper[0] - 0.5e-3  # inside the margin: may not go further out...
    assert scale_factor(robot, s, ds, 1e-3, 1e-3) == 0.0
    assert scale_factor(robot, s, -ds, 1e-3, 1e-3) == 1.0  # ...but may come back


def test_the_approach_with_the_limited_step_breaks_no_speed_bound_where_the_plain_one_does(
    robot: Iramis,
) -> None:
    eye = default_eye(robot)
    pts = default_points(eye)
    phases = injection(robot, eye, pts)[:1]  # the approach, in free space
    plain = Controller(KinematicPlant(robot), PinvSolver(), TipSolver()).run(phases)
    held = Controller(KinematicPlant(robot), PinvSolver(), LimitedTipSolver()).run(phases)
    assert violations(plain, robot, eye).counts["speed"] > 0
    v = violations(held, robot, eye)
    assert v.total == 0, v.counts
    assert np.linalg.norm(held.tip[-1] - pts.p2) <= 2e-8  # and still arrives


def test_the_qp_holds_its_limits_in_free_phases_by_default(robot: Iramis) -> None:
    eye = default_eye(robot)
    c = Controller(KinematicPlant(robot), make_qp(robot, eye))
    assert isinstance(c.free_solver, LimitedTipSolver)
    assert c.free_solver.dt == 1e-3


# --- violations over every record ----------------------------------------------------------------
def test_violations_count_every_kind_on_a_log_that_breaks_them(robot: Iramis) -> None:
    eye = default_eye(robot)
    log = Controller(KinematicPlant(robot), PinvSolver(), TipSolver()).run(
        injection(robot, eye, default_points(eye))
    )
    v = violations(log, robot, eye)
    assert v.counts["speed"] > 0 and v.worst["speed"] > 0.0
    assert v.counts["retina"] > 0  # pinv reaches the contacts through the margin
    n = len(log)
    lam = log.lam.copy()
    rcm = np.flatnonzero(~np.isnan(log.trocar[:, 0]))
    lam[rcm[:3]] = 1.5
    broken = type(log)(**{**{k: getattr(log, k) for k in log.__dataclass_fields__}, "lam": lam})
    assert violations(broken, robot, eye).counts["lam"] == 3
    assert v.counts["lam"] == 0 and n == len(broken)


@pytest.mark.parametrize("name", ["default", "near-slider-limit", "panda"])
def test_the_qp_breaks_no_limit_over_every_record_of_every_phase(name: str) -> None:
    """On the Panda too: its retina damper, sliding along the margin at 10 um per step, once
    settled 11 nm past it (the sphere's curvature loss over the damper's gain)."""
    result = run_scenario(load_scenario(name).with_method("qp"))
    assert result.ok, result.message
    s = result.summary()
    assert s["limit_violations"] == dict.fromkeys(s["limit_violations"], 0)
    assert len(s["limit_violations"]) == 6


def test_the_qp_breaks_no_limit_over_1000_random_reachable_targets(robot: Iramis) -> None:
    """A random walk of 1,000 targets in 0.2 mm steps through the eye, some within the retina
    margin and near the sliders' travel: every record of every phase within every limit."""
    eye = default_eye(robot)
    pts = default_points(eye)
    rng = np.random.default_rng(7)
    tips, tip = [], pts.p3.copy()
    while len(tips) < 1000:
        cand = tip + _step(rng, tip - eye.port, toward=eye.center - eye.port)
        if eye.distance_to_retina(cand) < 0.05e-3 or np.dot(cand - eye.port, eye.axis) < 3e-3:
            continue
        try:
            solve_pose(robot, rcm_target(cand, eye.port))
        except UnreachableTargetError:
            continue
        tips.append(cand)
        tip = cand
    walk = np.array([rcm_target(t, eye.port) for t in tips])
    phases = [*injection(robot, eye, pts, visits=())[:3], Phase("walk", walk)]
    log = Controller(KinematicPlant(robot), make_qp(robot, eye)).run(phases)
    assert len(np.unique(log.step[log.phase == 3])) == 1000
    v = violations(log, robot, eye)
    assert v.total == 0, (v.counts, v.worst)
    within = eye.retina_radius - np.linalg.norm(np.array(tips) - eye.center, axis=1) < 0.25e-3
    assert within.sum() > 0  # the walk asks for tips inside the margin: the QP holds it


def _step(rng: np.random.Generator, r: np.ndarray, toward: np.ndarray) -> np.ndarray:
    """A random tip step within the procedures' step sizes (0.2 mm, 2 mrad of needle turn about
    the trocar), drifting deeper along `toward` so that the walk meets the retina."""
    step = rng.normal(size=3) + 0.5 * toward / np.linalg.norm(toward)
    step *= 0.2e-3 / np.linalg.norm(step)
    u = r / np.linalg.norm(r)
    lateral = step - np.dot(step, u) * u
    room = 2e-3 * np.linalg.norm(r)  # lateral motion that turns the needle by 2 mrad
    if np.linalg.norm(lateral) > room:
        step = np.dot(step, u) * u + lateral * room / np.linalg.norm(lateral)
    return step


# --- waypoints -----------------------------------------------------------------------------------
def test_waypoints_name_the_retina_where_the_qp_stops_short_and_none_for_pinv(
    robot: Iramis,
) -> None:
    eye = default_eye(robot)
    phases = injection(robot, eye, default_points(eye), visits=("p4",))
    qp_log = Controller(KinematicPlant(robot), make_qp(robot, eye)).run(phases)
    w = waypoints(qp_log, robot, eye, Tolerance())
    assert w.limited, "the QP stops short of the waypoints next to the retina contact"
    assert all(entry["active_limits"] == ["retina"] for entry in w.limited)
    assert all(entry["tip_error_m"] > w.bound_m for entry in w.limited)
    assert w.max_tip_error_m == max(entry["tip_error_m"] for entry in w.limited)
    pinv_log = Controller(KinematicPlant(robot), PinvSolver()).run(phases)
    p = waypoints(pinv_log, robot, eye, Tolerance())
    assert p.limited == () and p.count == w.count
    assert p.max_tip_error_m is not None and p.max_tip_error_m <= p.bound_m


def test_reach_bound_follows_the_tolerances(robot: Iramis) -> None:
    assert reach_bound(Tolerance(1e-8, 1e-7), robot) == pytest.approx(
        3e-8 + 2e-7 * robot.needle_length
    )
    assert reach_bound(Tolerance(1e-6, 1e-7), robot) > reach_bound(Tolerance(), robot)


def test_the_summary_reports_worst_waypoint_error_and_limited_waypoints() -> None:
    s = run_scenario(load_scenario("default").with_method("qp")).summary()
    assert s["limited_waypoints"] == len(s["limited_waypoint_list"]) > 0
    assert s["max_waypoint_tip_error_m"] > s["max_tip_error_m"]
    first = s["limited_waypoint_list"][0]
    assert set(first) == {"phase", "step", "tip_error_m", "active_limits"}


def test_the_curved_needles_rcm_count_follows_its_rcm_deviation_not_the_chord_to_its_tip() -> None:
    """The RCM kind counts the records whose RCM deviation (the run's max_rcm_deviation_m
    measure, on the shaft) exceeds the tolerance: none for pinv's 0.45 um within 0.5 um, where
    the chord from the needle base to the curved tip passes the trocar far off."""
    result = run_scenario(load_scenario("curved"))
    assert result.ok, result.message
    s, log = result.summary(), result.log
    tol = QpLimits().rcm_tolerance
    rcm = ~np.isnan(log.trocar[:, 0])
    assert s["max_rcm_deviation_m"] <= tol
    assert s["limit_violations"]["rcm"] == 0
    assert np.all(log.line_distance()[rcm] > tol)  # measured on the chord, every record broke it
    # Records pushed beyond the tolerance on the shaft are counted, one for one.
    moved = log.rcm.copy()
    rows = np.flatnonzero(rcm)[[0, 100, 2000, -1]]
    moved[rows] += 2.0 * tol * np.array([0.0, 0.6, 0.8])
    broken = type(log)(**{**{k: getattr(log, k) for k in log.__dataclass_fields__}, "rcm": moved})
    v = violations(broken, result.robot, result.scenario.eye(result.robot))
    assert v.counts["rcm"] == len(rows)
    assert v.worst["rcm"] == pytest.approx(broken.max_rcm_deviation() - tol)


# --- the bounds a run states, checked on its measured log ---------------------------------------


def test_broken_bounds_names_the_qps_limits_for_the_qp_and_the_loop_tolerance_for_all() -> None:
    from rcmplan.analysis.limits import broken_bounds

    counts = {"limit_violations": {"travel": 0, "speed": 804, "rcm": 0, "retina": 12}}
    qp, pinv = load_scenario("default").with_method("qp"), load_scenario("default")
    assert pinv.loop.rcm_tolerance == pytest.approx(0.8e-6)
    assert broken_bounds(pinv, counts, 0.462e-6) == ""  # pinv holds no QP limit
    assert broken_bounds(qp, counts, 0.5e-6) == (
        "records beyond the QP's limits: speed 804, retina 12 (measured on the kinematic plant)"
    )
    assert broken_bounds(qp, {"limit_violations": dict.fromkeys(counts, 0)}, 0.5e-6) == ""
    beyond = broken_bounds(pinv.with_plant("mujoco"), counts, 1.2e-6)
    assert beyond == ("max RCM deviation 1.20 um above the loop's RCM tolerance 0.800 um "
                      "(measured on the mujoco plant)")  # fmt: skip
    assert broken_bounds(pinv, counts, 0.8e-6) == ""  # at the tolerance: held
    assert broken_bounds(pinv, counts, None) == ""  # no record inside the eye


def test_compare_names_limit_violated_before_the_bounds_in_its_status_column() -> None:
    from rcmplan.cli.compare import status_cell

    assert status_cell({"status": "ok", "message": ""}) == "ok"
    broke = {"status": "limit_violated", "message": "records beyond the QP's limits: rcm 3"}
    assert status_cell(broke) == "limit_violated: records beyond the QP's limits: rcm 3"
    stopped = {"status": "no_convergence", "message": "ConvergenceError: " + "x" * 200}
    assert status_cell(stopped) == ("ConvergenceError: " + "x" * 200)[:100]
