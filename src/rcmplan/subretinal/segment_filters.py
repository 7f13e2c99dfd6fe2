"""Filters and peak searches along and across the A-lines of a B-scan, compiled, for the
segmentation (`segment_kernels`).

An image is held A-line by A-line: lines[j] is A-line j (column j of the B-scan), lines[j, k]
its row k, deeper with k. Smoothing is scipy.ndimage's Gaussian filter (weights
exp(-t^2 / (2 sigma^2)) for |t| up to int(4 sigma + 0.5), normalised): along an A-line with
its 'reflect' boundary (the edge row repeated), across A-lines with 'nearest' (the edge A-line
repeated). A gradient along an A-line is numpy's (central differences, one-sided at the first
and last rows).
"""

from __future__ import annotations

import math

import numpy as np

from rcmplan._jit import njit
from rcmplan._validate import FloatArray


@njit(cache=True)
def gaussian_taps(sigma: float) -> FloatArray:
    """scipy.ndimage's Gaussian weights for sigma [px]; [1] (no smoothing) for a radius of 0."""
    radius = int(4.0 * sigma + 0.5)
    taps = np.ones(2 * radius + 1)
    if radius == 0:
        return taps
    for t in range(-radius, radius + 1):
        taps[t + radius] = math.exp(-0.5 / (sigma * sigma) * t * t)
    return taps / taps.sum()


@njit(cache=True)
def reflect(i: int, n: int) -> int:
    """Index i folded into [0, n) as scipy.ndimage's 'reflect' mode (period 2n)."""
    if 0 <= i < n:
        return i
    i %= 2 * n
    return i if i < n else 2 * n - 1 - i


@njit(cache=True)
def smoothed(line: FloatArray, r: int, taps: FloatArray) -> float:
    """The A-line smoothed along itself at row r ('reflect')."""
    radius = taps.size // 2
    total = 0.0
    for t in range(taps.size):
        total += taps[t] * line[reflect(r + t - radius, line.size)]
    return total


@njit(cache=True)
def gradients(line: FloatArray, lo: int, hi: int, taps: FloatArray, out: FloatArray) -> None:
    """Into out[r - lo], the gradient per row of the smoothed A-line at each row r in
    [lo, hi) (0 <= lo < hi <= rows, rows >= 2)."""
    rows = line.size
    first, last = max(lo - 1, 0), min(hi, rows - 1)  # the smoothed rows read
    smooth = np.empty(last - first + 1)
    for r in range(first, last + 1):
        smooth[r - first] = smoothed(line, r, taps)
    for r in range(lo, hi):
        low, high = max(r - 1, 0), min(r + 1, rows - 1)
        diff = smooth[high - first] - smooth[low - first]
        out[r - lo] = diff / 2.0 if high - low == 2 else diff


@njit(cache=True)
def refine(line: FloatArray, k: int, before: int, after: int, taps: FloatArray) -> float:
    """Sub-row of the largest gradient of the smoothed A-line in rows [k - before, k + after]
    (each clipped to [1, rows - 2]; the first of equal ones), placed by a parabola through it
    and its neighbours."""
    lo = min(max(k - before, 1), line.size - 2) - 1
    hi = min(max(k + after, 1), line.size - 2) + 2
    grad = np.empty(hi - lo)
    gradients(line, lo, hi, taps, grad)
    best, b = -1, -np.inf
    for r in range(k - before, k + after + 1):
        i = min(max(r, 1), line.size - 2)
        if grad[i - lo] > b:
            best, b = i, grad[i - lo]
    a, c = grad[best - 1 - lo], grad[best + 1 - lo]
    den = a - 2.0 * b + c
    return best + (0.5 * (a - c) / den if den < 0.0 else 0.0)


@njit(cache=True)
def largest_peak(line: FloatArray, lo: int, hi: int, least: float) -> int:
    """Row of the largest value (the first of equal ones) in rows [lo, hi), lo clipped to
    [1, rows - 2] and hi to [1, rows - 1]; -1 where it is below `least` or the range empty."""
    lo, hi = min(max(lo, 1), line.size - 2), min(max(hi, 1), line.size - 1)
    best, value = -1, -np.inf
    for r in range(lo, hi):
        if line[r] > value:
            best, value = r, line[r]
    return best if value >= least else -1


@njit(cache=True)
def first_peak(line: FloatArray, lo: int, hi: int, least: float) -> int:
    """Row of the local maximum closing the first run at or above `least` in rows [lo, hi)
    (clipped as `largest_peak`): from the first row that reaches it, climb while the next row
    in the range is higher; -1 where none reaches it."""
    lo, hi = min(max(lo, 1), line.size - 2), min(max(hi, 1), line.size - 1)
    for r in range(lo, hi):
        if line[r] >= least:
            while r + 1 < hi and line[r + 1] > line[r]:
                r += 1
            return r
    return -1


@njit(cache=True)
def smooth_across(lines: FloatArray, sigma: float, out: FloatArray) -> FloatArray:
    """The image smoothed across A-lines ('nearest'), into out (returned)."""
    cols, rows = lines.shape
    taps = gaussian_taps(sigma)
    radius = taps.size // 2
    for j in range(cols):
        line = out[j]
        line[:] = 0.0
        for t in range(taps.size):
            w, near = taps[t], lines[min(max(j + t - radius, 0), cols - 1)]
            for k in range(rows):
                line[k] += w * near[k]
    return out


@njit(cache=True)
def step_detector(lines: FloatArray, n: int, out: FloatArray) -> None:
    """Into out, per A-line and row k, the mean of the n rows from k on less the mean of the n
    rows before k, 0 where either window leaves the A-line: a step detector whose noise is far
    below a single row's gradient."""
    cols, rows = lines.shape
    csum = np.empty(rows + 1)
    for j in range(cols):
        line, step = lines[j], out[j]
        csum[0] = 0.0
        for k in range(rows):
            csum[k + 1] = csum[k] + line[k]
        step[:] = 0.0
        for k in range(n, rows - n + 1):
            step[k] = (csum[k + n] - 2.0 * csum[k] + csum[k - n]) / n
