"""The image steps of the B-scan segmentation (`segment`) as numba kernels: smoothing, the
gradient along the A-lines, the shadow's start, the step detector, the peak searches and their
sub-row refinement. An image is (rows, A-lines), rows along the depth; a kernel loops over the
rows outermost, so that it reads the image in memory order, and allocates only its outputs.

The filters are scipy.ndimage's: a Gaussian of standard deviation sigma truncated at
int(4 sigma + 0.5) pixels and normalised to sum 1, along the A-lines with the image mirrored
about its edge pixels ("reflect"), across them with the edge pixels repeated ("nearest"); the
gradient is numpy's (central differences inside, one-sided at the two ends).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from rcmplan._validate import FloatArray


@njit(cache=True)
def gaussian_taps(sigma: float) -> FloatArray:
    """The normalised Gaussian weights (2 r + 1,), r = int(4 sigma + 0.5)."""
    r = int(4.0 * sigma + 0.5)
    w = np.empty(2 * r + 1)
    if r == 0:
        w[0] = 1.0
        return w
    total, c = 0.0, -0.5 / (sigma * sigma)
    for t in range(-r, r + 1):
        w[t + r] = math.exp(c * (t * t))
        total += w[t + r]
    return w / total


@njit(cache=True)
def smooth_rows(src: FloatArray, sigma: float) -> FloatArray:
    """src smoothed along the A-lines (axis 0), mirrored about the edge pixels."""
    rows, cols = src.shape
    w = gaussian_taps(sigma)
    r = (w.size - 1) // 2
    out = np.zeros((rows, cols))
    for i in range(rows):
        for t in range(-r, r + 1):
            k = i + t
            while k < 0 or k >= rows:  # reflect (d c b a | a b c d | d c b a)
                k = -k - 1 if k < 0 else 2 * rows - k - 1
            wt = w[t + r]
            for j in range(cols):
                out[i, j] += wt * src[k, j]
    return out


@njit(cache=True)
def smooth_cols(src: FloatArray, sigma: float) -> FloatArray:
    """src smoothed across the A-lines (axis 1), the edge A-lines repeated."""
    rows, cols = src.shape
    w = gaussian_taps(sigma)
    r = (w.size - 1) // 2
    out = np.zeros((rows, cols))
    pad = np.empty(cols + 2 * r)
    for i in range(rows):
        for j in range(cols + 2 * r):  # the row with its edge A-lines repeated r times
            pad[j] = src[i, min(max(j - r, 0), cols - 1)]
        for t in range(2 * r + 1):
            wt = w[t]
            for j in range(cols):
                out[i, j] += wt * pad[j + t]
    return out


@njit(cache=True)
def gradient_rows(src: FloatArray) -> FloatArray:
    """d src / d row: central differences inside, one-sided in the first and last rows."""
    rows, cols = src.shape
    out = np.empty((rows, cols))
    for j in range(cols):
        out[0, j] = src[1, j] - src[0, j]
        out[rows - 1, j] = src[rows - 1, j] - src[rows - 2, j]
    for i in range(1, rows - 1):
        for j in range(cols):
            out[i, j] = 0.5 * (src[i + 1, j] - src[i - 1, j])
    return out


@njit(cache=True)
def shadow_start(linear: FloatArray, level: float, min_rows: int) -> FloatArray:
    """Per A-line, the first row of the dark run that reaches the bottom: the rows whose mean
    over 7 rows (the edge rows repeated) stays below `level`; the row count where that run is
    shorter than `min_rows`."""
    rows, cols = linear.shape
    out = np.empty(cols)
    for j in range(cols):
        run = 0
        for i in range(rows - 1, -1, -1):
            acc = 0.0
            for k in range(i - 3, i + 4):
                acc += linear[min(max(k, 0), rows - 1), j]
            if acc / 7.0 >= level:
                break
            run += 1
        out[j] = rows - run if run >= min_rows else rows
    return out


@njit(cache=True)
def window_max(arr: FloatArray, lo: FloatArray, hi: FloatArray) -> FloatArray:
    """Per A-line j, the largest arr in rows [lo[j], hi[j]] (both ends in; -inf for none)."""
    rows, cols = arr.shape
    out = np.full(cols, -np.inf)
    for j in range(cols):
        for i in range(max(math.ceil(lo[j]), 0), min(math.floor(hi[j]), rows - 1) + 1):
            out[j] = max(out[j], arr[i, j])
    return out


@njit(cache=True)
def step_detector(img: FloatArray, n: int) -> FloatArray:
    """Mean of the n rows from each row down less the mean of the n rows above it (0 where
    either window leaves the image)."""
    rows, cols = img.shape
    csum = np.zeros((rows + 1, cols))
    for i in range(rows):
        for j in range(cols):
            csum[i + 1, j] = csum[i, j] + img[i, j]
    out = np.zeros((rows, cols))
    for k in range(n, rows - n + 1):
        for j in range(cols):
            out[k, j] = (csum[k + n, j] - 2.0 * csum[k, j] + csum[k - n, j]) / n
    return out


@njit(cache=True)
def peaks(arr: FloatArray, lo: FloatArray, hi: FloatArray, least: float, first: bool) -> FloatArray:
    """Per A-line, the row of a peak of `arr` in rows [lo, hi) (clipped to [1, rows - 2] and
    [1, rows - 1]): the largest, or with `first` the local maximum closing the first run at or
    above `least` (climbing while the next row inside is higher); nan where none reaches it."""
    rows, cols = arr.shape
    out = np.full(cols, np.nan)
    for j in range(cols):
        a, b = min(max(lo[j], 1.0), rows - 2.0), min(max(hi[j], 1.0), rows - 1.0)
        if first:
            start = -1
            for i in range(rows):
                if a <= i < b and arr[i, j] >= least:
                    start = i
                    break
            if start < 0:
                continue
            k = start
            while k + 1 < rows and k + 1 < b and arr[k + 1, j] > arr[k, j]:
                k += 1
            out[j] = k
        else:
            best, k = -np.inf, -1
            for i in range(rows):
                if a <= i < b and arr[i, j] > best:
                    best, k = arr[i, j], i
            if k >= 0 and best >= least:
                out[j] = k
    return out


@njit(cache=True)
def refine(grad: FloatArray, k: FloatArray, before: int, after: int) -> FloatArray:
    """Per A-line, the sub-row of the largest gradient in rows [k - before, k + after]
    (clipped to [1, rows - 2]), placed by a parabola through it and its neighbours (nan where
    k is nan)."""
    rows, cols = grad.shape
    out = np.full(cols, np.nan)
    for j in range(cols):
        if math.isnan(k[j]):
            continue
        base = int(k[j])
        best, top = -1, -np.inf
        for t in range(-before, after + 1):
            i = min(max(base + t, 1), rows - 2)
            if grad[i, j] > top:
                best, top = i, grad[i, j]
        a, b, c = grad[best - 1, j], grad[best, j], grad[best + 1, j]
        den = a - 2.0 * b + c
        out[j] = best + (0.5 * (a - c) / den if den < 0.0 else 0.0)
    return out


@njit(cache=True)
def mask_below(img: FloatArray, limit: FloatArray) -> FloatArray:
    """img with every pixel at or below row limit[j] of its A-line set to the median of those
    pixels (a copy; unchanged if there are none)."""
    rows, cols = img.shape
    out = img.copy()
    count = 0
    for j in range(cols):
        count += max(rows - max(math.ceil(limit[j]), 0), 0)
    if count == 0:
        return out
    values = np.empty(count)
    n = 0
    for i in range(rows):
        for j in range(cols):
            if i >= limit[j]:
                values[n] = img[i, j]
                n += 1
    level = np.median(values)
    for i in range(rows):
        for j in range(cols):
            if i >= limit[j]:
                out[i, j] = level
    return out
