"""Predictors of the ILM displacement across the iOCT latency, chosen by name.

Each receives the delayed, sampled estimates of the ILM displacement (`update(t_acq, value)`,
t_acq the acquisition time [s], value [m], in acquisition order) and predicts the displacement
at any time (`predict(t)`), in particular now, `latency` after the newest acquisition. Names:

- `none`: no motion estimate: 0.
- `hold`: the newest estimate, as published set-ups compensate (the median ILM change between
  volumes, Arikan et al. 2024).
- `fft`: the FFT baseline of Wu et al. 2025: the dominant frequencies of a sliding window
  (Hann-windowed, zero-padded FFT, parabolic peak refinement), their amplitudes and phases by
  least squares on the window, extrapolated.
- `kalman`: rcmplan's extended Kalman filter on a drifting two-harmonic model
  (`kalman.py`).

Before a predictor has enough samples it holds the newest estimate (0 before the first).
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from rcmplan._validate import FloatArray, scalar
from rcmplan.exceptions import InvalidInputError


class Predictor:
    """Common interface; subclasses override `_update` and `_predict`."""

    name = "base"

    def __init__(self) -> None:
        self.t_last_s = -math.inf
        self.last_m = 0.0

    def update(self, t_acq_s: float, value_m: float) -> None:
        """Take the estimate `value_m` [m] of the displacement acquired at `t_acq_s` [s]."""
        t = scalar("t_acq_s", t_acq_s)
        if t <= self.t_last_s:
            raise InvalidInputError("t_acq_s", t, f"a time after the last one, {self.t_last_s:g} s")
        v = scalar("value_m", value_m, -1e-2, 1e-2)
        self._update(t, v)
        self.t_last_s, self.last_m = t, v

    def predict(self, t_s: float | FloatArray) -> FloatArray:
        """The predicted displacement [m] at times `t_s` [s] (an array shaped like t_s)."""
        t = np.asarray(t_s, dtype=np.float64)
        if not np.isfinite(t).all():
            raise InvalidInputError("t_s", t_s, "finite times [s]")
        return self._predict(t)

    def _update(self, t: float, value: float) -> None:
        """Fold in one estimate (the base class has stored nothing yet)."""

    def _predict(self, t: FloatArray) -> FloatArray:
        return np.full(t.shape, self.last_m)


class NonePredictor(Predictor):
    """No motion estimate: the displacement is taken as 0."""

    name = "none"

    def _predict(self, t: FloatArray) -> FloatArray:
        return np.zeros(t.shape)


class HoldPredictor(Predictor):
    """The newest estimate, held until the next one."""

    name = "hold"


def sinusoid_fit(
    t: FloatArray, y: FloatArray, freqs_hz: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Least-squares fit of y(t) by an offset and sinusoids at `freqs_hz`.

    Returns:
        The coefficients (offset, then a cosine and a sine per frequency) and the residual.
    """
    cols = [np.ones_like(t)]
    for f in freqs_hz:
        cols += [np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)]
    a = np.column_stack(cols)
    coef = np.asarray(np.linalg.lstsq(a, y, rcond=None)[0], dtype=np.float64)
    return coef, y - a @ coef


def sinusoid_eval(coef: FloatArray, freqs_hz: FloatArray, t: FloatArray) -> FloatArray:
    """The sum of an offset and sinusoids (`sinusoid_fit`'s coefficients) at times t."""
    out = np.full(t.shape, coef[0])
    for k, f in enumerate(freqs_hz):
        w = 2 * np.pi * f * t
        out += coef[1 + 2 * k] * np.cos(w) + coef[2 + 2 * k] * np.sin(w)
    return out


class FftPredictor(Predictor):
    """The FFT baseline (module docstring).

    Args:
        window_s: Length of the sliding window [s].
        peaks: Number of dominant frequencies fitted.
        pad: Zero-padding factor of the FFT.
        min_samples: Samples needed before the first fit (hold until then).
    """

    name = "fft"

    def __init__(
        self, window_s: float = 10.0, peaks: int = 2, pad: int = 8, min_samples: int = 16
    ) -> None:
        super().__init__()
        self.window_s = scalar("window_s", window_s, 0.5, 600.0)
        for name, value, high in (("peaks", peaks, 8), ("pad", pad, 64),
                                  ("min_samples", min_samples, 10_000)):  # fmt: skip
            if not isinstance(value, int) or not 1 <= value <= high:
                raise InvalidInputError(name, value, f"an integer in [1, {high}]")
        self.peaks, self.pad, self.min_samples = peaks, pad, max(min_samples, 2 * peaks + 2)
        self._samples: deque[tuple[float, float]] = deque()
        self._model: tuple[float, FloatArray, FloatArray] | None = None

    def _update(self, t: float, value: float) -> None:
        self._samples.append((t, value))
        while self._samples[0][0] < t - self.window_s:
            self._samples.popleft()
        if len(self._samples) >= self.min_samples:
            tt, yy = (np.array(c) for c in zip(*self._samples, strict=True))
            freqs = self._dominant(tt, yy)
            coef, _ = sinusoid_fit(tt - t, yy, freqs)
            self._model = (t, coef, freqs)

    def _dominant(self, t: FloatArray, y: FloatArray) -> FloatArray:
        """The `peaks` largest local maxima of the window's spectrum [Hz], refined."""
        dt = float(np.median(np.diff(t)))
        n = self.pad * len(y)
        spec = np.abs(np.fft.rfft((y - y.mean()) * np.hanning(len(y)), n))
        freqs = np.fft.rfftfreq(n, dt)
        k = np.flatnonzero((spec[1:-1] > spec[:-2]) & (spec[1:-1] >= spec[2:])) + 1
        k = k[np.argsort(spec[k])[::-1][: self.peaks]]
        log = np.log(spec + 1e-300)
        a, b, c = log[k - 1], log[k], log[k + 1]
        den = a - 2 * b + c
        shift = np.where(den < 0, 0.5 * (a - c) / np.where(den < 0, den, 1.0), 0.0)
        out: FloatArray = (k + shift) * (freqs[1] - freqs[0])
        return out

    def _predict(self, t: FloatArray) -> FloatArray:
        if self._model is None:
            return super()._predict(t)
        t0, coef, freqs = self._model
        return sinusoid_eval(coef, freqs, t - t0)
