"""report.html and summary.json: readable numbers, settings as a table, units in every key."""

from __future__ import annotations

import html
import json
import re
from pathlib import Path

import numpy as np
import pytest

from rcmplan import Iramis
from rcmplan.analysis.limits import KINDS
from rcmplan.analysis.report import summary_json, write_outputs, write_report
from rcmplan.analysis.settings_table import settings_rows
from rcmplan.analysis.summary_text import (
    VIOLATION_MEANING,
    execution_text,
    summary_lines,
    um,
    violations_label,
    violations_text,
)
from rcmplan.analysis.units import fmt
from rcmplan.cli.output import print_summary
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


def test_an_arms_slider_block_names_each_of_its_joints_in_its_own_unit() -> None:
    """The Panda (7 revolute joints): one entry per joint, named as the arm names it, in
    radians, each the range the log used; the block had named six with iRAM!S's slider names
    and units, dropped the seventh, and failed on an arm of five."""
    result = run_scenario(load_scenario("default").with_robot("panda"))
    s = summary_json(result)
    assert list(s["sliders"]) == [f"panda_joint{k}" for k in range(1, 8)]
    for i, block in enumerate(s["sliders"].values()):
        assert block["lower_used_rad"] == result.log.sliders[:, i].min()
        assert block["upper_used_rad"] == result.log.sliders[:, i].max()
        assert 0.0 < block["min_margin_rad"] < result.robot.upper[i] - result.robot.lower[i]


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


@pytest.fixture(scope="module")
def qp_report(tmp_path_factory):
    """The default injection with the QP (limited waypoints, every limit held) and its page."""
    result = run_scenario(load_scenario("default").with_method("qp"))
    page = write_report(result, tmp_path_factory.mktemp("qp"), {}).read_text()
    return result, page


def test_report_carries_the_limits_waypoints_and_path_the_command_line_prints(
    qp_report, capsys
) -> None:
    result, page = qp_report
    s = summary_json(result)
    print_summary(result)
    printed = capsys.readouterr().out
    assert s["limited_waypoints"] > 0 and s["execution_path"] == "compiled"
    for line in summary_lines(s):
        assert line in printed
    for shared in (um(s["max_waypoint_tip_error_m"]), violations_text(s), execution_text(s),
                   f"{s['limited_waypoints']:,} limited"):  # fmt: skip
        assert shared in printed
    assert f"<dt>max waypoint tip error</dt><dd>{um(s['max_waypoint_tip_error_m'])}</dd>" in page
    assert f"<dt>limited waypoints</dt><dd>{s['limited_waypoints']:,}</dd>" in page
    label = html.escape(violations_label(s))
    assert f"<div><dt>{label}</dt><dd>{violations_text(s)}</dd></div>" in page
    assert violations_label(s) == "records beyond the QP's limits"  # the QP's own: no "which"
    assert f"<dd>{execution_text(s)}</dd>" in page
    for kind, n in s["limit_violations"].items():
        assert f"<td class='l'>{kind}</td><td class='l'>" in page
        assert f"{html.escape(VIOLATION_MEANING[kind])}</td><td>{n:,}</td>" in page
    for w in s["limited_waypoint_list"]:
        row = (f"<td class='l'>{w['phase']}</td><td class='l'>{', '.join(w['active_limits'])}"
               f"</td><td>{w['step']:,}</td><td>{fmt(w['tip_error_m'], 'um')}</td>")  # fmt: skip
        assert row in page


def test_each_tip_error_has_one_name_in_the_table_the_lines_and_the_report(qp_report) -> None:
    """max tracking error (every iteration), max waypoint tip error (a step's end) and max tip
    error at the targets (a phase's end inside the eye): three quantities, three names."""
    result, page = qp_report
    s = summary_json(result)
    text = "\n".join(summary_lines(s))
    assert "max tip error at the targets" in text and "max waypoint tip error" in text
    assert "tracking" not in text  # the tracking error is the phase table's column alone
    tracking = max(p["max_tracking_error_m"] for p in s["phases"])
    assert tracking > s["max_waypoint_tip_error_m"] > s["max_tip_error_m"]
    assert "<th>max tracking error [um]</th>" in page
    assert f"<dt>max tip error at the targets</dt><dd>{um(s['max_tip_error_m'])}</dd>" in page


def test_the_violation_counts_of_a_method_without_limits_say_it_does_not_hold_them() -> None:
    assert violations_label({"method": "pinv"}) == (
        "records beyond the QP's limits, which pinv does not hold"
    )
    lines = summary_lines({"method": "dls", "max_rcm_deviation_m": 4e-7, "max_tip_error_m": 0.0,
                           "iterations": 10, "wall_time_s": 0.01,
                           "max_waypoint_tip_error_m": 1e-9, "limited_waypoints": 0,
                           "limit_violations": {"speed": 804, "retina": 12}})  # fmt: skip
    assert lines[1].endswith("which dls does not hold: speed 804, retina 12")
