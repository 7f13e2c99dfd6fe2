"""The command line: main job outputs, summary.json contract, errors and exit codes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from rcmplan.cli import main
from rcmplan.control.log import RunLog
from sigdigits import overlong


def test_robot_prints_the_model(capsys) -> None:
    assert main(["robot"]) == 0
    out = capsys.readouterr().out
    for text in ("prismatic", "assumed", "tip at home [mm]: (-97.000, 76.000, 104.500)", "L5"):
        assert text in out


def test_inject_writes_log_summary_figures_and_report(tmp_path: Path, capsys) -> None:
    assert main(["inject", "--out", str(tmp_path)]) == 0
    s = json.loads((tmp_path / "summary.json").read_text())
    for key in ("scenario", "method", "plant", "status", "phases", "max_rcm_deviation_m",
                "max_tip_error_m", "wall_time_s"):  # fmt: skip
        assert key in s
    assert s["command"] == "inject" and next(iter(s)) == "command"  # named first
    assert s["status"] == "ok" and s["method"] == "pinv" and s["plant"] == "kinematic"
    for p in s["phases"]:
        assert {"name", "max_rcm_deviation_m", "rms_rcm_deviation_m", "final_tip_error_m",
                "iterations", "wall_time_s"} <= set(p)  # fmt: skip
    assert s["max_rcm_deviation_m"] <= 1e-6 and s["max_tip_error_m"] <= 1e-6
    log = RunLog.load_npz(tmp_path / "log.npz")
    assert len(log) == s["iterations"]
    header = (tmp_path / "log.csv").read_text().splitlines()[0]
    assert header.startswith("time_s,phase,solver")
    html = (tmp_path / "report.html").read_text()
    assert html.count("data:image/png;base64,") == 3
    printed = capsys.readouterr().out
    assert "max RCM deviation" in printed
    assert overlong(printed) == []  # every figure through analysis.units.fmt


def test_inject_json_prints_the_summary(tmp_path: Path, capsys) -> None:
    assert main(["inject", "--out", str(tmp_path), "--json", "--no-plots", "--method", "dls"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["method"] == "dls" and s["status"] == "ok"


def test_an_unreachable_scenario_point_is_refused_before_motion(tmp_path: Path, capsys) -> None:
    scenario = tmp_path / "far.toml"
    scenario.write_text('name = "far"\n[points]\np5_mm = [-160.0, 71.5, 102.3]\n')
    out = tmp_path / "out"
    assert main(["inject", "--scenario", str(scenario), "--out", str(out), "--no-plots"]) == 2
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "unreachable_target"
    assert s["message"].startswith("UnreachableTargetError: target unreachable: point p5 at (")
    assert "refused before motion" in capsys.readouterr().err


def test_run_that_stops_midway_keeps_its_partial_log(tmp_path: Path) -> None:
    scenario = tmp_path / "cap.toml"
    scenario.write_text(
        'name = "cap"\n[controller]\nK = [0.01, 0.01, 0.01, 0.01, 0.01, 0.01]\nmax_iterations = 3\n'
    )
    out = tmp_path / "out"
    assert main(["inject", "--scenario", str(scenario), "--out", str(out), "--no-plots"]) == 1
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "no_convergence" and s["message"].startswith("ConvergenceError")
    assert s["command"] == "inject"
    log = RunLog.load_npz(out / "log.npz")
    assert len(log) > 0 and np.all(np.isfinite(log.tip))


FAR_TROCAR = (  # the trocar 50 mm aside: the approach drives L5 past its travel on the way
    'name = "far-trocar"\n[eye]\ntrocar_offset_mm = [14.0, 50.0, -30.0]\n'
    "insertion_angles_rad = [-0.37, -0.3]\n"
)


def test_a_run_stopped_before_the_eye_reports_the_figures_of_its_records(
    tmp_path: Path, capsys
) -> None:
    scenario = tmp_path / "far.toml"
    scenario.write_text(FAR_TROCAR)
    out = tmp_path / "out"
    assert main(["inject", "--scenario", str(scenario), "--out", str(out)]) == 1
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "actuator_limit" and s["iterations"] > 0
    assert [p["name"] for p in s["phases"]] == ["approach"] and not s["phases"][0]["inside_eye"]
    assert s["max_rcm_deviation_m"] is None  # no record held an RCM
    assert s["max_tip_error_m"] == s["phases"][0]["final_tip_error_m"] > 0.0
    assert s["max_waypoint_tip_error_m"] is not None and s["limit_violations"]["travel"] > 0
    printed = capsys.readouterr().out
    assert "no record inside the eye (stopped before entering it)" in printed
    assert "- um" not in printed
    assert "<dd>no record inside the eye</dd>" in (out / "report.html").read_text()
    assert (out / "figures" / "tip_path.png").stat().st_size > 0


def test_a_run_stopped_by_an_unreachable_target_after_moving_keeps_its_figures(
    tmp_path: Path, monkeypatch
) -> None:
    """The approach runs, then the pivot planned from where it ended asks for a pose beyond the
    sliders' travel: status unreachable_target, and the figures of the approach's records."""
    from rcmplan.control.phase import Phase
    from rcmplan.control.targets import pivot_target
    from rcmplan.scene.scenario import Scenario

    planned = Scenario.phases

    def phases(self, robot):
        eye = self.eye(robot)
        far = np.array([pivot_target(eye.port[0], 1.0, 0.2, eye.port)])
        return [*planned(self, robot)[:1], Phase("align", lambda q: far, "rcm")]

    monkeypatch.setattr(Scenario, "phases", phases)
    out = tmp_path / "out"
    assert main(["inject", "--out", str(out), "--no-plots"]) == 1
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "unreachable_target" and s["message"].startswith("UnreachableTarget")
    assert s["iterations"] == len(RunLog.load_npz(out / "log.npz")) > 0
    assert s["max_tip_error_m"] == s["phases"][0]["final_tip_error_m"]
    assert s["max_waypoint_tip_error_m"] is not None


def test_unwritable_output_folder_is_a_clear_error(tmp_path: Path, capsys) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert main(["inject", "--out", str(blocker / "sub")]) == 2
    assert "output folder" in capsys.readouterr().err


def test_compare_runs_each_method_named_by_a_repeated_method_option(tmp_path: Path, capsys) -> None:
    code = main(
        ["compare", "--out", str(tmp_path), "--method", "pinv", "--method", "dls", "--json"]
    )
    doc = json.loads(capsys.readouterr().out)
    assert code == 0
    rows = doc["methods"]
    assert [r["method"] for r in rows] == ["pinv", "dls"]
    assert all(r["max_rcm_deviation_m"] <= 1e-6 for r in rows)
    for r in rows:
        assert r["wall_time_per_iteration_s"] == pytest.approx(r["wall_time_s"] / r["iterations"])
    assert doc["execution_path"] in ("compiled where a method has a kernel", "reference")
    for r in rows:  # the path each run recorded for itself
        summary = json.loads((tmp_path / r["method"] / "summary.json").read_text())
        assert r["execution_path"] == summary["execution_path"]
        assert summary["command"] == "compare"
        assert r["compiled_phases"] == summary["compiled_phases"]
    assert json.loads((tmp_path / "summary.json").read_text()) == doc
    assert (tmp_path / "figures" / "compare.png").stat().st_size > 0


def test_compare_has_no_methods_option_any_more(capsys) -> None:
    with pytest.raises(SystemExit):
        main(["compare", "--methods", "pinv"])
    assert "unrecognized arguments: --methods" in capsys.readouterr().err


def test_bad_method_is_refused_by_the_parser(capsys) -> None:
    with pytest.raises(SystemExit):
        main(["inject", "--method", "nope"])
    assert "invalid choice" in capsys.readouterr().err


def test_malformed_scenario_file_exits_non_zero_with_status(tmp_path: Path, capsys) -> None:
    scenario = tmp_path / "bad.toml"
    scenario.write_text("[eye]\nradius_mm = -3\n")
    out = tmp_path / "out"
    assert main(["inject", "--scenario", str(scenario), "--out", str(out)]) == 2
    assert "radius_mm" in capsys.readouterr().err
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "invalid_scenario"
    assert s["message"].startswith("ScenarioError") and "[3, 20]" in s["message"]


def test_a_full_disk_while_writing_is_a_one_line_error_and_leaves_no_half_written_file(
    tmp_path: Path, capsys, monkeypatch
) -> None:
    import errno

    def full(self, path) -> None:
        with open(path, "w") as fh:
            fh.write("time_s,pha")  # a truncated start, as a full disk leaves it
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(RunLog, "_write_csv", full)
    assert main(["inject", "--out", str(tmp_path), "--no-plots"]) == 2
    assert "No space left on device" in capsys.readouterr().err
    assert not (tmp_path / "log.csv").exists()
    assert not [p.name for p in tmp_path.iterdir() if ".tmp" in p.name]
