"""Predictors of the ILM displacement across the iOCT latency."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from rcmplan.exceptions import InvalidInputError
from rcmplan.subretinal.aliasing import band_rates, fold_hz, folded_band
from rcmplan.subretinal.episode_settings import EpisodeSettings
from rcmplan.subretinal.ioct import IoctModel
from rcmplan.subretinal.kalman import KalmanPredictor
from rcmplan.subretinal.monitor import heart_rate_input
from rcmplan.subretinal.motion import MotionModel, sample_motion
from rcmplan.subretinal.predictors import PREDICTORS, make_predictor
from rcmplan.subretinal.trace import noisy_trace, prediction_errors, rms


def two_harmonics(t: np.ndarray, f2: float = 1.5) -> np.ndarray:
    return 50e-6 * np.sin(2 * np.pi * 0.25 * t + 0.3) + 10e-6 * np.sin(2 * np.pi * f2 * t + 1.0)


def run(name: str, t: np.ndarray, y: np.ndarray, ahead: float, after: float, **kw: object):
    """Feed (t, y) one by one; return the predictor and its errors `ahead` of each sample
    once t > after."""
    model = make_predictor(name, **kw)
    errors = []
    for tk, yk in zip(t, y, strict=True):
        model.update(float(tk), float(yk))
        if tk > after:
            errors.append(float(model.predict(tk + ahead)) - float(two_harmonics(tk + ahead)))
    return model, np.array(errors)


def test_predictors_are_chosen_by_name_and_an_unknown_name_lists_the_valid_ones() -> None:
    assert list(PREDICTORS) == ["none", "hold", "fft", "kalman"]
    for name in PREDICTORS:
        assert make_predictor(name).name == name
    with pytest.raises(InvalidInputError, match="none, hold, fft, kalman"):
        make_predictor("lstm")


@pytest.mark.parametrize("name", list(PREDICTORS))
def test_estimates_must_come_in_time_order_and_be_finite(name: str) -> None:
    model = make_predictor(name)
    model.update(1.0, 5e-6)
    with pytest.raises(InvalidInputError):
        model.update(1.0, 6e-6)
    with pytest.raises(InvalidInputError):
        model.update(2.0, float("nan"))
    with pytest.raises(InvalidInputError):
        model.predict(float("inf"))


def test_none_predicts_zero_and_hold_the_newest_estimate() -> None:
    none, hold = make_predictor("none"), make_predictor("hold")
    assert float(hold.predict(0.0)) == 0.0  # nothing seen yet
    for t, y in ((0.0, 3e-6), (0.1, -7e-6)):
        none.update(t, y)
        hold.update(t, y)
    np.testing.assert_array_equal(none.predict([0.2, 0.3]), [0.0, 0.0])
    np.testing.assert_array_equal(hold.predict([0.2, 0.3]), [-7e-6, -7e-6])


@pytest.mark.parametrize(("name", "tolerance"), [("fft", 1e-6), ("kalman", 0.1e-6)])
def test_a_clean_two_harmonic_motion_is_predicted_150_ms_ahead(name: str, tolerance: float) -> None:
    t = np.arange(0.0, 20.0, 1 / 9)
    model, errors = run(name, t, two_harmonics(t), 0.15, after=12.0)
    assert errors.size > 60 and np.abs(errors).max() < tolerance
    if name == "kalman":
        assert model.rates_hz == pytest.approx((0.25, 1.5), abs=1e-3)  # type: ignore[attr-defined]


def test_the_kalman_rates_follow_a_heart_rate_change_and_it_restarts_when_lost() -> None:
    t = np.arange(0.0, 40.0, 1 / 9)
    f2 = np.where(t < 20.0, 1.1, 1.8)  # a jump no random walk follows
    phase = 2 * np.pi * np.cumsum(f2) / 9
    y = 50e-6 * np.sin(2 * np.pi * 0.25 * t) + 10e-6 * np.sin(phase)
    model = KalmanPredictor()
    for tk, yk in zip(t, y, strict=True):
        model.update(float(tk), float(yk))
    assert model.acquisitions >= 2
    assert model.rates_hz is not None and model.rates_hz[1] == pytest.approx(1.8, abs=0.02)


def test_at_1_6_hz_the_aliased_cardiac_harmonic_is_left_out_and_breathing_still_predicted() -> None:
    model_motion, ioct = MotionModel(), IoctModel(volume_rate_hz=1.6)
    t_eval = np.arange(12.0, 40.0, 0.01)
    kal, hold = [], []
    for seed in range(10):
        traj = sample_motion(model_motion, 40.0, seed)
        trace = noisy_trace(traj, ioct, 1e-6, np.random.default_rng(seed))
        kal.append(float(rms(prediction_errors("kalman", trace, [0.15], traj, t_eval))))
        hold.append(float(rms(prediction_errors("hold", trace, [0.15], traj, t_eval))))
    assert np.all(np.array(kal) < np.array(hold))
    k = KalmanPredictor()
    for tk, yk in zip(trace.t_acq_s, trace.estimate_m, strict=True):
        k.update(float(tk), float(yk))
    assert k.x is not None and not k.x[2:4].any()  # the cardiac phasor stays at zero


def test_rates_fold_into_the_first_nyquist_zone_and_a_folded_rate_names_the_band_rates() -> None:
    assert fold_hz(1.4, 2.5) == pytest.approx(1.1)
    assert fold_hz(1.8, 2.5) == pytest.approx(0.7)
    assert fold_hz(1.6, 1.6) == pytest.approx(0.0)
    assert folded_band((1.0, 2.0), 2.5) == pytest.approx((0.5, 1.25))  # 1.25 = fs / 2 inside
    assert folded_band((1.0, 2.0), 1.6) == pytest.approx((0.0, 0.6))  # fs inside: 0
    assert folded_band((1.0, 2.0), 5.0) == pytest.approx((1.0, 2.0))  # the first zone
    rates = band_rates(1.1, (1.0, 2.0), 2.5)  # 1.1 itself and its mirror 2.5 - 1.1
    assert [f for f, _ in rates] == pytest.approx([1.1, 1.4])
    assert [turn for _, turn in rates] == [1, -1]
    assert band_rates(0.7, (1.0, 2.0), 2.5) == [(pytest.approx(1.8), -1)]  # one rate only


def clean_errors(fs_hz: float, f2_hz: float, **kw: object) -> tuple[KalmanPredictor, np.ndarray]:
    """A clean two-harmonic motion sampled at fs_hz: the Kalman predictor's errors 150 ms
    and every 10 ms up to one volume later ahead of each sample after 12 s."""
    t = np.arange(0.0, 30.0, 1 / fs_hz)
    model, errors = KalmanPredictor(**kw), []  # type: ignore[arg-type]
    ahead = 0.15 + np.arange(0.0, 1 / fs_hz, 0.01)
    for tk, yk in zip(t, two_harmonics(t, f2_hz), strict=True):
        model.update(float(tk), float(yk))
        if tk > 12.0:
            errors.append(model.predict(tk + ahead) - two_harmonics(tk + ahead, f2_hz))
    return model, np.concatenate(errors)


@pytest.mark.parametrize(("fs_hz", "f2_hz"), [(2.5, 1.8), (3.6, 1.2), (2.2, 1.6)])
def test_an_aliased_heart_rate_with_one_rate_in_its_band_is_predicted_between_volumes(
    fs_hz: float, f2_hz: float
) -> None:
    # The cardiac band 1-2 Hz straddles a Nyquist-zone edge at these rates, but only one rate
    # of the band folds onto what the samples show: the 10 um harmonic is predicted, not left
    # out (leaving it out errs by its RMS, 7.1 um).
    model, errors = clean_errors(fs_hz, f2_hz)
    assert errors.size > 100 and rms(errors) < 0.5e-6
    assert model.rate_hypotheses_hz[1] == [pytest.approx(f2_hz, abs=2e-3)]


def test_two_rates_that_fold_alike_are_weighed_equally_without_a_heart_rate() -> None:
    # At 3 Hz, 1.2 and 1.8 Hz give the same samples: the mean of their predictions errs by half
    # their difference, 5 um RMS for 10 um (A / 2), not the 7.1 um (A / sqrt 2) of leaving the
    # harmonic out.
    model, errors = clean_errors(3.0, 1.2)
    assert sorted(model.rate_hypotheses_hz[1]) == [pytest.approx(1.2, abs=2e-3),
                                                   pytest.approx(1.8, abs=2e-3)]  # fmt: skip
    assert 4e-6 < rms(errors) < 6e-6


def test_a_heart_rate_reading_picks_the_rate_among_those_that_fold_alike() -> None:
    # The same 3 Hz samples as above: a reading of 1.2 Hz, 3 bpm off, leaves the 1.8 Hz rate a
    # negligible weight and the 10 um harmonic is predicted between volumes.
    _, errors = clean_errors(3.0, 1.2, heart_rate_hz=1.25, heart_rate_std_hz=0.05)
    assert rms(errors) < 0.5e-6
    with pytest.raises(InvalidInputError, match="heart_rate_hz"):
        KalmanPredictor(heart_rate_hz=2.5)  # outside the cardiac band


def test_the_monitor_reading_is_given_to_kalman_only_when_asked_and_is_seeded() -> None:
    motion = MotionModel()
    base = EpisodeSettings(cardiac_rate_hz=1.4, seed=3)
    assert heart_rate_input(base, motion) == {}
    cfg = replace(base, heart_rate_sd_hz=0.05)
    assert heart_rate_input(replace(cfg, compensation="fft"), motion) == {}
    got = heart_rate_input(cfg, motion)
    assert got == heart_rate_input(cfg, motion)  # the episode's seed fixes it
    assert got["heart_rate_hz"] != 1.4 and abs(got["heart_rate_hz"] - 1.4) < 0.25
    assert got["heart_rate_std_hz"] == pytest.approx(np.hypot(0.05, 0.05 * got["heart_rate_hz"]))
    exact = heart_rate_input(replace(base, heart_rate_sd_hz=0.0), motion)
    assert exact["heart_rate_hz"] == 1.4
    with pytest.raises(InvalidInputError, match="heart_rate_sd_hz"):
        EpisodeSettings(heart_rate_sd_hz=-0.01)


def test_the_kalman_parts_add_up_to_its_prediction() -> None:
    model = KalmanPredictor()
    model.update(0.0, 4e-6)
    np.testing.assert_array_equal(model.components([0.1, 0.2]), [[0, 0, 4e-6], [0, 0, 4e-6]])
    model, _ = clean_errors(3.0, 1.2)
    t = model.t_last_s + np.linspace(0.0, 0.5, 11)
    parts = model.components(t)
    assert parts.shape == (11, 3) and np.abs(parts[:, 1]).max() > 1e-6
    np.testing.assert_allclose(parts.sum(axis=1), model.predict(t), rtol=0.0, atol=1e-18)
