"""Physiological motion of the posterior eye wall along its local normal, and whole-eye motion.

The wall displacement d(t) [m] (positive away from the eye centre, `layers.py`) is the sum of a
breathing and a cardiac component, each a sinusoid whose amplitude and rate drift slowly:

    d(t) = sum_k A_k m_k(t) sin(phi_k(t)),    phi_k(t) = phi_k0 + 2 pi int_0^t f_k(s) ds
    m_k(t) = max(0, 1 + sigma_a x_a(t)),      f_k(t) = clip(f_k0 (1 + sigma_f x_f(t)), band_k)

with x_a, x_f independent Ornstein-Uhlenbeck processes of unit variance and correlation time
`drift_time_s` (exact discretisation on a grid of `grid_s`), phi_k0 uniform in [0, 2 pi). The
optional whole-eye motion is a rigid translation T(t) (3,) [m] of the eye (and of the trocar it
carries), per axis a smooth second-order Gauss-Markov process with standard deviation
`eye_drift_m` (`eye_translation`). Everything is drawn
from one seeded `numpy.random.Generator`: a seed gives the same trajectory on every machine.
Sources of the defaults: docs/subretinal.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rcmplan._validate import FloatArray, scalar
from rcmplan.exceptions import InvalidInputError

BREATHING_BAND_HZ = (0.2, 0.33)  # under anaesthesia; subretinal-sources.md, Motion
CARDIAC_BAND_HZ = (1.0, 2.0)


@dataclass(frozen=True)
class MotionModel:
    """Parameters of the physiological motion.

    Attributes:
        breathing_amplitude_m: Nominal breathing amplitude along the normal [m] (assumed).
        breathing_rate_hz: Nominal breathing rate [Hz], inside `breathing_band_hz`.
        breathing_band_hz: Range the drifting breathing rate stays in [Hz].
        cardiac_amplitude_m: Nominal cardiac amplitude along the normal [m] (assumed).
        cardiac_rate_hz: Nominal heart rate [Hz], inside `cardiac_band_hz`.
        cardiac_band_hz: Range the drifting heart rate stays in [Hz].
        amplitude_drift: sigma_a, relative standard deviation of each amplitude (assumed).
        rate_drift: sigma_f, relative standard deviation of each rate (assumed).
        drift_time_s: Correlation time of the amplitude and rate drifts [s] (assumed).
        eye_drift_m: Standard deviation per axis of the whole-eye translation [m]; 0 = none.
        eye_drift_time_s: Correlation time of the whole-eye translation [s].
        grid_s: Time step [s] of the sampled drifts (the phase is integrated on it).
    """

    breathing_amplitude_m: float = 50e-6
    breathing_rate_hz: float = 0.25
    breathing_band_hz: tuple[float, float] = BREATHING_BAND_HZ
    cardiac_amplitude_m: float = 10e-6
    cardiac_rate_hz: float = 1.5
    cardiac_band_hz: tuple[float, float] = CARDIAC_BAND_HZ
    amplitude_drift: float = 0.1
    rate_drift: float = 0.05
    drift_time_s: float = 10.0
    eye_drift_m: float = 0.0
    eye_drift_time_s: float = 30.0
    grid_s: float = 5e-3

    def __post_init__(self) -> None:
        for name in ("breathing", "cardiac"):
            scalar(f"{name}_amplitude_m", getattr(self, f"{name}_amplitude_m"), 0.0, 1e-3)
            lo, hi = getattr(self, f"{name}_band_hz")
            scalar(f"{name}_band_hz[0]", lo, 0.0, 20.0, low_open=True)
            scalar(f"{name}_band_hz[1]", hi, lo, 20.0)
            scalar(f"{name}_rate_hz", getattr(self, f"{name}_rate_hz"), lo, hi)
        scalar("amplitude_drift", self.amplitude_drift, 0.0, 1.0)
        scalar("rate_drift", self.rate_drift, 0.0, 1.0)
        scalar("drift_time_s", self.drift_time_s, 0.0, 1e4, low_open=True)
        scalar("eye_drift_m", self.eye_drift_m, 0.0, 10e-3)
        scalar("eye_drift_time_s", self.eye_drift_time_s, 0.0, 1e4, low_open=True)
        scalar("grid_s", self.grid_s, 0.0, 0.05, low_open=True)


def ornstein_uhlenbeck(
    rng: np.random.Generator, n: int, dt_s: float, tau_s: float, size: int = 1
) -> FloatArray:
    """n samples (n, size) of a unit-variance OU process with correlation time tau_s, started
    from its stationary distribution, by the exact discretisation."""
    from scipy import signal  # imported when used: reading an episode (`rcmplan view`) does not

    a = np.exp(-dt_s / tau_s)
    noise = rng.standard_normal((n, size)) * np.sqrt(1.0 - a * a)
    noise[0] = rng.standard_normal(size)
    x: FloatArray = signal.lfilter([1.0], [1.0, -a], noise, axis=0)  # x_k = a x_k-1 + noise_k
    return x


@dataclass(frozen=True)
class MotionTrajectory:
    """One sampled motion: query displacement(t) and translation(t) at any t in [0, duration].

    Attributes:
        t_s: Sample grid (n,) [s].
        phase_rad: Phases (n, 2) of breathing and cardiac [rad].
        amplitude_m: Amplitudes (n, 2) [m].
        rate_hz: Rates (n, 2) [Hz].
        translation_m: Whole-eye translation (n, 3) [m].
    """

    t_s: FloatArray
    phase_rad: FloatArray
    amplitude_m: FloatArray
    rate_hz: FloatArray
    translation_m: FloatArray

    @property
    def duration_s(self) -> float:
        """Last time the trajectory covers [s]."""
        return float(self.t_s[-1])

    def _times(self, t: object) -> FloatArray:
        arr = np.asarray(t, dtype=np.float64)
        outside = arr.size > 0 and (arr.min() < 0 or arr.max() > self.t_s[-1])
        if not np.isfinite(arr).all() or outside:
            raise InvalidInputError("t", t, f"finite times in [0, {self.duration_s:g}] s")
        return arr

    def _interp(self, t: FloatArray, column: FloatArray) -> FloatArray:
        return np.interp(t, self.t_s, column)

    def components(self, t: object) -> FloatArray:
        """Breathing and cardiac displacements (..., 2) [m] at times t [s]."""
        tt = self._times(t)
        amp, phase = self.amplitude_m, self.phase_rad
        out = [self._interp(tt, amp[:, k]) * np.sin(self._interp(tt, phase[:, k])) for k in (0, 1)]
        return np.stack(out, axis=-1)

    def displacement(self, t: object) -> FloatArray:
        """Wall displacement d(t) [m] along the outward normal at times t [s]."""
        return self.components(t).sum(axis=-1)

    def translation(self, t: object) -> FloatArray:
        """Whole-eye translation T(t) (..., 3) [m] at times t [s]."""
        tt = self._times(t)
        return np.stack([self._interp(tt, self.translation_m[:, k]) for k in range(3)], axis=-1)

    def ilm_offset(self, t: object, normal: object = (0.0, 0.0, 1.0)) -> FloatArray:
        """What an OCT fixed in the room sees of the ILM along `normal` (unit, eye frame):
        d(t) + T(t) . n [m]."""
        n = np.asarray(normal, dtype=np.float64)
        return self.displacement(t) + self.translation(t) @ n


def sample_motion(
    model: MotionModel, duration_s: float, seed: int | np.random.Generator
) -> MotionTrajectory:
    """Draw one motion trajectory over [0, duration_s] from `model`.

    Args:
        duration_s: Length [s].
        seed: An integer seed or a `numpy.random.Generator` (consumed).
    """
    duration = scalar("duration_s", duration_s, 0.0, 3600.0, low_open=True)
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    n = int(np.ceil(duration / model.grid_s)) + 1
    t = np.linspace(0.0, (n - 1) * model.grid_s, n)
    drift = ornstein_uhlenbeck(rng, n, model.grid_s, model.drift_time_s, size=4)
    phase0 = rng.uniform(0.0, 2 * np.pi, size=2)
    nominal_a = np.array([model.breathing_amplitude_m, model.cardiac_amplitude_m])
    nominal_f = np.array([model.breathing_rate_hz, model.cardiac_rate_hz])
    bands = np.array([model.breathing_band_hz, model.cardiac_band_hz])
    amplitude = nominal_a * np.maximum(0.0, 1.0 + model.amplitude_drift * drift[:, :2])
    rate = np.clip(nominal_f * (1.0 + model.rate_drift * drift[:, 2:]), bands[:, 0], bands[:, 1])
    steps = 0.5 * (rate[1:] + rate[:-1]) * model.grid_s
    phase = phase0 + 2 * np.pi * np.vstack([np.zeros((1, 2)), np.cumsum(steps, axis=0)])
    translation = eye_translation(model, n, rng)
    return MotionTrajectory(t, phase, amplitude, rate, translation)


def eye_translation(model: MotionModel, n: int, rng: np.random.Generator) -> FloatArray:
    """The whole-eye translation T (n, 3) [m] on the model's grid (`grid_s`): per axis a smooth
    second-order Gauss-Markov process of standard deviation `eye_drift_m`, an OU process of
    time constant tau = `eye_drift_time_s` / 2 low-passed once more with the same tau (its path
    has a velocity, of standard deviation eye_drift_m / tau, as a drifting head has; an OU path
    has none: its moves per period grow as the square root of the period). Started stationary
    (10 tau drawn and dropped before the first sample); zeros (nothing drawn) when
    `eye_drift_m` is 0."""
    if model.eye_drift_m == 0:
        return np.zeros((n, 3))
    from scipy import signal

    tau = 0.5 * model.eye_drift_time_s
    skip = int(np.ceil(10.0 * tau / model.grid_s))
    x = ornstein_uhlenbeck(rng, skip + n, model.grid_s, tau, size=3)
    a = np.exp(-model.grid_s / tau)
    c = (1.0 - a * a) / np.sqrt(1.0 + a * a)  # unit variance for a unit AR(1) input
    y: FloatArray = signal.lfilter([c], [1.0, -a], x, axis=0)
    return model.eye_drift_m * y[skip:]
