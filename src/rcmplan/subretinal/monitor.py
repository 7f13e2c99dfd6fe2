"""The heart rate the anaesthesia monitor shows, an optional input of the `kalman` predictor.

Below about 4 volumes/s the cardiac band (1-2 Hz) folds across a Nyquist-zone edge of the iOCT
sampling, and two heart rates of the band can give the same samples (`aliasing.py`): the samples
cannot say which, the heart rate can. Under anaesthesia it is on the monitor all along (ECG or
pulse oximeter), so a controller can be given it. The episode models the reading as its nominal
heart rate (the mean the drifting rate wanders around) plus a normal error of standard deviation
`EpisodeSettings.heart_rate_sd_hz`, drawn from a generator of its own (the motion, the iOCT noise
and the draws of a batch stay those of the episode without it). The predictor weighs the rates
by the reading with that error combined with the motion model's rate drift: the current rate
differs from the nominal one by `rate_drift` of it (1 sigma).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from rcmplan.subretinal.episode_settings import EpisodeSettings
from rcmplan.subretinal.motion import MotionModel

READING_STREAM = 1  # spawn key of the reading's generator under the episode's seed


def heart_rate_input(cfg: EpisodeSettings, motion: MotionModel) -> dict[str, Any]:
    """The keyword arguments of the episode's predictor for the monitor's heart rate: none
    without a reading (`cfg.heart_rate_sd_hz` None) or for another method than `kalman`; else
    `heart_rate_hz` (the reading, clipped to the cardiac band) and `heart_rate_std_hz`."""
    sd = cfg.heart_rate_sd_hz
    if sd is None or cfg.compensation != "kalman":
        return {}
    rng = np.random.default_rng(np.random.SeedSequence(cfg.seed, spawn_key=(READING_STREAM,)))
    lo, hi = motion.cardiac_band_hz
    reading = float(np.clip(cfg.cardiac_rate_hz + sd * rng.standard_normal(), lo, hi))
    std = math.hypot(sd, motion.rate_drift * reading)
    return {"heart_rate_hz": reading, "heart_rate_std_hz": max(std, 1e-3)}
