"""What an episode's controller sees (`episode_ioct`): each estimate is the segmentation of the
B-scan rendered from the episode's true state at its acquisition, a volume without an ILM
delivers nothing, the summary reports the error of what was received, and the measured-noise
stand-in stays available as an option."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from rcmplan.cli import main
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.registry import make_robot
from rcmplan.scene.eye import default_eye
from rcmplan.subretinal import episode_ioct
from rcmplan.subretinal.episode import Episode, EpisodeResult, run_episode
from rcmplan.subretinal.episode_batch import BatchSettings, run_job
from rcmplan.subretinal.episode_bscans import episode_bscans
from rcmplan.subretinal.episode_ioct import TrueState, acquisition_scene, bscan_axes, speckle_rng
from rcmplan.subretinal.episode_metrics import summarise
from rcmplan.subretinal.episode_settings import (
    SEGMENTATION_BIAS_M,
    SEGMENTATION_STD_M,
    EpisodeSettings,
)
from rcmplan.subretinal.ioct import IoctModel, render_bscan
from rcmplan.subretinal.motion import MotionModel, sample_motion
from rcmplan.subretinal.segment import segment_bscan
from rcmplan.subretinal.tissue import TissueState
from rcmplan.subretinal.trace import NeedleHold, noisy_trace

# 1 s of iOCT before a 0.2 mm approach, 0.5 s hover, 1 s hold; `hold` compensation, so that the
# prediction at each period is the newest estimate received.
SHORT = EpisodeSettings(compensation="hold", warmup_s=1.0, start_height_m=200e-6, hover_s=0.5,
                        hold_s=1.0, advance_speed_m_s=0.4e-3, seed=11)  # fmt: skip


@pytest.fixture(scope="module")
def image_run() -> tuple[Episode, EpisodeResult]:
    ep = Episode(SHORT)
    return ep, ep.run()


def state_from_log(ep: Episode, result: EpisodeResult, t_acq: float) -> TrueState:
    """The true state at t_acq read back from the run log and the series (the record at or
    before it; the start record during the warm-up, the eye's centre from the trocar)."""
    log, s, eye = result.log, result.series, ep.eye
    i = max(int(np.searchsorted(log.time, t_acq, side="right")) - 1, 0)
    centre = eye.center + log.trocar[i] - eye.port
    tenting = int(s["tissue_state"][i]) == int(TissueState.TENTING)
    tent = float(s["depth_vs_undeformed_m"][i]) if tenting else 0.0
    return TrueState(log.tip[i], log.base[i], centre, tent)


def test_each_estimate_is_the_segmentation_of_the_state_at_its_acquisition(
    image_run: tuple[Episode, EpisodeResult],
) -> None:
    ep, result = image_run
    model = IoctModel(volume_rate_hz=SHORT.ioct_rate_hz, latency_s=SHORT.latency_s)
    axes = bscan_axes(default_eye(make_robot(SHORT.robot)), SHORT.direction)
    during = [r for r in result.received if r.t_acq_s >= SHORT.warmup_s]
    assert len(during) > 20 and all(r.estimate_m is not None for r in during)
    for r in during:
        truth = float(ep.motion.displacement(r.t_acq_s))
        scene = acquisition_scene(ep.layers, truth, state_from_log(ep, result, r.t_acq_s), axes)
        assert scene.tip_m == pytest.approx(r.scene.tip_m, abs=1e-12)
        image = render_bscan(model, scene, speckle_rng(SHORT.seed, r.number))
        seg = segment_bscan(image, model, ep.layers.ilm_radius_m, NeedleHold().diameter_m)
        assert seg.ilm_offset_m == pytest.approx(r.estimate_m, abs=1e-12)
    # the scenes follow the robot: still at the start during the warm-up, above the ILM at the
    # hover, in the retina during the hold
    warmup = [r for r in result.received if r.t_acq_s < SHORT.warmup_s]
    assert len(warmup) == 9
    for r in warmup:
        assert r.scene.tip_m[1] == pytest.approx(-SHORT.start_height_m, abs=1e-9)
    starts = result.phase_starts_s
    hover = [r for r in during if starts["hover"] <= r.t_acq_s < starts["advance"]]
    hold = [r for r in during if starts["hold"] <= r.t_acq_s < starts["retract"]]
    assert all(r.scene.tip_m[1] < r.scene.ilm_depth_m(r.scene.tip_m[0]) for r in hover)
    assert all(r.scene.tip_m[1] > r.scene.ilm_depth_m(r.scene.tip_m[0]) for r in hold)
    assert max(r.scene.tent_m for r in during) > 10e-6  # the ILM was tented before puncture


def test_the_controller_received_those_estimates(image_run) -> None:
    _, result = image_run
    trace, s = result.trace, result.series
    arrival = trace.t_acq_s + SHORT.latency_s
    newest = np.searchsorted(arrival, s["t_s"], side="right") - 1
    assert newest.min() >= 0
    np.testing.assert_array_equal(s["predicted_m"], trace.estimate_m[newest])  # `hold`
    # not the stand-in: the errors are the images' own, not the seed's stand-in draws
    ep = Episode(replace(SHORT, ioct_estimates="noise"))
    assert ep.ioct.stand_in is not None
    stand_in = ep.ioct.stand_in.estimate_m[[r.number for r in result.received]]
    assert np.abs(trace.estimate_m - stand_in).max() > 0.1e-6


def test_the_same_seed_gives_the_same_estimates(image_run) -> None:
    _, result = image_run
    again = run_episode(SHORT)
    np.testing.assert_array_equal(again.trace.estimate_m, result.trace.estimate_m)
    other = run_episode(replace(SHORT, seed=SHORT.seed + 1))
    assert not np.array_equal(other.trace.estimate_m, result.trace.estimate_m)


def test_a_volume_without_an_ilm_delivers_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    real = episode_ioct.segment_acquisition
    drop = {15, 16, 20}  # acquisitions at the end of the hover and during the advance

    def no_ilm(model: IoctModel, scene: Any, seed: int, index: int) -> tuple[Any, Any]:
        image, seg = real(model, scene, seed, index)
        if index in drop:
            seg = replace(seg, ilm_offset_m=None, valid=np.zeros_like(seg.valid))
        return image, seg

    monkeypatch.setattr(episode_ioct, "segment_acquisition", no_ilm)
    result = run_episode(SHORT)
    numbers = [r.number for r in result.received]
    assert drop <= set(numbers)
    assert [r.number for r in result.received if r.estimate_m is None] == sorted(drop)
    trace, s = result.trace, result.series
    times = {round(r.t_acq_s, 9) for r in result.received if r.number in drop}
    assert times.isdisjoint(np.round(trace.t_acq_s, 9)) and trace.dropped == len(drop)
    # `hold` keeps the estimate from before the drop until the next volume that has one
    k15 = next(r for r in result.received if r.number == 15)
    before = next(r for r in result.received if r.number == 14).estimate_m
    wait = (s["t_s"] >= k15.t_acq_s + SHORT.latency_s) & (
        s["t_s"] < k15.t_acq_s + 2 * 1 / SHORT.ioct_rate_hz + SHORT.latency_s
    )
    assert wait.sum() > 100 and np.all(s["predicted_m"][wait] == before)
    doc = summarise(result)
    assert doc["acquisitions_dropped"] == len(drop)
    assert doc["acquisitions_delivered"] == len(result.received)
    assert len(episode_bscans(result)) <= len(result.received) - len(drop)


def test_the_summary_reports_the_error_of_what_was_received(image_run) -> None:
    _, result = image_run
    doc = summarise(result)
    assert doc["ioct_estimates"] == "image" and "segmented" in doc["ioct_source"]
    assert doc["noise_std_m"] is None
    offsets = np.array([r.error.ilm_offset_m for r in result.received if r.error is not None])
    assert offsets.size == doc["acquisitions_delivered"] == len(result.received) > 20
    assert doc["segmentation_rms_m"] == pytest.approx(np.sqrt(np.mean(offsets**2)), rel=1e-12)
    assert doc["segmentation_bias_m"] == pytest.approx(np.mean(offsets), rel=1e-12)
    assert 0 < doc["segmentation_ilm_rms_m"] < 5e-6  # about the axial pixel
    assert doc["tip_segmented"] <= doc["tip_in_window"] <= doc["acquisitions_delivered"]
    assert doc["tip_segmented"] > 0 and doc["segmentation_tip_rms_m"] > 0
    phases = doc["segmentation_by_phase"]
    assert list(phases) == ["warmup", *result.phase_starts_s]
    assert sum(p["volumes"] for p in phases.values()) == doc["acquisitions_delivered"]
    assert sum(p["tip_segmented"] for p in phases.values()) == doc["tip_segmented"]
    pooled = np.sqrt(sum(p["rms_m"] ** 2 * p["volumes"] for p in phases.values()) / offsets.size)
    assert pooled == pytest.approx(doc["segmentation_rms_m"], rel=1e-9)
    assert phases["hold"]["tip_in_window"] == phases["hold"]["volumes"]


def test_the_noise_stand_in_is_an_option() -> None:
    cfg = replace(SHORT, ioct_estimates="noise")
    result = run_episode(cfg)
    doc = summarise(result)
    assert doc["ioct_estimates"] == "noise" and "stand-in" in doc["ioct_source"]
    assert doc["noise_std_m"] == SEGMENTATION_STD_M and doc["segmentation_ilm_rms_m"] is None
    assert doc["acquisitions_dropped"] == 0 and all(r.error is None for r in result.received)
    ep = Episode(cfg)  # the stand-in's draws: the truth plus the measured bias and noise
    rng = np.random.default_rng(cfg.seed)
    motion = MotionModel(breathing_amplitude_m=cfg.breathing_m, cardiac_amplitude_m=cfg.cardiac_m,
                         breathing_rate_hz=cfg.breathing_rate_hz,
                         cardiac_rate_hz=cfg.cardiac_rate_hz)  # fmt: skip
    trajectory = sample_motion(motion, cfg.warmup_s + ep.length_s + 1.0, rng)
    model = IoctModel(volume_rate_hz=cfg.ioct_rate_hz, latency_s=cfg.latency_s)
    expected = noisy_trace(trajectory, model, cfg.noise_std_m, rng, SEGMENTATION_BIAS_M)
    n = result.trace.estimate_m.size
    np.testing.assert_array_equal(result.trace.estimate_m, expected.estimate_m[:n])


def test_the_state_of_a_period_not_yet_run_is_refused() -> None:
    ep = Episode(SHORT)
    with pytest.raises(InvalidInputError, match="t_s"):
        episode_ioct.true_state(ep, SHORT.warmup_s + 0.5)


def test_bad_ioct_estimates_are_refused_naming_the_choices() -> None:
    with pytest.raises(InvalidInputError, match=r"ioct_estimates.*image, noise"):
        EpisodeSettings(ioct_estimates="images")


def test_the_cli_option_and_the_batch_record(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit):
        main(["subretinal", "--help"])
    assert "STAND-IN" in capsys.readouterr().out
    out = tmp_path / "noise"
    main(["subretinal", "--ioct-estimates", "noise", "--hold-s", "0.3", "--hover-s", "0.1",
          "--out", str(out), "--no-plots", "--json"])  # fmt: skip
    doc = json.loads((out / "summary.json").read_text())
    assert doc["ioct_estimates"] == "noise" and doc["segmentation_tip_rms_m"] is None
    base = replace(SHORT, hold_s=0.2, hover_s=0.1)
    for mode in ("image", "noise"):
        record = run_job(BatchSettings(episodes=1, methods=("hold",),
                                       base=replace(base, ioct_estimates=mode)), 0)  # fmt: skip
        assert record.ioct_estimates == mode and record.segmentation_rms_m is not None
        assert (record.draw.noise_std_m is None) == (mode == "image")


def test_the_replay_frames_are_the_images_the_estimates_came_from(image_run) -> None:
    _, result = image_run
    frames = episode_bscans(result)
    assert len(frames) > 20
    np.testing.assert_array_equal(frames.segmented_m, frames.estimate_m)
    assert frames.tent_m.max() > 10e-6  # the tented ILM is in the frames too
