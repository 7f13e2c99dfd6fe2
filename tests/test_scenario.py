"""Scenario files: shipped ones load, broken ones name the key and the allowed values."""

from __future__ import annotations

from pathlib import Path

import pytest

from rcmplan.exceptions import ScenarioError
from rcmplan.scene.scenario import load_scenario, scenario_names


def test_shipped_scenarios_load_and_plan(robot) -> None:
    assert {"default", "spiral"} <= set(scenario_names())
    for name in scenario_names():
        sc = load_scenario(name)
        assert sc.name == name
        assert len(sc.phases(robot)) > 3


def write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "s.toml"
    p.write_text(text)
    return p


@pytest.mark.parametrize(
    ("text", "pattern"),
    [
        ("procedure = 'dance'", r"procedure = 'dance'.*injection"),
        ("[eye]\nradius_mm = 40.0", r"\[eye\] radius_mm = 40.0.*\[3, 20\]"),
        ("[eye]\nradius = 12.0", r"\[eye\] key = 'radius'.*radius_mm"),
        ("[controller]\nK = [1, 10, 12, 1, 2, 2]", r"\[controller\] K"),
        ("[controller]\nmethod = 'magic'", r"method = 'magic'.*pinv"),
        ("[controller]\nmax_iterations = 0", r"max_iterations = 0"),
        ("[points]\nvisits = ['p9']", r"visits"),
        ("[spline]\nx = 1", r"section = 'spline'"),
        ("plant = 'gazebo'", r"plant = 'gazebo'.*kinematic"),
        ("[eye]\ntrocar_offset_mm = [1, 2]", r"trocar_offset_mm.*3 numbers"),
        ("[controller]\ndrift_correction = 'yes'", r"true or false"),
        ("[eye]\nradius_mm = true", r"\[eye\] radius_mm = True.*a number in \[3, 20\]"),
        ("[controller]\nK = [1, true, 1, 1, 1, 1]", r"\[controller\] K.*6 numbers"),
        ("[controller]\nmax_iterations = true", r"max_iterations = True.*an integer"),
        ("[qp]\ncontact_tolerance_um = true", r"\[qp\] contact_tolerance_um = True.*a number"),
        ("[qp]\neye_gain = '0.5'", r"\[qp\] eye_gain = '0.5'.*a number"),
        ("[qp]\ncontacts_mm = [[1, 2, true]]", r"\[qp\] contacts_mm.*numbers in mm"),
        ("[steps]\nposition_mm = 5", r"\[steps\] position_mm = 5.*\[0.0001, 1\]"),
        ("[points]\nvisits = []", r"\[points\] visits.*1 to 100,000 names"),
    ],
)
def test_broken_scenarios_name_the_key_and_the_allowed_values(
    tmp_path: Path, text: str, pattern: str
) -> None:
    with pytest.raises(ScenarioError, match=pattern):
        load_scenario(write(tmp_path, text))


@pytest.mark.parametrize(
    ("text", "said"),
    [
        ("[steps]\npositon_mm = 0.2", "; did you mean position_mm?"),
        ("[step]\nposition_mm = 0.2", "; did you mean steps?"),
        ("procedur = 'spiral'", "; did you mean procedure?"),
        ("[qp]\ntip_speed = 1", "; did you mean tip_speed_mm_s?"),
        ("[eye]\nzzz = 1", ""),  # nothing close: nothing offered
    ],
)
def test_a_misspelt_key_is_answered_with_the_closest_valid_one(
    tmp_path: Path, text: str, said: str
) -> None:
    with pytest.raises(ScenarioError) as info:
        load_scenario(write(tmp_path, text))
    message = str(info.value)
    assert message.endswith(said) and message.count("did you mean") == (1 if said else 0)


def test_malformed_toml_and_missing_files_raise(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError, match="valid TOML"):
        load_scenario(write(tmp_path, "[eye\nradius_mm = "))
    with pytest.raises(ScenarioError, match="default") as info:
        load_scenario(tmp_path / "nope.toml")
    assert str(info.value).endswith(f"; there is no file {str(tmp_path / 'nope.toml')!r}")
    with pytest.raises(ScenarioError) as info:
        load_scenario("defualt")  # a misspelt name, not a file: no path offered
    assert "there is no file" not in str(info.value)
    assert str(info.value).endswith("; did you mean default?")


def test_units_are_converted_to_si(tmp_path: Path) -> None:
    sc = load_scenario(write(tmp_path, "[eye]\nradius_mm = 11.5\n[steps]\nangle_mrad = 1.5"))
    assert sc.eye_options["radius"] == pytest.approx(0.0115)
    assert sc.steps.angle == pytest.approx(0.0015)


def test_every_plant_a_scenario_may_name_is_registered() -> None:
    from rcmplan.scene.scenario import PLANTS
    from rcmplan.sim.registry import PLANTS as REGISTERED

    assert sorted(PLANTS) == sorted(REGISTERED)


def test_a_step_longer_than_the_loop_takes_is_refused_on_load_naming_the_bound(
    tmp_path: Path,
) -> None:
    with pytest.raises(ScenarioError, match=r"position_mm = 1.0 .*at most 0.99998.*1 mm"):
        load_scenario(write(tmp_path, "[steps]\nposition_mm = 1"))
    text = "[steps]\nposition_mm = 0.9\n[controller]\ntolerance_position_m = 1e-4"
    with pytest.raises(ScenarioError, match=r"at most 0.8267.*0.173 mm"):
        load_scenario(write(tmp_path, text))


def test_the_longest_step_the_schema_accepts_is_one_the_loop_takes(tmp_path: Path) -> None:
    from rcmplan.job import run_scenario
    from rcmplan.scene.schema import MAX_JUMP_M

    tolerance_m = 1e-8  # the default
    longest_mm = (MAX_JUMP_M - 3**0.5 * tolerance_m) / (1 + 1e-9) * 1e3
    sc = load_scenario(write(tmp_path, f"[steps]\nposition_mm = {longest_mm!r}"))
    assert sc.steps.position == pytest.approx(longest_mm * 1e-3)
    result = run_scenario(sc)
    assert result.status == "ok", result.message


def test_a_visit_list_longer_than_a_run_may_plan_is_refused_on_load(tmp_path: Path) -> None:
    text = "[points]\nvisits = [" + ", ".join(["'p3'"] * 100_001) + "]"
    with pytest.raises(ScenarioError, match=r"visits = 'a list of 100,001 items'.*100,000"):
        load_scenario(write(tmp_path, text))


def test_visits_planning_too_many_targets_are_refused_before_any_is_planned(
    tmp_path: Path, robot, monkeypatch
) -> None:
    from rcmplan.exceptions import PlanTooLargeError
    from rcmplan.scene import procedures

    def no_planning(*args: object) -> None:
        raise AssertionError("targets planned before the size check")

    monkeypatch.setattr(procedures, "line_targets", no_planning)
    sc = load_scenario(write(tmp_path, "[points]\nvisits = [" + "'p4', " * 20_000 + "]"))
    with pytest.raises(PlanTooLargeError, match=r"20,000 visits.*at most 200,000 targets"):
        sc.phases(robot)
