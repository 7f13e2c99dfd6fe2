"""A seeded synthetic surgeon: intended smooth motion, physiological tremor and sensor noise.

position(t) = intended(t) + tremor(t) + noise(t), in the master frame [m], sampled at the
device rate. Sources of the figures (docs/teleop.md lists them in full):

- Tremor band 6-16 Hz, the band in which Riviere, Rader and Thakor (IEEE TBME 45(7), 1998)
  measure tremor; its peak lies at 8-12 Hz (Wells et al., IEEE SMC 2013: "a distinct peak in
  the 6-12 Hz range"), so the centre frequency defaults to 10 Hz.
- Amplitude: 50-200 um RMS of hand tremor (Wells et al. 2013), 49 um RMS error of eye
  surgeons holding still (Riviere, Rader and Khosla, IEEE EMBS 1997), 38 um RMS during the
  most delicate part of retinal surgery (Singh and Riviere, NEBC 2002): 100 um RMS (3-D) by
  default, the middle of the range.
- Drift: tremor is a modulated sinusoid whose frequency and amplitude wander (the WFLC's
  model, Riviere et al. 1998). Here the frequency wanders by `frequency_drift_hz` (standard
  deviation, 1 Hz: across the 8-12 Hz peak) and the amplitude by `amplitude_drift` (20 %),
  both as smooth noise below `drift_bandwidth_hz`. These drift figures are assumptions within
  the published band, not measured values; real tremor is broader (Veluvolu and Ang,
  Sensors 11(3), 2011, find several dominant frequencies), so a canceller does better on this
  model than on a recorded hand (67 % in Riviere et al. 1998).
- Voluntary motion: 98.9 % of its power lies below 2 Hz (Riviere et al. 1997); the intended
  path here is made of minimum-jerk moves of 1-2.5 s.
- Sensor noise: white, `noise_rms` per axis (5 um: the resolution class of a precision haptic
  master, an assumption).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import signal

from rcmplan._validate import FloatArray, scalar
from rcmplan.exceptions import InvalidInputError
from rcmplan.teleop.motion_plan import DEFAULT_PLAN, MotionPlan
from rcmplan.teleop.samples import MasterTrack, check_track

TREMOR_BAND_HZ = (6.0, 16.0)
TREMOR_RMS_MAX_M = 5e-3  # the largest synthetic tremor accepted, RMS of its 3-D magnitude [m]


@dataclass(frozen=True)
class SyntheticSurgeon:
    """Settings of the synthetic surgeon (SI units).

    Attributes:
        seed: Seed of every random draw (tremor phase, drift, direction, noise).
        rate_hz: Device sample rate [Hz].
        tremor_rms: RMS of the 3-D tremor displacement |tremor(t)| over the session [m].
        tremor_frequency_hz: Centre frequency of the tremor [Hz], in the 6-16 Hz band.
        frequency_drift_hz: Standard deviation of the frequency's wander [Hz].
        amplitude_drift: Standard deviation of the amplitude's relative wander.
        drift_bandwidth_hz: Bandwidth of the wander [Hz].
        noise_rms: Sensor noise per axis [m].
        plan: The intended motion and the clutch schedule.
    """

    seed: int = 0
    rate_hz: float = 1000.0
    tremor_rms: float = 100e-6
    tremor_frequency_hz: float = 10.0
    frequency_drift_hz: float = 1.0
    amplitude_drift: float = 0.2
    drift_bandwidth_hz: float = 0.2
    noise_rms: float = 5e-6
    plan: MotionPlan = field(default_factory=lambda: DEFAULT_PLAN)

    def __post_init__(self) -> None:
        if not isinstance(self.seed, int) or isinstance(self.seed, bool) or self.seed < 0:
            raise InvalidInputError("seed", self.seed, "an integer >= 0")
        scalar("rate_hz", self.rate_hz, 100.0, 10_000.0)
        scalar("tremor_rms", self.tremor_rms, 0.0, TREMOR_RMS_MAX_M)
        scalar("tremor_frequency_hz", self.tremor_frequency_hz, *TREMOR_BAND_HZ)
        scalar("frequency_drift_hz", self.frequency_drift_hz, 0.0, 5.0)
        scalar("amplitude_drift", self.amplitude_drift, 0.0, 0.5)
        scalar("drift_bandwidth_hz", self.drift_bandwidth_hz, 0.01, 2.0)
        scalar("noise_rms", self.noise_rms, 0.0, 1e-3)

    def track(self) -> MasterTrack:
        """The session's samples, with the intended motion kept beside them."""
        n = round(self.plan.duration * self.rate_hz) + 1
        t = np.arange(n) / self.rate_hz
        rng = np.random.default_rng(self.seed)
        intended = self.plan.positions(t)
        tremor = self.tremor(t, rng)
        noise = self.noise_rms * rng.standard_normal((n, 3))
        track = MasterTrack(t, intended + tremor + noise, self.plan.clutch(t), intended,
                            "synthetic")  # fmt: skip
        return check_track(track)

    def tremor(self, t: FloatArray, rng: np.random.Generator) -> FloatArray:
        """Tremor (N, 3) [m]: a(t) (u sin theta + v cos theta), theta' = 2 pi f(t), on a
        random ellipse (u, v), scaled to `tremor_rms`."""
        n = t.shape[0]
        lo, hi = TREMOR_BAND_HZ
        f = self.tremor_frequency_hz + self.frequency_drift_hz * self._wander(n, rng)
        f = np.clip(f, lo, hi)
        a = np.maximum(1.0 + self.amplitude_drift * self._wander(n, rng), 0.1)
        theta = rng.uniform(0.0, 2.0 * math.pi) + 2.0 * math.pi * np.cumsum(f) / self.rate_hz
        uv = rng.standard_normal((2, 3))
        d = (a * np.sin(theta))[:, None] * uv[0] + (a * np.cos(theta))[:, None] * uv[1]
        rms = math.sqrt(float(np.mean(np.sum(d * d, axis=1))))
        return d * (self.tremor_rms / rms) if rms > 0.0 else d

    def _wander(self, n: int, rng: np.random.Generator) -> FloatArray:
        """Smooth noise (n,) of unit standard deviation below `drift_bandwidth_hz`."""
        pad = int(4 * self.rate_hz / self.drift_bandwidth_hz)
        sos = signal.butter(2, self.drift_bandwidth_hz, fs=self.rate_hz, output="sos")
        w = signal.sosfiltfilt(sos, rng.standard_normal(n + 2 * pad))[pad : pad + n]
        return np.asarray(w / np.std(w))
