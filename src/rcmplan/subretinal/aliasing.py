"""Which rates a uniformly sampled sinusoid can have: folding into the first Nyquist zone.

Sampled every 1 / fs, a sinusoid of rate f gives the same samples as one of rate f + m fs (the
phasor turning the same way) and one of rate m fs - f (turning the other way), for any integer
m. Its folded rate, the one among them in [0, fs / 2], is all the samples tell; a rate band
[lo, hi] folds onto an interval of [0, fs / 2], and each folded rate stands for the rates of the
band that fold onto it (`band_rates`): one when the band lies inside one Nyquist zone
[m fs / 2, (m + 1) fs / 2], up to two when it straddles a zone edge and fs >= the band's width.
Between the samples those rates differ: a prediction there has to say which, or weigh them.
"""

from __future__ import annotations

import math

BandHz = tuple[float, float]
EPS_HZ = 1e-12


def fold_hz(f_hz: float, fs_hz: float) -> float:
    """The folded rate [Hz] in [0, fs_hz / 2] that a rate f_hz [Hz] shows sampled at fs_hz."""
    r = math.fmod(f_hz, fs_hz)
    r = r + fs_hz if r < 0 else r
    return min(r, fs_hz - r)


def folded_band(band_hz: BandHz, fs_hz: float) -> BandHz:
    """The interval [Hz] of [0, fs_hz / 2] onto which the band [Hz] folds."""
    lo, hi = band_hz
    half = 0.5 * fs_hz
    edges = [m * half for m in range(math.floor(lo / half) + 1, math.ceil(hi / half))]
    folded = [fold_hz(f, fs_hz) for f in (lo, hi, *edges)]
    return min(folded), max(folded)


def band_rates(
    folded_hz: float, band_hz: BandHz, fs_hz: float, margin_hz: float = 0.0
) -> list[tuple[float, int]]:
    """The rates [Hz] of the band, widened by `margin_hz` [Hz] on each side, that fold onto
    `folded_hz` at fs_hz, each with its turn: +1 when it is folded_hz + m fs (the phasor turns
    the same way), -1 when it is m fs - folded_hz (the other way)."""
    lo, hi = band_hz[0] - margin_hz, band_hz[1] + margin_hz
    out: list[tuple[float, int]] = []
    for m in range(math.floor((lo - folded_hz) / fs_hz), math.ceil((hi + folded_hz) / fs_hz) + 1):
        for turn in (1, -1):
            f = m * fs_hz + turn * folded_hz
            if lo - 1e-9 <= f <= hi + 1e-9 and all(abs(f - g) > 1e-9 for g, _ in out):
                out.append((f, turn))
    return out
