"""rcmplan's predictor of the ILM displacement: an extended Kalman filter on a drifting
two-harmonic model (breathing and cardiac).

Model. Each harmonic k is a rotating phasor (c_k, s_k) with angular rate w_k [rad/s]; the
measured displacement is the sum of the in-phase parts plus a slowly wandering offset b:

    state x = (c_1, s_1, c_2, s_2, b, w_1, w_2),     y = c_1 + c_2 + b + v,  v ~ N(0, r^2)
    over dt: (c_k, s_k) <- R(w_k dt) (c_k, s_k);  b, w_k unchanged

with process noise (random walks): each phasor component q_a,k^2 dt (q_a,k = `amplitude_walk`
times the harmonic's amplitude at acquisition), each rate (2 pi f_mid,k `frequency_walk`)^2 dt
(f_mid the band's centre), the offset `offset_walk_m`^2 dt. The transition is nonlinear in w_k
only; its Jacobian has d(c', s')/dw = dt (-s', c'). After each update w_k is clipped to its
band. The prediction at time t rotates each phasor by w_k (t - t_k) from the newest state.

Acquisition. The filter needs each harmonic's rate, amplitude and phase to start from: once
the estimates span `acquire_s`, a least-squares periodogram over each band (breathing first,
then cardiac on the residual, then breathing again on what the cardiac fit leaves) gives them;
the filter starts at the newest sample. Before that, the predictor holds the newest estimate.

Folded bands (`aliasing.py`). A band above half the sampling rate fs (the cardiac band 1-2 Hz
below 4 volumes/s) is searched and tracked at its folded rate, the one in [0, fs/2] that the
samples show; both rates are then searched at once (`acquisition.pair_search`), since a folded
band may overlap the other. The samples fit the folded phasor exactly; between them the
prediction turns it at each rate of the band that folds onto the tracked rate (one, or two when
the band straddles a zone edge: at 3 Hz, 1.2 and 1.8 Hz give the same samples), the turn
reversed for a mirrored rate, weighted by the probability that the rate lies in the band (the
tracked rate's standard deviation widening the band by 3 of them), times, for the cardiac
harmonic, the likelihood of a heart-rate reading when one is given (`heart_rate_hz`, e.g. from
the anaesthesia monitor, `monitor.py`). Two equally likely rates give the mean of their
predictions: half their difference in error, A / 2 RMS for an amplitude A, against A / sqrt(2)
for leaving the harmonic out. A folded harmonic that the samples cannot tell from the offset or
the other harmonic is left out, and what it leaves in the acquisition residual is added to r^2:
when its cosine and sine columns, less their fit by the others', keep less than half a unit
sinusoid's norm (`acquisition.separable`), or its folded rate lies within 1 / `acquire_s`
(the periodogram's resolution) of the other's, of 0 (at fs = 1.6 Hz a heart rate of 1.6 Hz
shows as a constant) or of fs/2 (where the samples alternate and show one component of the
phasor). A tracked folded rate that drifts that close restarts the filter.

Divergence. The normalised innovation squared, exponentially averaged over about 10 updates
(weight 0.1), is about 1 for a filter that fits (a mean of 10 chi-square variables with one
degree of freedom exceeds 4 with probability 2e-5); above `reacquire_nis` (4) the filter
starts again from a periodogram of the last `acquire_s` of estimates (a lost lock, a jump of
the heart rate).

Why not the WFLC (`rcmplan.teleop.wflc`): it runs at a fixed rate of at least 100 Hz, tracks one
harmonic through a band-pass prefilter and cancels tremor at the current sample; here the
samples arrive at 1.6-51 Hz, two harmonics matter and the estimate is needed 0-300 ms ahead.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from rcmplan._validate import FloatArray, scalar
from rcmplan.exceptions import InvalidInputError
from rcmplan.subretinal.acquisition import band_search, harmonics, pair_search, separable
from rcmplan.subretinal.aliasing import EPS_HZ, band_rates, folded_band
from rcmplan.subretinal.motion import BREATHING_BAND_HZ, CARDIAC_BAND_HZ
from rcmplan.subretinal.predict import Predictor, sinusoid_fit

H = np.array([1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0])
SQRT2 = math.sqrt(2.0)


class KalmanPredictor(Predictor):
    """The EKF predictor (module docstring).

    Args:
        bands_hz: (breathing, cardiac) rate bands [Hz].
        measurement_std_m: r, the standard deviation of one estimate [m].
        amplitude_walk: Phasor random walk per sqrt(s), relative to the amplitude.
        frequency_walk: Rate random walk per sqrt(s), relative to the band's centre.
        offset_walk_m: Offset random walk [m per sqrt(s)].
        acquire_s: Span of estimates [s] the acquisition periodogram waits for.
        reacquire_nis: Mean normalised innovation squared that restarts the filter.
        heart_rate_hz: A heart rate read elsewhere (the anaesthesia monitor) [Hz], or None;
            it weighs the cardiac band's rates that fold alike (module docstring).
        heart_rate_std_hz: The reading's error as a description of the current heart rate,
            one standard deviation [Hz].
    """

    name = "kalman"

    def __init__(
        self,
        bands_hz: tuple[tuple[float, float], tuple[float, float]] = (
            BREATHING_BAND_HZ,
            CARDIAC_BAND_HZ,
        ),
        measurement_std_m: float = 2e-6,
        amplitude_walk: float = 0.05,
        frequency_walk: float = 0.025,
        offset_walk_m: float = 1e-6,
        acquire_s: float = 8.0,
        reacquire_nis: float = 4.0,
        heart_rate_hz: float | None = None,
        heart_rate_std_hz: float = 0.1,
    ) -> None:
        super().__init__()
        for k, (lo, hi) in enumerate(bands_hz):
            scalar(f"bands_hz[{k}][0]", lo, 0.0, 50.0, low_open=True)
            scalar(f"bands_hz[{k}][1]", hi, lo, 50.0)
        if len(bands_hz) != 2:
            raise InvalidInputError("bands_hz", bands_hz, "two bands (breathing, cardiac)")
        self.bands_hz = bands_hz
        self.r2 = scalar("measurement_std_m", measurement_std_m, 1e-9, 1e-3) ** 2
        self.amplitude_walk = scalar("amplitude_walk", amplitude_walk, 0.0, 10.0)
        self.frequency_walk = scalar("frequency_walk", frequency_walk, 0.0, 10.0)
        self.offset_walk_m = scalar("offset_walk_m", offset_walk_m, 0.0, 1e-3)
        self.acquire_s = scalar("acquire_s", acquire_s, 0.5, 600.0)
        self.reacquire_nis = scalar("reacquire_nis", reacquire_nis, 1.0, 1e6)
        if heart_rate_hz is not None:
            scalar("heart_rate_hz", heart_rate_hz, *bands_hz[1])
        self.heart_rate_hz = heart_rate_hz
        self.heart_rate_std_hz = scalar("heart_rate_std_hz", heart_rate_std_hz, 1e-3, 10.0)
        self._t: deque[float] = deque()
        self._y: deque[float] = deque()
        self.x: FloatArray | None = None
        self.P = np.zeros((7, 7))
        self._q = np.zeros(7)
        self._r2 = self.r2
        self._fs_hz = 0.0
        self._folded = [False, False]
        self._active = [True, True]
        self._rate_bands = list(bands_hz)
        self._nis = 1.0
        self.acquisitions = 0

    @property
    def rates_hz(self) -> tuple[float, float] | None:
        """The tracked (breathing, cardiac) rates [Hz], or None before acquisition; a folded
        harmonic's is its folded rate (`aliasing`)."""
        if self.x is None:
            return None
        return float(self.x[5] / (2 * np.pi)), float(self.x[6] / (2 * np.pi))

    @property
    def rate_hypotheses_hz(self) -> list[list[float]]:
        """Per harmonic, the rates of its band [Hz] its prediction weighs (one unless its band
        is folded); none for a harmonic left out or before acquisition."""
        if self.x is None:
            return [[], []]
        return [[f for f, _ in self._rates(k)] if self._active[k] else [] for k in range(2)]

    def _update(self, t: float, value: float) -> None:
        self._t.append(t)
        self._y.append(value)
        while len(self._t) > 1 and t - self._t[1] >= self.acquire_s:
            self._t.popleft()  # keep the last acquire_s, and one sample before
            self._y.popleft()
        if self.x is not None:
            self._step(t - self.t_last_s)
            self._correct(value)
        lost = self.x is None or self._nis > self.reacquire_nis or self._confounded()
        if lost and t - self._t[0] >= self.acquire_s:
            self._acquire(np.array(self._t) - t, np.array(self._y))

    def _acquire(self, t: FloatArray, y: FloatArray) -> None:
        """Start the filter at t = 0 (the newest sample) from a periodogram (docstring)."""
        self._fs_hz = fs = 1.0 / float(np.median(np.diff(t)))
        self._folded = [band[1] > 0.5 * fs + EPS_HZ for band in self.bands_hz]
        self._rate_bands = [folded_band(b, fs) if f else b
                            for b, f in zip(self.bands_hz, self._folded, strict=True)]  # fmt: skip
        if any(self._folded):  # folded bands may overlap: search the pairs of rates
            freqs = pair_search(t, y, self._rate_bands)
        else:
            freqs = [0.5 * (lo + hi) for lo, hi in self._rate_bands]
            for k in [0, 1, 0]:
                rest = y - harmonics(t, y, [freqs[1 - k]])
                freqs[k] = band_search(t, rest, self._rate_bands[k])
        self._active = active = [
            not self._folded[k]
            or (separable(t, freqs[k], [freqs[1 - k]]) and not self._near(freqs[k], freqs[1 - k]))
            for k in range(2)
        ]
        for k in range(2):  # a harmonic left out: search the other's rate alone
            if not active[1 - k] and active[k]:
                freqs[k] = band_search(t, y, self._rate_bands[k])
        fitted = [f for f, a in zip(freqs, active, strict=True) if a]
        coef, resid = sinusoid_fit(t, y, np.array(fitted))
        phasors, i = np.zeros(4), 1
        for k in range(2):
            if active[k]:  # at t = 0 a cos(wt) + b sin(wt) = a: the phasor is (a, -b)
                phasors[2 * k : 2 * k + 2] = coef[i], -coef[i + 1]
                i += 2
        self.x = np.array([*phasors, coef[0], *(2 * np.pi * np.array(freqs))])
        self._initial_covariance(np.hypot(phasors[[0, 2]], phasors[[1, 3]]), active, resid)
        self._nis = 1.0
        self.acquisitions += 1

    def _near(self, f_hz: float, other_hz: float) -> bool:
        """Whether the folded rate f_hz [Hz] lies within 1 / acquire_s of the other harmonic's
        rate, of 0 or of fs / 2, where the samples cannot tell it apart over an acquisition."""
        gap = 1.0 / self.acquire_s
        return min(abs(f_hz - other_hz), f_hz, 0.5 * self._fs_hz - f_hz) < gap

    def _confounded(self) -> bool:
        """Whether a folded, modelled harmonic's tracked rate drifted `_near` the other's."""
        if self.x is None:
            return False
        f_hz = self.x[5:7] / (2 * np.pi)
        return any(self._folded[k] and self._active[k] and self._near(f_hz[k], f_hz[1 - k])
                   for k in range(2))  # fmt: skip

    def _initial_covariance(self, amps: FloatArray, active: list[bool], resid: FloatArray) -> None:
        """P, process noise and r^2 at acquisition; an inactive harmonic stays at 0."""
        mids = np.array([0.5 * (lo + hi) for lo, hi in self.bands_hz])
        widths = np.array([hi - lo for lo, hi in self._rate_bands])
        on = np.array(active, dtype=float)
        q_a = self.amplitude_walk * amps * on
        q_w = self.frequency_walk * 2 * np.pi * mids * on
        self._q = np.array([q_a[0], q_a[0], q_a[1], q_a[1], self.offset_walk_m, *q_w]) ** 2
        var = float(np.mean(resid**2))
        self._r2 = self.r2 if all(active) else max(self.r2, var)
        p0 = max(var, self.r2)
        self.P = np.diag([p0 * on[0]] * 2 + [p0 * on[1]] * 2 + [p0]
                         + list((2 * np.pi * widths / 8 * on) ** 2))  # fmt: skip

    def _step(self, dt: float) -> None:
        """Propagate state and covariance over dt [s]."""
        assert self.x is not None  # only called after acquisition
        x, jac = self.x.copy(), np.eye(7)
        for k in range(2):
            c, s, w = x[2 * k], x[2 * k + 1], x[5 + k]
            cos, sin = math.cos(w * dt), math.sin(w * dt)
            c2, s2 = cos * c - sin * s, sin * c + cos * s
            x[2 * k], x[2 * k + 1] = c2, s2
            jac[2 * k : 2 * k + 2, 2 * k : 2 * k + 2] = [[cos, -sin], [sin, cos]]
            jac[2 * k, 5 + k], jac[2 * k + 1, 5 + k] = -dt * s2, dt * c2
        self.x = x
        self.P = jac @ self.P @ jac.T + np.diag(self._q * dt)

    def _correct(self, value: float) -> None:
        """Measurement update with one estimate; rates clipped to their bands."""
        assert self.x is not None
        ph = self.P @ H
        var = H @ ph + self._r2
        gain = ph / var
        innovation = value - H @ self.x
        self._nis += 0.1 * (innovation * innovation / var - self._nis)
        self.x = self.x + gain * innovation
        self.P = self.P - np.outer(gain, ph)
        self.P = 0.5 * (self.P + self.P.T)
        for k, (lo, hi) in enumerate(self._rate_bands):
            self.x[5 + k] = min(max(self.x[5 + k], 2 * np.pi * lo), 2 * np.pi * hi)

    def _predict(self, t: FloatArray) -> FloatArray:
        if self.x is None:
            return super()._predict(t)
        parts = self.components(t)
        return np.asarray(parts[..., 2] + parts[..., 0] + parts[..., 1])

    def components(self, t_s: float | FloatArray) -> FloatArray:
        """The prediction's parts at times t_s [s], (..., 3): breathing, cardiac and offset [m]
        (their sum is `predict`); before acquisition 0, 0 and the newest estimate."""
        t = np.asarray(t_s, dtype=np.float64)
        out = np.zeros((*t.shape, 3))
        out[..., 2] = self.last_m if self.x is None else self.x[4]
        if self.x is None:
            return out
        dt = t - self.t_last_s
        for k in range(2):
            c, s = self.x[2 * k], self.x[2 * k + 1]
            rates = self._rates(k)
            for (f_hz, turn), weight in zip(rates, self._weights(k, rates), strict=True):
                w = 2 * np.pi * f_hz
                out[..., k] += weight * (c * np.cos(w * dt) - turn * s * np.sin(w * dt))
        return out

    def _weights(self, k: int, rates: list[tuple[float, int]]) -> FloatArray:
        """Weights of harmonic k's rates (summing to 1): the probability that each lies in the
        band given the tracked rate's standard deviation, times for the cardiac harmonic the
        likelihood of a heart-rate reading if there is one (module docstring)."""
        if len(rates) == 1:
            return np.ones(1)
        f_hz, sd = np.array([f for f, _ in rates]), self._rate_sd_hz(k)
        lo, hi = self.bands_hz[k]
        w = np.array([0.5 * (math.erf((f - lo) / sd / SQRT2) - math.erf((f - hi) / sd / SQRT2))
                      for f in f_hz])  # fmt: skip
        if k == 1 and self.heart_rate_hz is not None:
            z = (f_hz - self.heart_rate_hz) / self.heart_rate_std_hz
            w = w * np.exp(-0.5 * (z * z - np.min(z * z)))
        total = float(w.sum())
        return w / total if total > 0 else np.full(len(rates), 1.0 / len(rates))

    def _rate_sd_hz(self, k: int) -> float:
        """The standard deviation [Hz] of harmonic k's tracked rate (at least 1 mHz)."""
        return max(math.sqrt(max(float(self.P[5 + k, 5 + k]), 0.0)) / (2 * np.pi), 1e-3)

    def _rates(self, k: int) -> list[tuple[float, int]]:
        """Harmonic k's rates [Hz] with their turns (`aliasing.band_rates`): its tracked rate
        (+1) unless its band is folded."""
        assert self.x is not None
        f_hz = float(self.x[5 + k] / (2 * np.pi))
        if not self._folded[k]:
            return [(f_hz, 1)]
        margin = 3.0 * self._rate_sd_hz(k)
        return band_rates(f_hz, self.bands_hz[k], self._fs_hz, margin) or [(f_hz, 1)]
