"""The command line as a whole: descriptions, choice lists, JSON, fixed procedures, tip input,
closed pipes and one-line errors."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rcmplan._jit import FirstCompile
from rcmplan.cli import COMMANDS, build_parser, command_parsers, main
from rcmplan.cli.tip_input import parse_point, read_path_csv
from rcmplan.exceptions import InvalidInputError
from rcmplan.scene.eye import default_eye, eye_frame
from rcmplan.scene.eye_text import to_base

SRC = Path(__file__).resolve().parents[1] / "src"


@pytest.mark.parametrize("name", [*COMMANDS, "spiral"])
def test_every_command_has_a_description_in_its_help(name) -> None:
    assert command_parsers(build_parser())[name].description


def test_render_plant_and_camera_are_choice_lists() -> None:
    options = {a.dest: a for a in command_parsers(build_parser())["render"]._actions}
    assert options["plant"].choices and "kinematic" in options["plant"].choices
    assert options["camera"].choices == ("closeup", "overview")


def test_robot_json_prints_the_model_with_units_in_the_keys(capsys) -> None:
    assert main(["robot", "--json"]) == 0
    model = json.loads(capsys.readouterr().out)
    assert model["home_tip_m"] == pytest.approx([-0.097, 0.076, 0.1045])
    assert set(model["sliders"][0]) == {"slider", "lower_m", "upper_m", "speed_m_per_s"}
    assert set(model["sliders"][5]) == {"slider", "lower_rad", "upper_rad", "speed_rad_per_s"}


def test_spiral_on_an_injection_scenario_runs_a_spiral_and_says_so(tmp_path, capsys) -> None:
    assert main(["spiral", "--scenario", "default", "--out", str(tmp_path), "--no-plots"]) == 0
    captured = capsys.readouterr()
    assert "names procedure 'injection'; running the spiral" in captured.err
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["procedure"] == "spiral"
    assert "spiral" in [p["name"] for p in summary["phases"]]


def test_inject_on_its_own_scenario_prints_no_note(tmp_path, capsys) -> None:
    assert main(["inject", "--out", str(tmp_path), "--no-plots"]) == 0
    assert "names procedure" not in capsys.readouterr().err


def test_the_eye_frame_puts_the_trocar_on_the_negative_z_axis(robot) -> None:
    eye = default_eye(robot)
    R = eye_frame(eye)
    assert np.allclose(R.T @ R, np.eye(3)) and np.linalg.det(R) == pytest.approx(1.0)
    trocar_eye_mm = R.T @ (eye.port - eye.center) * 1e3
    assert trocar_eye_mm == pytest.approx([0.0, 0.0, -eye.radius * 1e3], abs=1e-9)
    assert np.allclose(to_base(eye, np.zeros((1, 3))), eye.center)


def test_inject_target_visits_the_given_eye_frame_point(tmp_path, robot) -> None:
    assert main(["inject", "--target", "1.5,-2,6", "--out", str(tmp_path), "--no-plots"]) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert [p["name"] for p in summary["phases"]][3:5] == ["p3-p4", "p4-p3"]
    from rcmplan.control.log import RunLog

    log = RunLog.load_npz(tmp_path / "log.npz")
    end = log.tip[log.phase == log.phase_names.index("p3-p4")][-1]
    expected = to_base(default_eye(robot), np.array([[1.5, -2.0, 6.0]]))[0]
    assert np.linalg.norm(end - expected) < 1e-9


def test_inject_path_follows_the_csv_points(tmp_path, robot) -> None:
    csv = tmp_path / "path.csv"
    csv.write_text("x_mm,y_mm,z_mm\n0,0,4\n1,0,4\n1,1,4.5\n")
    out = tmp_path / "out"
    assert main(["inject", "--path", str(csv), "--out", str(out), "--no-plots"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["procedure"] == "path" and summary["status"] == "ok"
    from rcmplan.control.log import RunLog

    log = RunLog.load_npz(out / "log.npz")
    last = log.tip[log.phase == log.phase_names.index("path")][-1]
    expected = to_base(default_eye(robot), np.array([[1.0, 1.0, 4.5]]))[0]
    assert np.linalg.norm(last - expected) < 1e-9


def test_a_malformed_target_or_path_is_a_clear_error(tmp_path) -> None:
    with pytest.raises(InvalidInputError, match="X,Y,Z"):
        parse_point("1,2")
    bad = tmp_path / "bad.csv"
    bad.write_text("1,2,3\n4,five,6\n")
    with pytest.raises(InvalidInputError, match="bad rows: \\[1\\]"):
        read_path_csv(bad)


def test_a_target_outside_the_eye_is_refused_before_motion(tmp_path, capsys) -> None:
    assert main(["inject", "--target", "0,0,30", "--out", str(tmp_path), "--no-plots"]) == 2
    assert "outside the retina" in capsys.readouterr().err
    assert json.loads((tmp_path / "summary.json").read_text())["status"] == "unreachable_target"
    assert not (tmp_path / "log.npz").exists()


def test_a_closed_pipe_ends_the_command_without_a_traceback() -> None:
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    cmd = [sys.executable, "-m", "rcmplan", "robot", "--json"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    assert proc.stdout is not None and proc.stderr is not None
    proc.stdout.close()  # the reader is gone before the command writes its first line
    err = proc.stderr.read().decode()
    proc.wait(timeout=120)
    assert "Traceback" not in err and "BrokenPipeError" not in err


def test_a_run_that_stops_early_reports_its_error_on_one_line(tmp_path, capsys) -> None:
    scenario = tmp_path / "cap.toml"
    scenario.write_text(
        "[controller]\nK = [0.01, 0.01, 0.01, 0.01, 0.01, 0.01]\nmax_iterations = 3\n"
    )
    assert (
        main(["inject", "--scenario", str(scenario), "--out", str(tmp_path / "o"), "--no-plots"])
        == 1
    )
    err = [e for e in capsys.readouterr().err.strip().splitlines() if e != FirstCompile.LINE]
    assert len(err) == 1 and "array(" not in err[0]
    assert "no convergence" in err[0] and "exceeds tolerance (1e-08, 1e-07" in err[0]


def test_reproduce_puts_each_thesis_report_with_its_source_beside_both_settings(
    tmp_path, capsys
) -> None:
    assert main(["reproduce", "--out", str(tmp_path), "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["experiments"]
    assert [r["experiment"] for r in rows] == ["pivot", "p3-p7", "spiral"]
    for r in rows:
        assert r["thesis_reported"]["source"].startswith("sec. 4.")
        assert {"thesis", "rcmplan", "hypothesis"} <= set(r)
        assert (tmp_path / "figures" / f"{r['experiment']}.png").stat().st_size > 0
    pivot = rows[0]["thesis_reported"]
    assert pivot["rcm_deviation_bound_m"] == pytest.approx(30e-6)


def test_the_hypothesised_vrep_setup_gives_the_thesiss_pivot_drift_and_iterations() -> None:
    from rcmplan.cli import thesis_hypothesis

    o = thesis_hypothesis.pivot()
    x_drift = float(np.nanmax(np.abs(o.log.rcm_deviation()[:, 0])))
    assert 20e-6 < x_drift < 40e-6  # thesis: +-3e-5 m (sec. 4.1.2)
    assert 2.5 <= o.iterations / o.steps <= 3.5  # thesis: 1350 points for 500 steps
