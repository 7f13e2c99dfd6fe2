"""Tremor filters: the low-pass delays slow motion by its stated lag and attenuates tremor as
designed; the WFLC locks on the tremor's frequency, cancels it and does not delay slow motion."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from rcmplan.exceptions import InvalidInputError
from rcmplan.teleop import LowPassFilter, NoFilter, SyntheticSurgeon, WflcFilter
from rcmplan.teleop.filters import Biquads

RATE = 1000.0


def run(f, x: np.ndarray) -> np.ndarray:
    f.reset(tuple(x[0]))
    return np.array([f.step(tuple(p)) for p in x.tolist()])


def band_rms(x: np.ndarray, skip: int = 2000) -> float:
    sos = signal.butter(4, (6.0, 16.0), "bandpass", fs=RATE, output="sos")
    xb = signal.sosfiltfilt(sos, x, axis=0)[skip:]
    return math.sqrt(np.mean(np.sum(xb**2, axis=1)))


def sinusoid(f_hz: float, n: int, amp: float = 100e-6) -> np.ndarray:
    t = np.arange(n) / RATE
    return amp * np.sin(2 * np.pi * f_hz * t)[:, None] * np.array([1.0, 0.5, -0.3])


def test_the_biquad_cascade_matches_scipy(rng) -> None:
    sos = signal.butter(4, (5.0, 18.0), "bandpass", fs=RATE, output="sos")
    x = rng.standard_normal((500, 3))
    ours = Biquads(sos)
    ours.reset((0.0, 0.0, 0.0))
    got = np.array([ours.step(tuple(p)) for p in x.tolist()])
    assert got == pytest.approx(signal.sosfilt(sos, x, axis=0), abs=1e-12)


def test_no_filter_passes_the_input_unchanged() -> None:
    x = sinusoid(10.0, 100)
    assert run(NoFilter(), x) == pytest.approx(x, abs=0.0)


def test_a_filter_reset_at_a_position_starts_at_rest_there() -> None:
    x = np.tile([0.01, -0.02, 0.03], (300, 1))
    for f in (LowPassFilter(), WflcFilter()):
        assert run(f, x) == pytest.approx(x, abs=1e-12)


def test_the_low_pass_delays_a_ramp_by_its_stated_lag() -> None:
    f = LowPassFilter(cutoff_hz=2.0)
    t = np.arange(3000) / RATE
    ramp = np.column_stack([1e-3 * t, 0 * t, 0 * t])
    out = run(f, ramp)
    lag = (ramp[-1, 0] - out[-1, 0]) / 1e-3  # steady-state lag of a ramp = group delay at 0 Hz
    assert lag == pytest.approx(f.delay_s, rel=1e-3)
    assert f.delay_s == pytest.approx(math.sqrt(2.0) / (2 * math.pi * 2.0), rel=0.01)


def test_the_low_pass_attenuates_tremor_as_its_response_states() -> None:
    f = LowPassFilter(cutoff_hz=2.0)
    gain, lag_deg = f.response(10.0)
    out = run(f, sinusoid(10.0, 4000))
    assert band_rms(out) == pytest.approx(gain * band_rms(sinusoid(10.0, 4000)), rel=0.02)
    assert 0.0 < lag_deg < 180.0


def test_the_low_pass_refuses_a_cutoff_above_nyquist() -> None:
    with pytest.raises(InvalidInputError, match="cutoff_hz"):
        LowPassFilter(cutoff_hz=600.0)


@pytest.mark.parametrize("f_hz", [7.0, 10.0, 14.0])
def test_the_wflc_locks_on_a_tremor_frequency_and_cancels_it(f_hz: float) -> None:
    f = WflcFilter()
    x = sinusoid(f_hz, 6000)
    out = run(f, x)
    assert f.frequency_hz == pytest.approx(f_hz, abs=0.05)
    assert band_rms(out, skip=3000) < 0.01 * band_rms(x, skip=3000)


def test_the_wflc_cancels_most_of_the_synthetic_tremor_without_delaying_the_motion() -> None:
    track = SyntheticSurgeon(seed=5).track()
    out = run(WflcFilter(), track.position)
    tremor = track.position - track.intended
    assert band_rms(out - track.intended) < 0.1 * band_rms(tremor)
    slow = signal.butter(4, 2.0, fs=RATE, output="sos")
    diff = signal.sosfiltfilt(slow, out - track.intended, axis=0)
    assert np.abs(diff[2000:]).max() < 20e-6  # voluntary motion passes, no lag of 0.1 s


def test_the_wflc_checks_its_settings() -> None:
    with pytest.raises(InvalidInputError, match="initial_hz"):
        WflcFilter(initial_hz=30.0)
    with pytest.raises(InvalidInputError, match="mu_amplitude"):
        WflcFilter(mu_amplitude=0.0)
