"""The weighted-frequency Fourier linear combiner (WFLC): an adaptive tremor canceller.

Riviere, Rader and Thakor, "Adaptive canceling of physiological tremor for improved precision
in microsurgery", IEEE TBME 45(7):839-846, 1998. Tremor is modelled as a sinusoid of slowly
varying frequency, amplitude and phase; the WFLC tracks all three by least mean squares (LMS)
and the tremor estimate is subtracted from the input. Voluntary motion is not delayed: only
the estimate, not the signal, passes through filters.

With k the sample, x_k the band-passed input per axis, phi_k the oscillator phase, w_k = (w_s,
w_c) per axis and omega_k the frequency [rad/sample] (one harmonic, M = 1):

    y_k     = w_s sin(phi_k) + w_c cos(phi_k)                  estimate of the band-passed tremor
    e_k     = x_k - y_k
    omega   += 2 mu_0 sum_axes e_k (w_s cos phi_k - w_c sin phi_k) / (|w|^2 + P)   (frequency)
    w_s     += 2 mu_1 e_k sin(phi_k);   w_c += 2 mu_1 e_k cos(phi_k)              (amplitude)
    phi_k+1 = phi_k + omega

Departures from the paper, each for a stated reason:
- One frequency for the three axes (the paper runs one WFLC per axis): the hand's tremor is
  one oscillation seen along three axes; one frequency costs a third and adapts on three
  times the signal. The amplitude weights stay per axis.
- The frequency step is normalised by the weights' power |w|^2 + P (P = `power_floor`), so
  `mu_frequency` does not depend on the unit or size of the tremor.
- The prefilter (the paper's band-pass; here a fourth-order high-pass at 5 Hz, which keeps
  millimetre hand moves out of the estimate, and a second-order low-pass at 18 Hz) shifts the
  tremor's phase and scales it; the estimate is corrected by the prefilter's exact response
  at the tracked frequency, 1 / H(omega), before it is subtracted from the raw input (without
  it, about half the tremor remains: docs/teleop.md).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import signal

from rcmplan._validate import scalar
from rcmplan.exceptions import InvalidInputError
from rcmplan.teleop.filters import Biquads, Vec3

TABLE_STEP_HZ = 1e-3  # resolution of the 1 / H(omega) table
TWO_PI = 2.0 * math.pi


def prefilter(band_hz: tuple[float, float], rate_hz: float, order: tuple[int, int]) -> np.ndarray:
    """Second-order sections of the prefilter: Butterworth high-pass at band_hz[0] of order[0]
    then low-pass at band_hz[1] of order[1]."""
    hp = signal.butter(order[0], band_hz[0], "highpass", fs=rate_hz, output="sos")
    lp = signal.butter(order[1], band_hz[1], fs=rate_hz, output="sos")
    return np.vstack([hp, lp])


class WflcFilter:
    """The WFLC tremor canceller (module docstring).

    Args:
        rate_hz: Sample rate [Hz].
        band_hz: Pass band (low, high) [Hz] of the second-order Butterworth prefilter; the
            tracked frequency stays inside it.
        initial_hz: Frequency the oscillator starts at [Hz].
        mu_frequency: mu_0, the frequency step (normalised, per sample).
        mu_amplitude: mu_1, the amplitude step (per sample; weights settle in about
            1 / (2 mu_1) samples).
        power_floor: P [m^2] in the frequency step's normalisation.
    """

    name = "wflc"
    delay_s = 0.0

    def __init__(
        self,
        rate_hz: float = 1000.0,
        band_hz: tuple[float, float] = (5.0, 18.0),
        initial_hz: float = 10.0,
        mu_frequency: float = 5e-4,
        mu_amplitude: float = 0.01,
        power_floor: float = 1e-14,
        prefilter_order: tuple[int, int] = (4, 2),
    ) -> None:
        self.prefilter_order = prefilter_order
        self.rate_hz = scalar("rate_hz", rate_hz, 100.0, 1e6)
        lo = scalar("band_hz[0]", band_hz[0], 0.0, rate_hz / 2, low_open=True, high_open=True)
        hi = scalar("band_hz[1]", band_hz[1], lo, rate_hz / 2, low_open=True, high_open=True)
        self.band_hz = (lo, hi)
        self.initial_hz = scalar("initial_hz", initial_hz, lo, hi)
        self.mu_frequency = scalar("mu_frequency", mu_frequency, 0.0, 0.1)
        self.mu_amplitude = scalar("mu_amplitude", mu_amplitude, 0.0, 0.5, low_open=True)
        self.power_floor = scalar("power_floor", power_floor, 0.0, 1.0, low_open=True)
        sos = prefilter(self.band_hz, self.rate_hz, self.prefilter_order)
        self._prefilter = Biquads(sos)
        freqs = np.arange(lo, hi + TABLE_STEP_HZ, TABLE_STEP_HZ)
        _, h = signal.sosfreqz(sos, worN=freqs, fs=self.rate_hz)
        if np.any(np.abs(h) < 1e-3):
            raise InvalidInputError("band_hz", band_hz, "a pass band the prefilter passes")
        g = 1.0 / h
        self._inverse = list(zip(g.real.tolist(), g.imag.tolist(), strict=True))
        self._omega_lo, self._omega_hi = (TWO_PI * f / self.rate_hz for f in self.band_hz)
        self._per_bin = self.rate_hz / (TWO_PI * TABLE_STEP_HZ)  # table index per rad/sample
        self._mu0x2, self._mu1x2 = 2.0 * self.mu_frequency, 2.0 * self.mu_amplitude
        self._w = [0.0] * 6
        self._omega = self._phase = 0.0
        self.reset((0.0, 0.0, 0.0))

    @property
    def frequency_hz(self) -> float:
        """The tracked tremor frequency [Hz]."""
        return self._omega * self.rate_hz / TWO_PI

    def reset(self, x: Vec3) -> None:
        """At rest at x: prefilter settled, no tremor estimated, oscillator at `initial_hz`."""
        self._prefilter.reset(x)
        self._w = [0.0] * 6
        self._omega = TWO_PI * self.initial_hz / self.rate_hz
        self._phase = 0.0

    def tremor(self) -> Vec3:
        """The current estimate of the tremor in the raw input [m], per axis."""
        return self._estimate(math.sin(self._phase), math.cos(self._phase))

    def _estimate(self, s: float, c: float) -> Vec3:
        # Im((w_s + j w_c) / H e^{j phi}) per axis, with 1 / H = gr + j gi
        gr, gi = self._inverse[int((self._omega - self._omega_lo) * self._per_bin + 0.5)]
        ws0, wc0, ws1, wc1, ws2, wc2 = self._w
        gs, gc = gr * s + gi * c, gr * c - gi * s
        return (ws0 * gs + wc0 * gc, ws1 * gs + wc1 * gc, ws2 * gs + wc2 * gc)

    def step(self, x: Vec3) -> Vec3:
        """Adapt on sample x [m] and return x less the tremor estimate."""
        f0, f1, f2 = self._prefilter.step(x)
        phase = self._phase
        s, c = math.sin(phase), math.cos(phase)
        ws0, wc0, ws1, wc1, ws2, wc2 = self._w
        e0 = f0 - (ws0 * s + wc0 * c)
        e1 = f1 - (ws1 * s + wc1 * c)
        e2 = f2 - (ws2 * s + wc2 * c)
        grad = (e0 * (ws0 * c - wc0 * s) + e1 * (ws1 * c - wc1 * s)
                + e2 * (ws2 * c - wc2 * s))  # fmt: skip
        power = ws0 * ws0 + wc0 * wc0 + ws1 * ws1 + wc1 * wc1 + ws2 * ws2 + wc2 * wc2
        m = self._mu1x2
        ms, mc = m * s, m * c
        self._w = [ws0 + ms * e0, wc0 + mc * e0, ws1 + ms * e1, wc1 + mc * e1,
                   ws2 + ms * e2, wc2 + mc * e2]  # fmt: skip
        omega = self._omega + self._mu0x2 * grad / (power + self.power_floor)
        self._omega = min(max(omega, self._omega_lo), self._omega_hi)
        t0, t1, t2 = self._estimate(s, c)
        self._phase = (phase + self._omega) % TWO_PI
        return (x[0] - t0, x[1] - t1, x[2] - t2)
