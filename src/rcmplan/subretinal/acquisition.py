"""The least-squares periodogram searches that start `kalman.KalmanPredictor`: the rate of one
sinusoid in a band, the rates of two at once, and whether a rate can be told from others on the
samples at hand."""

from __future__ import annotations

import math

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.subretinal.predict import sinusoid_fit

GRID = 64  # candidate rates per band
SEPARATION = 0.5  # `separable`'s default floor


def band_search(t: FloatArray, y: FloatArray, band_hz: tuple[float, float]) -> float:
    """The rate [Hz] in `band_hz` whose least-squares sinusoid (with offset) leaves the
    smallest residual on y(t)."""
    freqs = np.linspace(band_hz[0], band_hz[1], GRID)
    best = min(freqs, key=lambda f: float(np.sum(sinusoid_fit(t, y, np.array([f]))[1] ** 2)))
    return float(best)


def pair_search(t: FloatArray, y: FloatArray, bands_hz: list[tuple[float, float]]) -> list[float]:
    """The pair of rates [Hz], one per band, whose least-squares sinusoids (with offset) leave
    the smallest residual on y(t): a `GRID` x `GRID` search."""
    grids = [np.linspace(lo, hi, GRID) for lo, hi in bands_hz]
    fa, fb = (g.reshape(-1) for g in np.meshgrid(*grids, indexing="ij"))
    wa, wb = 2 * np.pi * fa[:, None] * t, 2 * np.pi * fb[:, None] * t
    a = np.stack([np.ones_like(wa), np.cos(wa), np.sin(wa), np.cos(wb), np.sin(wb)], axis=-1)
    coef = np.linalg.pinv(a) @ y
    resid = np.sum((y - np.einsum("gnc,gc->gn", a, coef)) ** 2, axis=1)
    best = int(np.argmin(resid))
    return [float(fa[best]), float(fb[best])]


def separable(
    t: FloatArray, f_hz: float, others_hz: list[float], floor: float = SEPARATION
) -> bool:
    """Whether a sinusoid at f_hz [Hz] sampled at t [s] can be told from an offset and
    sinusoids at `others_hz`: the smallest singular value of its cosine and sine columns,
    less their least-squares fit by the others' columns, is at least `floor` of sqrt(n / 2),
    the norm of one sampled unit sinusoid (1: orthogonal; 0: collinear)."""
    cols = [np.ones_like(t)] + [g(2 * np.pi * f * t) for f in others_hz for g in (np.cos, np.sin)]
    a = np.column_stack(cols)
    c = np.column_stack([np.cos(2 * np.pi * f_hz * t), np.sin(2 * np.pi * f_hz * t)])
    rest = c - a @ np.linalg.lstsq(a, c, rcond=None)[0]
    return bool(np.linalg.svd(rest, compute_uv=False)[-1] >= floor * math.sqrt(0.5 * t.size))


def harmonics(t: FloatArray, y: FloatArray, freqs: list[float]) -> FloatArray:
    """The least-squares sinusoids at `freqs` [Hz] in y(t), without their offset."""
    coef, resid = sinusoid_fit(t, y, np.array(freqs))
    return y - resid - coef[0]
