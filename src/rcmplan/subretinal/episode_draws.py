"""The ranges that a batch of subretinal episodes draws its conditions from, and the draws.

Episode k of a batch with seed s draws every condition from its own generator,
`numpy.random.default_rng(SeedSequence(s, spawn_key=(k,)))`: the same seed gives the same
episodes, and episode k is the same whatever the number of episodes. Each condition is uniform
in its range, the iOCT volume rate log-uniform (its range spans 1.6 to 51 Hz, a factor of 32).
A range whose two ends are equal fixes the condition. Sources of the ranges: docs/subretinal.md.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace
from typing import Any

import numpy as np

from rcmplan._validate import scalar
from rcmplan.exceptions import InvalidInputError
from rcmplan.subretinal.episode_settings import EYE_DRIFT_MAX_M, EpisodeSettings
from rcmplan.subretinal.motion import BREATHING_BAND_HZ, CARDIAC_BAND_HZ

Range = tuple[float, float]


@dataclass(frozen=True)
class DrawRanges:
    """Ranges (low, high) of the conditions drawn per episode (SI units).

    Attributes:
        breathing_amplitude_m: Breathing amplitude along the normal [m].
        cardiac_amplitude_m: Cardiac amplitude along the normal [m].
        breathing_rate_hz: Nominal breathing rate [Hz], inside the motion model's band.
        cardiac_rate_hz: Nominal heart rate [Hz], inside the motion model's band.
        ioct_rate_hz: iOCT volume rate [Hz] (log-uniform).
        latency_s: iOCT latency [s].
        noise_std_m: Standard deviation of the iOCT estimates' error [m].
        target_fraction: Target depth between ILM (0) and RPE (1).
        eye_drift_m: Standard deviation per axis of the whole-eye translation [m] (0, 0:
            the eye stays put; drawn last, so a drawn range leaves the other conditions as
            they are, the episode's seed not).
    """

    breathing_amplitude_m: Range = (20e-6, 75e-6)
    cardiac_amplitude_m: Range = (2e-6, 15e-6)
    breathing_rate_hz: Range = BREATHING_BAND_HZ
    cardiac_rate_hz: Range = CARDIAC_BAND_HZ
    ioct_rate_hz: Range = (1.6, 51.0)
    latency_s: Range = (0.0, 0.3)
    noise_std_m: Range = (0.23e-6, 3.3e-6)
    target_fraction: Range = (0.3, 0.7)
    eye_drift_m: Range = (0.0, 0.0)

    def __post_init__(self) -> None:
        envelopes: dict[str, tuple[float, float, bool]] = {
            "breathing_amplitude_m": (0.0, 200e-6, False),
            "cardiac_amplitude_m": (0.0, 200e-6, False),
            "breathing_rate_hz": (*BREATHING_BAND_HZ, False),
            "cardiac_rate_hz": (*CARDIAC_BAND_HZ, False),
            "ioct_rate_hz": (0.5, 200.0, False),
            "latency_s": (0.0, 1.0, False),
            "noise_std_m": (0.0, 50e-6, False),
            "target_fraction": (0.0, 1.0, True),
            "eye_drift_m": (0.0, EYE_DRIFT_MAX_M, False),
        }
        for name, (low, high, open_ends) in envelopes.items():
            value = getattr(self, name)
            if not isinstance(value, tuple | list) or len(value) != 2:
                raise InvalidInputError(
                    name, value, f"a pair (low, high) within [{low:g}, {high:g}]"
                )
            lo = scalar(f"{name}[0]", value[0], low, high, low_open=open_ends, high_open=open_ends)
            hi = scalar(f"{name}[1]", value[1], lo, high, high_open=open_ends)
            object.__setattr__(self, name, (lo, hi))

    def check_against(self, base: EpisodeSettings) -> None:
        """Refuse ranges that the episode settings `base` cannot take: a target band reaching
        past the ILM or the RPE, or a motion that could reach the needle hovering at rest."""
        band = base.band_fraction
        lo, hi = self.target_fraction
        scalar("target_fraction[0]", lo, band, 1.0 - band)
        scalar("target_fraction[1]", hi, band, 1.0 - band)
        reach = self.breathing_amplitude_m[1] + self.cardiac_amplitude_m[1]
        valid = f"below the stand-off, {base.standoff_m * 1e6:g} um (the needle's path at rest)"
        if reach >= base.standoff_m:
            raise InvalidInputError(
                "breathing_amplitude_m[1] + cardiac_amplitude_m[1]", reach, valid
            )

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON-ready dictionary (pairs as lists)."""
        return {k: list(v) for k, v in asdict(self).items()}


@dataclass(frozen=True)
class EpisodeDraw:
    """The conditions of one episode (SI units; fields as in `DrawRanges`) and its seed.
    `noise_std_m` is None where the episode does not use it (a batch's record of "image"
    estimates: `episode_batch.run_job`); `settings` then keeps the base's."""

    episode: int
    seed: int
    breathing_amplitude_m: float
    cardiac_amplitude_m: float
    breathing_rate_hz: float
    cardiac_rate_hz: float
    ioct_rate_hz: float
    latency_s: float
    noise_std_m: float | None
    target_fraction: float
    eye_drift_m: float = 0.0

    def settings(self, base: EpisodeSettings, compensation: str) -> EpisodeSettings:
        """`base` with this episode's conditions and the given compensation."""
        return replace(
            base,
            compensation=compensation,
            seed=self.seed,
            breathing_m=self.breathing_amplitude_m,
            cardiac_amplitude_m=self.cardiac_amplitude_m,
            breathing_rate_hz=self.breathing_rate_hz,
            cardiac_rate_hz=self.cardiac_rate_hz,
            ioct_rate_hz=self.ioct_rate_hz,
            latency_s=self.latency_s,
            noise_std_m=base.noise_std_m if self.noise_std_m is None else self.noise_std_m,
            target_fraction=self.target_fraction,
            eye_drift_m=self.eye_drift_m,
        )

    def as_dict(self) -> dict[str, Any]:
        """Plain dictionary."""
        return asdict(self)


CONDITIONS = tuple(f.name for f in fields(DrawRanges))


def _uniform(rng: np.random.Generator, bounds: Range, log: bool = False) -> float:
    lo, hi = bounds
    if lo == hi:
        return lo
    if log and lo > 0:
        return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))
    return float(rng.uniform(lo, hi))


def draw_episode(ranges: DrawRanges, seed: int, episode: int) -> EpisodeDraw:
    """The conditions of episode `episode` (>= 0) of a batch with seed `seed` (module doc)."""
    if not isinstance(seed, int) or isinstance(seed, bool) or not 0 <= seed < 2**32:
        raise InvalidInputError("seed", seed, "an integer in [0, 2**32)")
    if not isinstance(episode, int) or isinstance(episode, bool) or episode < 0:
        raise InvalidInputError("episode", episode, "an integer >= 0")
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(episode,)))
    values = {name: _uniform(rng, getattr(ranges, name), name == "ioct_rate_hz")
              for name in CONDITIONS}  # fmt: skip
    return EpisodeDraw(episode=episode, seed=int(rng.integers(0, 2**32)), **values)


def draw_episodes(ranges: DrawRanges, seed: int, n: int) -> list[EpisodeDraw]:
    """Episodes 0 to n - 1 of a batch with seed `seed`."""
    if not isinstance(n, int) or isinstance(n, bool) or n < 1:
        raise InvalidInputError("episodes", n, "an integer >= 1")
    return [draw_episode(ranges, seed, k) for k in range(n)]
