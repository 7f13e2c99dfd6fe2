"""Refusals answer in the frame and the units the user typed: eye-frame millimetres for
--target and --path, the option's own name and unit for a number out of range, the key and
unit of a robot file; each before any motion, with summary.json saying why."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

import rcmplan
from rcmplan._jit import FirstCompile
from rcmplan.cli import main
from rcmplan.robot.registry import make_robot
from rcmplan.scene.eye_text import to_eye_mm
from rcmplan.scene.scenario import load_scenario

BASE_FRAME_TUPLE = re.compile(r"\(target \(")  # the base-frame X_ext the core appends


def refused(argv: list[str], out: Path, capsys: pytest.CaptureFixture[str]) -> str:
    """The one error line of a command refused with exit 2 (summary.json written), beside the
    first-compile line of a process that compiles a kernel (`_jit.FirstCompile`: whether it
    comes depends on the numba cache the tests find)."""
    assert main([*argv, "--out", str(out)]) == 2
    err = [e for e in capsys.readouterr().err.strip().splitlines() if e != FirstCompile.LINE]
    assert len(err) == 1
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] != "ok" and summary["message"]
    return err[0]


@pytest.mark.parametrize(
    ("target", "said"),
    [
        ("30,0,0", "lies 19 mm outside the retina, the sphere of radius 11 mm about the eye "
                   "centre (the origin)"),
        ("0,0,40", "lies 29 mm outside the retina"),
        ("0,0,-11.5", "lies 0.5 mm outside the retina"),
        ("0,8,7", "is out of reach: slider L1 would be at 41.7905 mm, 1.79 mm beyond its travel "
                  "[-40, 40] mm"),
        ("-8,0,7", "is out of reach: slider L3 would be at 48.2068 mm, 8.21 mm beyond"),
    ],
)  # fmt: skip
def test_an_unreachable_target_is_answered_in_eye_frame_millimetres(
    target: str, said: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    line = refused(["inject", f"--target={target}", "--no-plots"], tmp_path, capsys)
    assert f"--target {target} (mm, eye frame) {said}" in line
    assert not BASE_FRAME_TUPLE.search(line) and " m " not in line and " m]" not in line
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["status"] == "unreachable_target" and said in summary["message"]
    assert not (tmp_path / "log.npz").exists()  # refused before any motion


def test_a_path_point_out_of_reach_is_named_by_its_place_and_values(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    csv = tmp_path / "path.csv"
    csv.write_text("x_mm,y_mm,z_mm\n0,0,4\n1,0,4\n0,0,12\n")
    line = refused(["inject", "--path", str(csv), "--no-plots"], tmp_path / "out", capsys)
    assert "--path point 3 (0, 0, 12) (mm, eye frame) lies 1 mm outside the retina" in line


def test_a_second_target_is_named_and_the_first_passes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["inject", "--target", "1,0,9", "--target", "-1,0,12", "--no-plots"]
    line = refused(argv, tmp_path, capsys)
    assert "--target -1,0,12 (mm, eye frame) lies 1.042 mm outside the retina" in line
    assert "--target 1,0,9" not in line


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (["sweep", "--max-angle", "95"], "--max-angle = 95.0 is invalid; valid: a finite "
                                         "number in (0, 90)"),
        (["sweep", "--targets", "0"], "--targets = 0 is invalid"),
        (["sweep", "--workers", "0"], "--workers = 0 is invalid"),
        (["sweep", "--timeout", "-1"], "--timeout = -1.0 is invalid"),
        (["sweep", "--gain-search", "grid", "--rcm-bound", "-1"],
         "--rcm-bound = -1.0 is invalid; valid: a finite number in (0, 10000]"),
        (["sweep", "--gain-search", "grid", "--subsample", "0"], "--subsample = 0 is invalid"),
        (["teleop", "--tremor-um", "-5"], "--tremor-um = -5.0 is invalid; valid: a finite "
                                          "number in [0, 5000]"),
        (["teleop", "--scale", "100"], "--scale = 100.0 is invalid; valid: a finite number in "
                                       "[1, 50]"),
        (["teleop", "--seed", "-1"], "--seed = -1 is invalid"),
        (["render", "--demo", "--fps", "-1"], "--fps = -1.0 is invalid"),
        (["render", "--demo", "--frames", "0"], "--frames = 0 is invalid"),
    ],
)  # fmt: skip
def test_a_number_out_of_range_is_named_as_the_option_in_its_unit(
    argv: list[str], said: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert said in refused(argv, tmp_path, capsys)


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (["--width", "5000"], "--width = 5000 is invalid; valid: an integer in [16, 1280]"),
        (["--height", "8"], "--height = 8 is invalid; valid: an integer in [16, 960]"),
        (["--fps", "0"], "--fps = 0.0 is invalid"),
    ],
)  # fmt: skip
def test_render_options_are_refused_before_the_scenario_runs(
    argv: list[str], said: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert said in refused(["render", *argv], tmp_path, capsys)
    assert not (tmp_path / "log.npz").exists()  # the scenario did not run


def test_render_mp4_without_the_video_extra_is_refused_before_the_scenario_runs(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import sys

    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)
    assert "rcmplan[video]" in refused(["render", "--format", "mp4"], tmp_path, capsys)
    assert not (tmp_path / "log.npz").exists()


def test_the_thesis_method_on_a_curved_needle_is_refused_before_the_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["inject", "--scenario", "curved", "--method", "pinv-thesis", "--no-plots"]
    line = refused(argv, tmp_path, capsys)
    assert "method = 'pinv-thesis' is invalid; valid: one of ('pinv', 'dls', 'qp') for a " \
        "curved needle" in line  # fmt: skip
    assert not (tmp_path / "log.npz").exists()


def test_a_robot_file_with_a_bad_value_names_the_file_the_key_and_its_unit(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    robot = tmp_path / "short.toml"
    robot.write_text('[robot]\nname = "short"\nurdf = "arm.urdf"\nflange = "tool0"\n'
                     "needle_length_mm = -5.0\n")  # fmt: skip
    line = refused(["inject", "--robot", str(robot), "--no-plots"], tmp_path / "out", capsys)
    assert f"robot file '{robot}': [robot] needle_length_mm = -5.0 is invalid" in line
    assert "(0, 1000] mm" in line


def test_a_scenario_point_out_of_reach_is_refused_before_motion_in_eye_frame_millimetres(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["scenario", "--show", "default"]) == 0
    text = capsys.readouterr().out.replace("spread_rad = 0.12 ", "spread_rad = 0.6 ")
    (tmp_path / "wide.toml").write_text(text)
    line = refused(["inject", "--scenario", str(tmp_path / "wide.toml"), "--no-plots"],
                   tmp_path / "out", capsys)  # fmt: skip
    assert line.startswith("rcmplan inject: refused before motion: ")
    assert re.search(r"point p4 at \(-?[\d.]+, -?[\d.]+, -?[\d.]+\) mm \(eye frame\) is out of "
                     r"reach: slider L1 would be at -99\.8\d* mm", line), line  # fmt: skip
    assert not BASE_FRAME_TUPLE.search(line)


def test_a_planned_target_refused_before_motion_names_its_phase_and_its_tip_in_the_eye_frame(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The Panda's curved needle bent along the flange's x asks joint 7 for the bend-down roll
    of p5, 0.49 rad it cannot turn (`panda.toml` bends it along +y for that reason): the
    controller's check before motion refuses the first target beyond travel, and the line
    names the phase, the target's index and its tip in the eye frame, not X_c in the base
    frame."""
    shipped = Path(rcmplan.__file__).parent / "robots" / "panda.toml"
    text = shipped.read_text().replace('needle_bend = "+y"\n', "")
    (tmp_path / "panda_x.toml").write_text(text)
    line = refused(["inject", "--scenario", "curved", "--robot", str(tmp_path / "panda_x.toml"),
                    "--no-plots"], tmp_path / "out", capsys)  # fmt: skip
    assert line.startswith("rcmplan inject: refused before motion: UnreachableTargetError: ")
    found = re.search(r"phase 'p3-p5', target (\d+) of 0\.\.(\d+): joint panda_joint7 = "
                      r"(-?[\d.]+) rad is beyond its travel \[-2\.8973, 2\.8973\] rad \(its tip "
                      r"at x = (-?[\d.]+), y = (-?[\d.]+), z = (-?[\d.]+) mm in the eye frame, "
                      r"the needle's roll (-?[\d.]+) rad\)$", line)  # fmt: skip
    assert found, line
    k, last = int(found[1]), int(found[2])
    assert abs(float(found[3])) > 2.8973
    sc = load_scenario("curved").with_robot(str(tmp_path / "panda_x.toml"))
    robot = sc.needle.fit(make_robot(sc.robot))
    (plan,) = [ph.plan(robot.home) for ph in sc.phases(robot) if ph.name == "p3-p5"]
    assert last == len(plan) - 1 and 0 < k < last  # the named target of that phase
    stated = [float(found[i]) for i in (4, 5, 6, 7)]
    expected = [*to_eye_mm(sc.eye(robot), plan[k, :3]), plan[k, 3]]
    assert stated == pytest.approx(expected, rel=1e-3, abs=1e-3)  # 4 significant digits
    assert not BASE_FRAME_TUPLE.search(line)
