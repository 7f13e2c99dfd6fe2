"""Tremor filters on the master position, one sample per control period: `none`, `lowpass`
and `wflc` (`rcmplan.teleop.wflc`), chosen per run by name.

A filter takes and returns positions as three floats [m] (plain Python floats: at one sample
per millisecond, numpy's per-call cost on (3,) arrays would be most of the budget). Each
states `delay_s`, the lag it adds to the intended (voluntary, below 2 Hz) motion.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from scipy import signal

from rcmplan._validate import scalar
from rcmplan.exceptions import InvalidInputError

Vec3 = tuple[float, float, float]
FILTERS = ("none", "lowpass", "wflc")


class TremorFilter(Protocol):
    """A causal filter of the master position."""

    @property
    def name(self) -> str:
        """ "none", "lowpass" or "wflc"."""
        ...

    @property
    def delay_s(self) -> float:
        """Lag added to the intended motion [s] (group delay at 0 Hz)."""
        ...

    def reset(self, x: Vec3) -> None:
        """Start at rest at position x [m]."""
        ...

    def step(self, x: Vec3) -> Vec3:
        """The filtered position for the next sample x [m]."""
        ...


class NoFilter:
    """The position passes unchanged."""

    name = "none"
    delay_s = 0.0

    def reset(self, x: Vec3) -> None:
        """Nothing to reset."""

    def step(self, x: Vec3) -> Vec3:
        """x itself."""
        return x


class Biquads:
    """A cascade of second-order sections (scipy's `sos` layout) run on three channels, in
    transposed direct form II."""

    def __init__(self, sos: np.ndarray) -> None:
        self.sos = np.asarray(sos, dtype=float)
        self._coef = [tuple(float(v) for v in (s[0], s[1], s[2], s[4], s[5])) for s in self.sos]
        self._z = [[0.0, 0.0] for _ in range(3 * len(self._coef))]  # section k, axis a: 3 k + a

    def reset(self, x: Vec3) -> None:
        """The state of a filter that has seen the constant input x forever."""
        zi = signal.sosfilt_zi(self.sos)  # (sections, 2) for a unit step
        self._z = [[float(zi[k, 0]) * x[a], float(zi[k, 1]) * x[a]]
                   for k in range(len(self._coef)) for a in range(3)]  # fmt: skip

    def step(self, x: Vec3) -> Vec3:
        """One sample through every section, per channel."""
        v0, v1, v2 = x
        z = self._z
        i = 0
        for b0, b1, b2, a1, a2 in self._coef:
            s0, s1, s2 = z[i], z[i + 1], z[i + 2]
            y0, y1, y2 = b0 * v0 + s0[0], b0 * v1 + s1[0], b0 * v2 + s2[0]
            s0[0] = b1 * v0 - a1 * y0 + s0[1]
            s1[0] = b1 * v1 - a1 * y1 + s1[1]
            s2[0] = b1 * v2 - a1 * y2 + s2[1]
            s0[1] = b2 * v0 - a2 * y0
            s1[1] = b2 * v1 - a2 * y1
            s2[1] = b2 * v2 - a2 * y2
            v0, v1, v2 = y0, y1, y2
            i += 3
        return (v0, v1, v2)


class LowPassFilter:
    """A Butterworth low-pass of the master position (scipy's design, run sample by sample).

    It removes tremor by attenuation, at the price of lag: its group delay at 0 Hz,
    `delay_s` (0.113 s for the default second order at 2 Hz), delays the intended motion.

    Args:
        cutoff_hz: Cut-off frequency [Hz] (default 2 Hz: 98.9 % of voluntary motion lies below,
            Riviere et al. 1997).
        order: Filter order, 1 to 8.
        rate_hz: Sample rate [Hz] (the control rate).
    """

    name = "lowpass"

    def __init__(self, cutoff_hz: float = 2.0, order: int = 2, rate_hz: float = 1000.0) -> None:
        self.rate_hz = rate = scalar("rate_hz", rate_hz, 10.0, 1e6)
        self.cutoff_hz = scalar(
            "cutoff_hz", cutoff_hz, 0.0, rate / 2, low_open=True, high_open=True
        )
        if not isinstance(order, int) or isinstance(order, bool) or not 1 <= order <= 8:
            raise InvalidInputError("order", order, "an integer in [1, 8]")
        self.order = order
        sos = signal.butter(order, self.cutoff_hz, fs=rate, output="sos")
        self._cascade = Biquads(sos)
        b, a = signal.sos2tf(sos)
        _, gd = signal.group_delay((b, a), w=[0.0], fs=rate)
        self.delay_s = float(gd[0]) / rate

    def response(self, frequency_hz: float) -> tuple[float, float]:
        """(gain, phase lag [deg], wrapped to (-180, 180]) at a frequency [Hz]."""
        _, h = signal.sosfreqz(self._cascade.sos, worN=[frequency_hz], fs=self.rate_hz)
        return float(abs(h[0])), float(-np.degrees(np.angle(h[0])))

    def reset(self, x: Vec3) -> None:
        """At rest at x."""
        self._cascade.reset(x)

    def step(self, x: Vec3) -> Vec3:
        """The low-passed position."""
        return self._cascade.step(x)
