"""Physiological motion: reproducible by seed, with the stated amplitudes and rates."""

from __future__ import annotations

import numpy as np
import pytest

from rcmplan.exceptions import InvalidInputError
from rcmplan.subretinal.motion import (
    MotionModel,
    eye_translation,
    ornstein_uhlenbeck,
    sample_motion,
)


def spectrum(signal: np.ndarray, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """One-sided amplitude spectrum (a sinusoid of amplitude A shows A at its bin)."""
    amp = 2.0 * np.abs(np.fft.rfft(signal)) / signal.size
    return np.fft.rfftfreq(signal.size, 1.0 / fs), amp


def test_a_seed_gives_the_same_trajectory_and_another_seed_another() -> None:
    model = MotionModel(eye_drift_m=1e-3)
    t = np.linspace(0.0, 20.0, 777)
    a, b = sample_motion(model, 20.0, 7), sample_motion(model, 20.0, 7)
    np.testing.assert_array_equal(a.displacement(t), b.displacement(t))
    np.testing.assert_array_equal(a.translation(t), b.translation(t))
    c = sample_motion(model, 20.0, np.random.default_rng(8))
    assert not np.allclose(a.displacement(t), c.displacement(t))


def test_without_drift_the_spectrum_peaks_at_the_stated_rates_and_amplitudes() -> None:
    model = MotionModel(
        breathing_amplitude_m=40e-6, breathing_rate_hz=0.3, cardiac_amplitude_m=8e-6,
        cardiac_rate_hz=1.2, amplitude_drift=0.0, rate_drift=0.0,
    )  # fmt: skip
    fs, duration = 50.0, 100.0  # whole periods of both rates: no leakage
    traj = sample_motion(model, duration, 3)
    t = np.arange(0.0, duration, 1.0 / fs)
    f, amp = spectrum(traj.displacement(t), fs)
    low, high = f < 0.7, f > 0.7
    assert f[low][np.argmax(amp[low])] == pytest.approx(0.3, abs=0.011)
    assert f[high][np.argmax(amp[high])] == pytest.approx(1.2, abs=0.011)
    assert amp[low].max() == pytest.approx(40e-6, rel=0.01)
    assert amp[high].max() == pytest.approx(8e-6, rel=0.01)


def test_with_the_default_drift_the_rates_stay_in_their_bands_and_the_peaks_with_them() -> None:
    model = MotionModel()
    fs, duration = 20.0, 120.0
    for seed in range(5):
        traj = sample_motion(model, duration, seed)
        assert np.all((traj.rate_hz[:, 0] >= 0.2) & (traj.rate_hz[:, 0] <= 0.33))
        assert np.all((traj.rate_hz[:, 1] >= 1.0) & (traj.rate_hz[:, 1] <= 2.0))
        t = np.arange(0.0, duration, 1.0 / fs)
        f, amp = spectrum(traj.displacement(t) * np.hanning(t.size) * 2, fs)
        low, high = f < 0.6, f > 0.6
        assert 0.18 <= f[low][np.argmax(amp[low])] <= 0.35
        assert 0.95 <= f[high][np.argmax(amp[high])] <= 2.05
        rms = np.sqrt(np.mean(traj.displacement(t) ** 2))
        assert rms == pytest.approx(np.sqrt((50e-6**2 + 10e-6**2) / 2), rel=0.3)


def test_the_ou_drift_has_unit_variance_and_the_stated_correlation_time() -> None:
    x = ornstein_uhlenbeck(np.random.default_rng(1), 400_000, 0.01, 0.5, size=2)
    assert np.var(x) == pytest.approx(1.0, abs=0.05)
    lag = 50  # one correlation time: correlation 1/e
    corr = np.mean(x[lag:] * x[:-lag]) / np.var(x)
    assert corr == pytest.approx(np.exp(-1.0), abs=0.05)


def test_the_eye_is_still_by_default_and_drifts_with_the_stated_spread_when_asked() -> None:
    t = np.linspace(0.0, 300.0, 3001)
    assert not np.any(sample_motion(MotionModel(), 300.0, 1).translation(t))
    model = MotionModel(eye_drift_m=2e-3, eye_drift_time_s=5.0)
    pooled = np.concatenate([sample_motion(model, 300.0, s).translation(t) for s in range(8)])
    assert pooled.shape[1] == 3
    np.testing.assert_allclose(pooled.std(axis=0), 2e-3, rtol=0.2)
    traj = sample_motion(model, 300.0, 1)
    n = np.array([0.0, 0.6, 0.8])
    np.testing.assert_allclose(
        traj.ilm_offset(t, n), traj.displacement(t) + traj.translation(t) @ n
    )


def test_times_outside_the_trajectory_and_bad_parameters_raise() -> None:
    traj = sample_motion(MotionModel(), 5.0, 1)
    with pytest.raises(InvalidInputError):
        traj.displacement([0.0, 5.5])
    with pytest.raises(InvalidInputError):
        traj.displacement([np.nan])
    with pytest.raises(InvalidInputError) as err:
        MotionModel(cardiac_rate_hz=2.5)
    assert err.value.name == "cardiac_rate_hz" and "[1, 2]" in str(err.value)
    with pytest.raises(InvalidInputError):
        MotionModel(drift_time_s=0.0)
    with pytest.raises(InvalidInputError):
        sample_motion(MotionModel(), -1.0, 1)


def test_the_eye_translation_starts_stationary_with_its_standard_deviation_and_is_smooth() -> None:
    """Each path's first sample is a stationary draw (sd `eye_drift_m` per axis); its moves
    over 4 grid steps are 4 times those over one (a path with a velocity; an OU path: 2)."""
    model = MotionModel(eye_drift_m=200e-6, eye_drift_time_s=30.0)
    first = np.array([eye_translation(model, 1, np.random.default_rng(k))[0] for k in range(200)])
    assert 0.9 * 200e-6 < float(np.std(first)) < 1.1 * 200e-6  # 600 draws: sd within 6 %
    path = eye_translation(model, 20_000, np.random.default_rng(7))
    one, four = np.diff(path, axis=0), path[4:] - path[:-4]
    ratio = float(np.sqrt(np.mean(four**2) / np.mean(one**2)))
    assert 3.9 < ratio < 4.01
