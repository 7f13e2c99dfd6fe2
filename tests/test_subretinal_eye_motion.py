"""Whole-eye motion in a subretinal episode: the trocar moves with the eye and the RCM follows it."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from rcmplan.cli import main
from rcmplan.control.targets import rcm_target, rcm_targets
from rcmplan.exceptions import InvalidInputError
from rcmplan.subretinal.episode import Episode, EpisodeResult, run_episode
from rcmplan.subretinal.episode_draws import DrawRanges, draw_episode
from rcmplan.subretinal.episode_metrics import summarise
from rcmplan.subretinal.episode_settings import EpisodeSettings

# A short episode with 500 um of eye drift per axis, its correlation time shortened to 2 s so
# that the smooth drift moves the eye by hundreds of um within the episode's 3 s.
DRIFT = EpisodeSettings(hold_s=0.5, hover_s=0.3,
                        start_height_m=200e-6, advance_speed_m_s=0.4e-3, eye_drift_m=500e-6,
                        eye_drift_time_s=2.0, seed=2)  # fmt: skip


@pytest.fixture(scope="module")
def moving() -> EpisodeResult:
    return run_episode(DRIFT)


def _line_distance(base: np.ndarray, tip: np.ndarray, trocar: np.ndarray) -> np.ndarray:
    """Distance [m] from each needle line (base to tip, (N, 3) each) to trocar (N, 3)."""
    u = (tip - base) / np.linalg.norm(tip - base, axis=1, keepdims=True)
    w = trocar - base
    return np.linalg.norm(w - np.sum(w * u, axis=1, keepdims=True) * u, axis=1)


def test_the_rcm_follows_the_moving_trocar(moving: EpisodeResult) -> None:
    log, doc = moving.log, summarise(moving)
    assert doc["status"] == "ok" and doc["punctured"] and doc["eye_drift_m"] == 500e-6
    away = np.linalg.norm(log.trocar - log.trocar[0], axis=1)
    assert away.max() > 50e-6 and doc["max_trocar_displacement_m"] == pytest.approx(away.max())
    # Against the trocar where it is: within the bound, and no more than the trocar's own move
    # in one period (the step was planned to where the trocar was when it was read).
    deviation = moving.series["rcm_deviation_m"]
    assert deviation.max() <= min(DRIFT.rcm_bound_m, doc["max_trocar_step_m"] + 1e-9)
    assert doc["max_rcm_deviation_m"] == pytest.approx(deviation.max())
    # Each step puts the needle line through the trocar it was planned for.
    assert _line_distance(log.base[1:], log.tip[1:], log.trocar[:-1]).max() < 1e-9
    # Against the trocar where it was at the start, the needle is far off: it did follow.
    start = np.broadcast_to(log.trocar[0], log.trocar.shape)
    assert _line_distance(log.base, log.tip, start).max() > 50e-6


def test_the_retina_moves_with_the_eye(moving: EpisodeResult) -> None:
    # The depth below the ILM is about the moved centre: the hold stays in the target band and
    # the RPE is never reached although the eye moved further than the retina is thick.
    doc = summarise(moving)
    assert doc["in_band_fraction"] == 1.0 and not doc["rpe_breach"]
    assert doc["max_trocar_displacement_m"] > moving.layers.thickness_m


def test_eye_drift_leaves_the_wall_motion_and_noise_of_a_seed() -> None:
    # The stand-in's noise is drawn up front: the same with and without the eye's drift.
    noise = replace(DRIFT, ioct_estimates="noise")
    still, moved = Episode(replace(noise, eye_drift_m=0.0)), Episode(noise)
    assert still.ioct.stand_in is not None and moved.ioct.stand_in is not None
    assert still.ioct.stand_in.estimate_m.size > 100
    np.testing.assert_array_equal(still.ioct.stand_in.estimate_m, moved.ioct.stand_in.estimate_m)
    np.testing.assert_array_equal(still.wall_m, moved.wall_m)
    assert np.all(still.trocar_m == still.trocar_m[0])
    assert np.ptp(moved.trocar_m, axis=0).max() > 50e-6


@pytest.mark.parametrize("value", [-1e-6, 5.1e-3, float("nan")])
def test_bad_eye_drift_is_refused(value: float) -> None:
    with pytest.raises(InvalidInputError, match="eye_drift_m"):
        EpisodeSettings(eye_drift_m=value)


def test_the_rcm_follows_the_moving_trocar_on_the_mujoco_plant() -> None:
    # The servos lag the command, so the deviation exceeds the trocar's move per period; the
    # floor on MuJoCo is 2 um. The eye in the MuJoCo scene has no contacts: only the trocar
    # the controller follows moves. Correlation time 5 s: the trocar moves about 0.4 um per
    # period, some 40 times a drifting head's speed (docs/subretinal.md, whole-eye motion).
    result = run_episode(replace(DRIFT, plant="mujoco", eye_drift_time_s=5.0))
    log, doc = result.log, summarise(result)
    assert doc["status"] == "ok" and doc["punctured"] and doc["plant"] == "mujoco"
    assert doc["max_trocar_displacement_m"] > 50e-6
    assert doc["max_rcm_deviation_m"] <= 2e-6
    start = np.broadcast_to(log.trocar[0], log.trocar.shape)
    assert _line_distance(log.base, log.tip, start).max() > 50e-6  # it followed


def test_drawn_eye_drift_keeps_the_other_conditions() -> None:
    still = draw_episode(DrawRanges(), 4, 7)
    drawn = draw_episode(DrawRanges(eye_drift_m=(0.0, 300e-6)), 4, 7)
    assert 0.0 < drawn.eye_drift_m <= 300e-6 and still.eye_drift_m == 0.0
    assert drawn.target_fraction == still.target_fraction
    assert drawn.ioct_rate_hz == still.ioct_rate_hz
    with pytest.raises(InvalidInputError, match=r"eye_drift_m\[1\]"):
        DrawRanges(eye_drift_m=(0.0, 6e-3))


@pytest.mark.parametrize("value", ["-5", "6000"])
def test_cli_refuses_a_bad_eye_drift(tmp_path: Path, value: str) -> None:
    out = tmp_path / "bad"
    assert main(["subretinal", "--eye-drift-um", value, "--out", str(out), "--no-plots"]) == 2
    doc = json.loads((out / "summary.json").read_text())
    assert doc["status"] == "invalid_input" and "--eye-drift-um" in doc["message"]


def test_the_depth_limit_moves_with_the_eye() -> None:
    # Target 225 um deep (0.9 of 250 um) and an operator pushing 50 um further: 25 um past the
    # RPE of the moving eye. Without the limit the tip breaches; the limit about the moved
    # centre holds it at its sphere (the estimated RPE less 25 um), past it only by what the
    # eye moves towards the tip faster than the limit's recovery (1 um a period): never by the
    # 25 um margin. A limit about the eye's first centre would be off by the eye's motion along
    # the normal (here over 50 um).
    deep = replace(DRIFT, target_fraction=0.9, band_fraction=0.05, overshoot_m=50e-6)
    free = summarise(run_episode(replace(deep, depth_limit=False)))
    assert free["rpe_breach"]
    ep = Episode(deep)
    along = (ep.center_m - ep.center_m[0]) @ ep.normal_base
    assert np.abs(along).max() > 50e-6
    result = ep.run()
    doc, s = summarise(result), result.series
    assert doc["status"] == "ok" and not doc["rpe_breach"]
    tip = s["depth_vs_undeformed_m"] + s["wall_m"]  # below the ILM of the moved eye
    past = tip - (s["limit_m"] + result.layers.thickness_m - deep.rpe_margin_m)
    assert -5e-6 < past.max() < deep.rpe_margin_m


def test_rcm_targets_take_a_trocar_per_row() -> None:
    rng = np.random.default_rng(5)
    trocars = np.array([0.02, 0.001, -0.002]) + rng.uniform(-1e-3, 1e-3, (20, 3))
    tips = trocars + rng.uniform(-5e-3, 5e-3, (20, 3)) + [0.01, 0.0, 0.0]
    rows = np.array([rcm_target(tip, trocar) for tip, trocar in zip(tips, trocars, strict=True)])
    np.testing.assert_allclose(rcm_targets(tips, trocars), rows, rtol=0.0, atol=1e-12)
    with pytest.raises(InvalidInputError, match="trocar"):
        rcm_targets(tips, trocars[:5])


def test_the_bscans_show_the_tip_relative_to_the_moving_eye(moving: EpisodeResult) -> None:
    # The tip's place in the B-scans of a moving eye is nearly that of the same seed with the
    # eye still (the tracking differs by micrometres), not off by the eye's motion.
    from rcmplan.subretinal.episode_bscans import episode_bscans

    still = run_episode(replace(DRIFT, eye_drift_m=0.0))
    a, b = episode_bscans(moving), episode_bscans(still)
    np.testing.assert_array_equal(a.t_acq_s, b.t_acq_s)
    assert np.abs(a.tip_m - b.tip_m).max() < 10e-6
    assert summarise(moving)["max_trocar_displacement_m"] > 100e-6
