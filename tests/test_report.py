"""report.html and summary.json: readable numbers, settings as a table, units in every key."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from rcmplan import Iramis
from rcmplan.analysis.limits import KINDS
from rcmplan.analysis.report import summary_json, write_outputs
from rcmplan.analysis.settings_table import settings_rows
from rcmplan.job import run_scenario
from rcmplan.scene.scenario import load_scenario

UNIT_SUFFIXES = ("_m", "_s", "_rad")
# Counts and indices: iterations, steps, limited waypoints and a waypoint's step index, and the
# records breaking each kind of limit (`limit_violations`).
COUNTS = {"iterations", "steps", "limited_waypoints", "step", *KINDS}


@pytest.fixture(scope="module")
def outputs(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("inject")
    result = run_scenario(load_scenario("default"))
    write_outputs(result, out, scenario_text="# the scenario file\nname = 'default'\n")
    return out


def numeric_keys(obj: object, key: str = "") -> list[str]:
    """Keys of every number in a JSON tree (list items inherit their list's key)."""
    if isinstance(obj, dict):
        return [k2 for k, v in obj.items() for k2 in numeric_keys(v, k)]
    if isinstance(obj, list):
        return [k2 for v in obj for k2 in numeric_keys(v, key)]
    return [key] if isinstance(obj, int | float) and not isinstance(obj, bool) else []


def test_every_number_in_summary_json_has_a_unit_in_its_key_or_is_a_count(outputs) -> None:
    summary = json.loads((outputs / "summary.json").read_text())
    for key in numeric_keys(summary):
        assert key in COUNTS or key.endswith(UNIT_SUFFIXES), key


def test_the_slider_block_names_each_slider_with_metres_or_radians() -> None:
    s = summary_json(run_scenario(load_scenario("default")))
    assert list(s["sliders"]) == ["L1", "L2", "L3", "L4", "L5", "q5"]
    assert set(s["sliders"]["L1"]) == {"lower_used_m", "upper_used_m", "min_margin_m"}
    assert set(s["sliders"]["q5"]) == {"lower_used_rad", "upper_used_rad", "min_margin_rad"}
    assert s["simulated_time_s"] > 0.0


def test_report_shows_settings_as_a_table_without_reprs_or_float_noise(outputs) -> None:
    page = (outputs / "report.html").read_text()
    assert "MethodSettings(" not in page and "Tolerance(" not in page
    assert not re.search(r"\d\.\d{10,}", page.split("<h2>Scenario file")[0].split("base64")[0])
    assert "<td class='l'>trocar radius</td><td class='l'>0.45</td><td class='l'>mm</td>" in page


def test_report_has_headline_phase_table_captioned_figures_and_the_scenario(outputs) -> None:
    page = (outputs / "report.html").read_text()
    assert "max RCM deviation inside the eye" in page and "um</dd>" in page
    assert page.count("<figcaption>") == page.count("data:image/png;base64,") == 3
    assert "<td class='l'>p3-p4</td>" in page
    assert "# the scenario file" in page


def test_settings_rows_show_the_scenario_values_in_scenario_units() -> None:
    rows = {
        (g, n): (v, u) for g, n, v, u in settings_rows(load_scenario("grazing-spiral"), Iramis())
    }
    assert rows[("points", "p3 depth on the axis")] == ("22.1846", "mm")
    assert rows[("qp", "retina margin")] == ("0.25", "mm")
    assert rows[("controller", "gains K (diagonal)")] == ("1, 1, 1, 1, 1, 1", "")


def test_a_path_run_lists_its_tip_points_in_the_settings(robot) -> None:
    from rcmplan.cli.tip_input import with_path

    sc = with_path(load_scenario("default"), np.array([[0.0, 0.0, 4.0], [1.0, 0.0, 4.0]]))
    rows = [r for r in settings_rows(sc, robot) if r[0] == "path"]
    assert len(rows) == 1 and rows[0][1] == "2 tip points, base frame" and rows[0][3] == "mm"
