"""A subretinal-injection episode on the RCM controller, and `rcmplan subretinal`."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from rcmplan.cli import main
from rcmplan.control.augmented import extended_task
from rcmplan.control.limits import TissueDepthLimit
from rcmplan.control.qp import QpSolver
from rcmplan.control.qp_limits import QpLimits
from rcmplan.control.targets import rcm_target, solve_pose
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.needle import closest_lambda
from rcmplan.robot.registry import make_robot
from rcmplan.scene.eye import default_eye, eye_frame
from rcmplan.subretinal.episode import PHASES, EpisodeResult, run_episode
from rcmplan.subretinal.episode_metrics import summarise
from rcmplan.subretinal.episode_settings import EpisodeSettings

# Short episodes: 0.2 mm approach, 0.5 s hover, 1 s hold, a faster advance.
SHORT = EpisodeSettings(hold_s=1.0, start_height_m=200e-6, hover_s=0.5, advance_speed_m_s=0.4e-3)
SEED = 3


@pytest.fixture(scope="module")
def episodes() -> dict[str, EpisodeResult]:
    """kalman and none on the same seed."""
    return {c: run_episode(replace(SHORT, compensation=c, seed=SEED)) for c in ("kalman", "none")}


def test_rcm_holds_within_one_micrometre(episodes: dict[str, EpisodeResult]) -> None:
    for result in episodes.values():
        assert len(result.log) == result.series["t_s"].size > 1000
        assert result.log.max_rcm_deviation() <= 1e-6
        assert summarise(result)["max_rcm_deviation_m"] <= 1e-6


def test_kalman_tracks_better_than_no_compensation(episodes: dict[str, EpisodeResult]) -> None:
    k, n = summarise(episodes["kalman"]), summarise(episodes["none"])
    assert k["status"] == "ok" and k["punctured"]
    assert k["in_band_fraction"] > n["in_band_fraction"]
    assert k["tracking_rms_m"] < n["tracking_rms_m"]
    assert abs(k["depth_error_m"]) < abs(n["depth_error_m"])
    assert k["tracking_rms_m"] < 10e-6  # the hover holds within 10 um of the stand-off


def test_episode_phases_follow_the_plan(episodes: dict[str, EpisodeResult]) -> None:
    s = episodes["kalman"].series
    phases = np.flatnonzero(np.diff(s["phase"])) + 1
    names = [PHASES[int(p)] for p in s["phase"][np.r_[0, phases]]]
    # the target (125 um) lies deeper than the puncture depth (120 um): no withdraw
    assert names == ["approach", "hover", "advance", "hold", "retract", "settle"]
    hold = s["phase"] == PHASES.index("hold")
    assert np.all(s["tissue_state"][hold] == 2)  # punctured for the whole hold
    settle = s["phase"] == PHASES.index("settle")
    assert np.all(s["depth_vs_undeformed_m"][settle] < 0.0)  # back out of the tissue


def test_a_target_shallower_than_the_tent_is_reached_by_puncturing_deeper_then_withdrawing() -> (
    None
):
    # 0.3 of 250 um: 75 um, shallower than the 100 um tent at which the ILM gives way.
    shallow = replace(SHORT, compensation="kalman", seed=SEED, target_fraction=0.3)
    result = run_episode(shallow)
    s, summary = result.series, summarise(result)
    assert summary["status"] == "ok" and summary["punctured"]
    assert summary["in_band_fraction"] == 1.0 and not summary["rpe_breach"]
    assert summary["puncture_depth_m"] == 120e-6
    withdraw = s["phase"] == PHASES.index("withdraw")
    assert withdraw.any() and np.all(np.diff(s["command_depth_m"][withdraw]) < 0)
    advance = s["phase"] == PHASES.index("advance")
    deepest = s["command_depth_m"][advance | withdraw].max()  # the withdraw starts there
    assert deepest == pytest.approx(120e-6, abs=1e-9)
    assert np.all(s["tissue_state"][withdraw | (s["phase"] == PHASES.index("hold"))] == 2)
    # Advancing to the target only, the tip tents the ILM and never passes it.
    direct = summarise(run_episode(replace(shallow, puncture_depth_m=0.0)))
    assert not direct["punctured"] and direct["status"] != "ok"


def test_a_puncture_depth_at_the_depth_limit_is_refused_before_motion() -> None:
    with pytest.raises(InvalidInputError, match=r"puncture_depth_m = 0\.000225.*225 um") as info:
        run_episode(replace(SHORT, puncture_depth_m=225e-6))
    assert info.value.name == "puncture_depth_m"


def test_depth_limit_prevents_an_rpe_breach() -> None:
    # Target 225 um deep (0.9 of 250 um) and an operator pushing 50 um further: 25 um past
    # the RPE. Without the limit the tip breaches; with it the tip stays above the estimated
    # RPE less the 25 um margin.
    deep = replace(SHORT, seed=SEED, target_fraction=0.9, band_fraction=0.05, overshoot_m=50e-6)
    free = summarise(run_episode(replace(deep, depth_limit=False)))
    assert free["rpe_breach"] and free["status"] == "rpe_breach"
    result = run_episode(deep)
    doc = summarise(result)
    assert not doc["rpe_breach"] and doc["max_depth_past_rpe_m"] < 0.0
    s, layers = result.series, result.layers
    tip = s["depth_vs_undeformed_m"] + s["wall_m"]  # below the undisplaced ILM
    past = tip - (s["limit_m"] + layers.thickness_m - deep.rpe_margin_m)
    # Past the bound only by the bound's own jumps (a new estimate moves the prediction), and
    # then the tip backs out at the next period.
    jump = max(0.0, float((-np.diff(s["limit_m"])).max()))
    assert past.max() <= jump + 0.1e-6
    outside = np.flatnonzero(past[:-1] > 0.05e-6)
    assert np.all(tip[outside + 1] < tip[outside])


def _tip_after_steps(limit: TissueDepthLimit | None, deeper_m: float, n: int = 60) -> float:
    """Radius [m] of the tip from the eye centre after n QP steps towards a tip `deeper_m`
    further out along the radial direction, with or without the depth limit."""
    robot = make_robot("iramis")
    eye = default_eye(robot)
    start = eye.center + eye_frame(eye) @ np.array([0.0, 0.0, 10.5e-3])
    q = solve_pose(robot, rcm_target(start, eye.port)).q
    u = (start - eye.center) / np.linalg.norm(start - eye.center)
    target = rcm_target(start + deeper_m * u, eye.port)
    solver = QpSolver(robot, None, 1e-3, limits=QpLimits(), extra_limits=(limit,) if limit else ())
    active = list(robot.active)
    for _ in range(n):
        base, end = robot.needle_point(q, 0.0), robot.needle_point(q, 1.0)
        lam = closest_lambda(base, end, eye.port)
        dq, _ = solver.step(robot, q, lam, target, target - extended_task(robot, q, lam))
        q = q.copy()
        q[active] += dq
    return float(np.linalg.norm(robot.tip(q) - eye.center))


def test_depth_limit_stops_the_tip_at_its_sphere() -> None:
    robot = make_robot("iramis")
    centre = default_eye(robot).center
    floor = 10.5e-3 + 5e-6
    free = _tip_after_steps(None, 20e-6)
    held = _tip_after_steps(TissueDepthLimit(centre, floor), 20e-6)
    assert free == pytest.approx(10.5e-3 + 20e-6, abs=0.2e-6)  # reaches the target
    assert floor - 0.5e-6 <= held <= floor + 0.05e-6  # stops at the sphere
    with pytest.raises(InvalidInputError):
        TissueDepthLimit(centre, floor).set_floor(-1.0)


def test_cli_writes_the_summary(tmp_path: Path) -> None:
    out = tmp_path / "sr"
    code = main(["subretinal", "--hold-s", "0.3", "--compensation", "hold", "--seed", "1",
                 "--out", str(out), "--no-plots", "--json"])  # fmt: skip
    doc = json.loads((out / "summary.json").read_text())
    assert code == (0 if doc["status"] == "ok" else 1)
    for key in ("status", "compensation", "ioct_rate_hz", "latency_s", "max_rcm_deviation_m",
                "tracking_rms_m", "depth_error_m", "in_band_fraction", "rpe_breach",
                "max_depth_past_rpe_m", "segmentation_rms_m"):  # fmt: skip
        assert key in doc
    assert doc["compensation"] == "hold" and doc["latency_s"] == pytest.approx(0.15)
    assert (out / "log.npz").exists() and (out / "episode.npz").exists()
    assert doc["bscans"] == "bscans.npz" and (out / "bscans.npz").exists()  # for rcmplan view


def test_the_table_gives_one_figure_per_row_and_the_segmentation_rows_for_images(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from rcmplan.cli.subretinal import print_table

    out = tmp_path / "sr"
    main(["subretinal", "--hold-s", "0.3", "--out", str(out), "--no-plots", "--json"])
    doc = json.loads((out / "summary.json").read_text())
    capsys.readouterr()
    for estimates in ("image", "noise"):
        print_table({**doc, "ioct_estimates": estimates})
        rows = capsys.readouterr().out.splitlines()[3:]
        named = [r for r in rows if r.startswith("segmented ")]
        if estimates == "noise":
            assert named == []
            continue
        assert [r.split(":")[0] for r in named] == ["segmented ILM per A-line",
                                                    "segmented needle tip"]  # fmt: skip
        assert f"({doc['tip_segmented']} volumes)" in named[1]
        assert all(r.split()[-1] == "um" and "," not in r.split(")")[-1] for r in named)


@pytest.mark.parametrize(
    ("option", "value", "named"),
    [("--ioct-rate-hz", "0", "--ioct-rate-hz"), ("--latency-ms", "-5", "--latency-ms"),
     ("--motion-um", "500", "--motion-um"), ("--hold-s", "0", "--hold-s"),
     ("--heart-rate-sd-bpm", "-3", "--heart-rate-sd-bpm"),
     ("--target-fraction", "1.2", "--target-fraction"),
     ("--puncture-depth-um", "-1", "--puncture-depth-um"),
     ("--puncture-depth-um", "300", "--puncture-depth-um")],
)  # fmt: skip
def test_cli_refuses_a_bad_option(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], option: str, value: str, named: str
) -> None:
    out = tmp_path / "bad"
    assert main(["subretinal", option, value, "--out", str(out), "--no-plots"]) == 2
    assert named in capsys.readouterr().err
    doc = json.loads((out / "summary.json").read_text())
    assert doc["status"] == "invalid_input" and value in doc["message"]


def test_a_bad_plant_is_refused_naming_the_valid_ones(capsys: pytest.CaptureFixture[str]) -> None:
    """The option's choices refuse another plant (exit 2), the settings a typed error."""
    with pytest.raises(SystemExit) as exc:
        main(["subretinal", "--plant", "mujoco-kinematic", "--no-plots"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "invalid choice: 'mujoco-kinematic' (choose from 'kinematic', 'mujoco')" in err
    with pytest.raises(InvalidInputError, match=r"plant.*'kinematic', 'mujoco'") as info:
        EpisodeSettings(plant="rigid")
    assert info.value.name == "plant"
