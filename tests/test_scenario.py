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
    ],
)
def test_broken_scenarios_name_the_key_and_the_allowed_values(
    tmp_path: Path, text: str, pattern: str
) -> None:
    with pytest.raises(ScenarioError, match=pattern):
        load_scenario(write(tmp_path, text))


def test_malformed_toml_and_missing_files_raise(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError, match="valid TOML"):
        load_scenario(write(tmp_path, "[eye\nradius_mm = "))
    with pytest.raises(ScenarioError, match="default"):
        load_scenario(tmp_path / "nope.toml")


def test_units_are_converted_to_si(tmp_path: Path) -> None:
    sc = load_scenario(write(tmp_path, "[eye]\nradius_mm = 11.5\n[steps]\nangle_mrad = 1.5"))
    assert sc.eye_options["radius"] == pytest.approx(0.0115)
    assert sc.steps.angle == pytest.approx(0.0015)


def test_every_plant_a_scenario_may_name_is_registered() -> None:
    from rcmplan.scene.scenario import PLANTS
    from rcmplan.sim.registry import PLANTS as REGISTERED

    assert sorted(PLANTS) == sorted(REGISTERED)
