"""The curved-needle injection: scenario keys, entry through the trocar, lateral targets."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from rcmplan.exceptions import InvalidInputError, ScenarioError, UnreachableTargetError
from rcmplan.job import run_scenario
from rcmplan.robot.registry import make_robot
from rcmplan.scene.curved_figures import needle_polyline, needle_polylines, port_offset
from rcmplan.scene.curved_procedure import entry_poses
from rcmplan.scene.eye import default_eye
from rcmplan.scene.procedures import Steps
from rcmplan.scene.scenario import load_scenario, scenario_from_dict


@pytest.fixture(scope="module")
def curved_scenario():
    return replace(load_scenario("curved"), visits=("p7",))


@pytest.mark.parametrize("method", ["pinv", "dls"])
def test_the_curved_injection_holds_the_rcm_and_meets_every_target(curved_scenario, method):
    result = run_scenario(curved_scenario.with_method(method))
    s = result.summary()
    assert s["status"] == "ok"
    assert s["needle"] == "curved"
    assert s["max_rcm_deviation_m"] <= 1e-6
    assert s["max_target_tip_error_m"] <= 1e-6
    assert s["max_tip_direction_error_rad"] <= 1e-3
    row = s["lateral_targets"][0]
    assert row["approach_to_normal_rad"] < row["straight_approach_to_normal_rad"] - 0.2
    assert 0.0 < s["worst_port_clearance_m"] < 0.45e-3


def test_a_straight_run_reports_a_straight_needle() -> None:
    sc = replace(load_scenario("default"), visits=("p4",))
    assert run_scenario(sc).summary()["needle"] == "straight"


def test_the_arc_passes_the_port_with_its_sagitta_only() -> None:
    robot = load_scenario("curved").needle.fit(make_robot("iramis"))
    eye = default_eye(robot)
    polys = np.array([
        [T[:3, :3] @ robot.needle.arc_local(t) + T[:3, 3]
         for t in np.linspace(0.0, robot.needle.arc_angle, 201)]
        for T in entry_poses(robot.needle, eye, np.array([0.0, 0.0, 1.0]), Steps())
    ])  # fmt: skip
    each = np.array([port_offset(eye, poly) for poly in polys])
    np.testing.assert_array_equal(port_offset(eye, polys), each)  # many at once: the same
    assert np.ptp(each) > 0.0
    R, w = robot.needle.radius, eye.wall
    assert each.max() == pytest.approx(R - math.sqrt(R * R - w * w), rel=1e-3)


@pytest.mark.parametrize("name", ["iramis", "ur5", "straight"])
def test_the_needle_lines_of_many_poses_are_each_poses_own(name: str) -> None:
    """A curved needle's lines come from its kernels' frames at once, another's one by one."""
    base = make_robot("iramis" if name == "straight" else name)
    robot = base if name == "straight" else load_scenario("curved").needle.fit(base)
    joints = robot.home + np.random.default_rng(3).normal(0.0, 0.05, (40, len(robot.home)))
    each = np.array([needle_polyline(robot, q) for q in joints])
    np.testing.assert_allclose(needle_polylines(robot, joints), each, rtol=0, atol=1e-15)
    assert each.shape[1] == (2 if name == "straight" else 202)


def test_a_needle_on_the_axis_has_no_port_offset() -> None:
    robot = make_robot("iramis")
    eye = default_eye(robot)
    line = np.array([eye.port - 0.05 * eye.axis, eye.port + 0.01 * eye.axis])
    assert port_offset(eye, line) == pytest.approx(0.0, abs=1e-15)
    assert needle_polyline(robot, robot.home).shape == (2, 3)


@pytest.mark.parametrize(
    "data, key",
    [({"needle": {"kind": "bent"}}, "kind"),
     ({"needle": {"arc_angle_rad": 2.0}}, "arc_angle_rad"),
     ({"lateral": {"directions": [[1.0, 0.0]]}}, "directions"),
     ({"lateral": {"directions": []}}, "directions")],
)  # fmt: skip
def test_bad_needle_keys_raise_naming_the_key(data, key) -> None:
    with pytest.raises(ScenarioError, match=key):
        scenario_from_dict(data)


def test_a_curved_spiral_is_refused() -> None:
    sc = scenario_from_dict({"procedure": "spiral", "needle": {"kind": "curved"}})
    with pytest.raises(ScenarioError, match="needle"):
        sc.phases(make_robot("iramis"))


def test_an_arc_too_tight_for_the_port_is_refused_before_motion() -> None:
    sc = scenario_from_dict({"needle": {"kind": "curved", "radius_mm": 1.0, "arc_angle_rad": 1.5}})
    with pytest.raises(UnreachableTargetError, match=r"R >= 1.34 mm"):
        sc.phases(make_robot("iramis"))


def test_one_direction_per_visit_is_required() -> None:
    sc = scenario_from_dict({"needle": {"kind": "curved"}, "lateral": {"directions": [[1, 0, 0]]}})
    with pytest.raises(InvalidInputError, match="one per visit"):
        sc.phases(make_robot("iramis"))


def test_a_curved_needle_on_an_arm_runs_its_qp_on_mujoco_compiled_within_its_bounds() -> None:
    """The `curved` scenario on the UR5's dynamic MuJoCo plant with the QP: the plant moves the
    shaft's model, the controller drives the curved model on the same joints, every phase in
    the compiled loop, and the run holds what it states (`ok` only within its bounds)."""
    sc = load_scenario("curved").with_plant("mujoco").with_robot("ur5").with_method("qp")
    result = run_scenario(sc)
    assert result.status == "ok", result.message
    assert result.extra["execution_path"] == "compiled"
    assert np.isfinite(result.log.roll_error).all()
    assert float(np.nanmax(np.linalg.norm(result.log.rcm_deviation(), axis=1))) <= 1e-6


def test_the_panda_rolls_its_curved_needle_to_the_retina_below_within_joint_7s_travel() -> None:
    """p5 lies below the trocar: the needle rolls from the entry (bend up) to bend down. Joint
    7 of the Panda turns +-2.8973 rad, so a bend on the flange's x put bend-down 0.1 rad
    beyond its travel (refused before motion); the file's needle_bend ("+y") centres the
    travel on the rolls the injection uses."""
    sc = replace(load_scenario("curved").with_robot("panda"), visits=("p5",))
    result = run_scenario(sc)
    assert result.status == "ok", result.message
    q7 = result.log.joints[:, 6]
    assert np.ptp(q7) > 2.5  # the roll turned about half a turn
    robot = make_robot("panda")
    assert robot.lower[6] + 1.0 < q7.min() and q7.max() < robot.upper[6] - 1.0
    assert float(np.nanmax(np.linalg.norm(result.log.rcm_deviation(), axis=1))) <= 1e-6


def test_the_mujoco_scene_draws_the_arc_ending_at_the_models_tip() -> None:
    mujoco = pytest.importorskip("mujoco")
    from rcmplan.sim.mujoco.plant import MujocoPlant

    robot = load_scenario("curved").needle.fit(make_robot("iramis"))
    plant = MujocoPlant(robot.base, mode="kinematic", needle_arc=(12e-3, 0.25))
    q = np.array([1e-3, 0.05, -2e-3, 0.1, 5e-3, 0.7])
    plant.reset(robot.actuators_from_joints(q))
    model, data = plant.scene()
    site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "needle_arc_tip")
    assert data.site_xpos[site] == pytest.approx(robot.tip(q), abs=1e-9)
    assert plant.warnings() == {}
