"""Scenario points in the eye frame go with the eye to every robot; points and directions in a
robot's base frame run on that robot only, and another robot is refused naming the key."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from rcmplan.cli import build_parser
from rcmplan.cli.inject import scenario_for
from rcmplan.exceptions import ScenarioError
from rcmplan.robot.registry import make_robot
from rcmplan.scene.eye_text import to_base, to_eye_mm
from rcmplan.scene.scenario import Scenario, load_scenario, scenario_from_dict

# near-slider-limit's p4 as it stood in iRAM!S's base frame [mm] (L4 0.25 mm from its end)
P4_BASE_MM = (-112.566564, 73.430227, 104.878644)


def test_an_eye_frame_point_is_the_base_frame_point_it_replaced_on_iramis() -> None:
    sc = load_scenario("near-slider-limit")
    assert sc.point_frame == "eye"
    robot = make_robot("iramis")
    p4 = sc.points(sc.eye(robot)).p4
    np.testing.assert_allclose(p4, np.array(P4_BASE_MM) * 1e-3, rtol=0, atol=1e-15)


@pytest.mark.parametrize("robot", ["ur5", "panda"])
def test_an_eye_frame_point_is_the_same_place_in_every_robots_eye(robot: str) -> None:
    sc = load_scenario("near-slider-limit")
    on_iramis = to_eye_mm(sc.eye(make_robot("iramis")), sc.points(sc.eye(make_robot("iramis"))).p4)
    moved = sc.with_robot(robot)
    eye = moved.eye(make_robot(robot))
    np.testing.assert_allclose(to_eye_mm(eye, moved.points(eye).p4), on_iramis, atol=1e-9)


def base_frame_scenario() -> dict:
    return {"name": "mine", "points": {"p4_mm": list(P4_BASE_MM), "visits": ["p4"]}}


def test_a_base_frame_point_runs_on_its_own_robot_only() -> None:
    sc = scenario_from_dict(base_frame_scenario())
    assert sc.with_robot("iramis").point_overrides == sc.point_overrides
    with pytest.raises(ScenarioError) as err:
        sc.with_robot("ur5")
    text = str(err.value)
    assert "[points] p4_mm" in text and 'frame = "eye"' in text and "robot ur5" in text
    assert "base frame of its own robot, iramis" in text


@pytest.mark.parametrize(
    ("extra", "key"),
    [({"qp": {"contacts_mm": [[-112.5, 73.4, 104.8]]}}, "[qp] contacts_mm"),
     ({"needle": {"kind": "curved"}, "controller": {"method": "pinv"},
       "lateral": {"directions": [[0.0, 0.0, 1.0]]}}, "[lateral] directions")],
)  # fmt: skip
def test_base_frame_contacts_and_directions_run_on_their_own_robot_only(
    extra: dict, key: str
) -> None:
    data = {"name": "mine", **extra}
    sc = scenario_from_dict(data)
    with pytest.raises(ScenarioError, match=key.replace("[", r"\[").replace("]", r"\]")):
        sc.with_robot("ur5")


def test_a_points_frame_outside_the_two_is_refused() -> None:
    data = base_frame_scenario()
    data["points"]["frame"] = "world"
    with pytest.raises(ScenarioError, match=r"\[points\] frame.*one of \('base', 'eye'\)"):
        scenario_from_dict(data)
    with pytest.raises(ScenarioError, match=r"\[points\] frame = 'world'"):
        Scenario(point_frame="world")


def test_a_target_joins_eye_frame_points_where_the_eye_frame_puts_it() -> None:
    args = build_parser().parse_args(["inject", "--scenario", "near-slider-limit", "--robot",
                                      "panda", "--target", "-1,0,10.5"])  # fmt: skip
    sc = scenario_for(args)
    robot = make_robot("panda")
    eye = sc.eye(robot)
    want = to_base(eye, np.array([[-1.0, 0.0, 10.5]]))[0]
    np.testing.assert_allclose(sc.points(eye).p4, want, rtol=0, atol=1e-15)
    assert sc.visits == ("p4",)


def test_a_refused_eye_frame_point_is_named_as_typed() -> None:
    from rcmplan.exceptions import UnreachableTargetError

    data = {"name": "mine", "points": {"frame": "eye", "p4_mm": [0.0, 0.0, 30.0], "visits": ["p4"]}}
    sc = scenario_from_dict(data)
    with pytest.raises(UnreachableTargetError, match=r"p4 at \(0, 0, 30\) mm \(eye frame\)"):
        sc.phases(make_robot("iramis"))


def test_a_sweep_on_another_robot_refuses_base_frame_contacts(tmp_path: Path) -> None:
    from rcmplan.cli import main

    path = tmp_path / "contacts.toml"
    path.write_text('name = "mine"\n[qp]\ncontacts_mm = [[-112.5, 73.4, 104.8]]\n')
    out = tmp_path / "out"
    code = main(["sweep", "--scenario", str(path), "--robot", "ur5", "--targets", "4",
                 "--out", str(out), "--no-plots"])  # fmt: skip
    assert code == 2
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] != "ok" and "[qp] contacts_mm" in summary["message"]
