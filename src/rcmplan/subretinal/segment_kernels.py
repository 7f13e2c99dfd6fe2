"""The segmentation's steps compiled (`segment` module docstring): the shadow, the needle's
surface, the mask under it, the layer edges and the outlier test, on the filters of
`segment_filters`.

An image is held A-line by A-line (`segment_filters`): lines[j, k] is row k of A-line j, in dB
unless said otherwise. Along an A-line only the rows a step reads are smoothed.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.subretinal.segment_filters import (
    first_peak,
    gaussian_taps,
    gradients,
    largest_peak,
    refine,
    smoothed,
    step_detector,
)

IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]


@njit(cache=True)
def shadow_start(linear: FloatArray, level: float, min_rows: int, out: IntArray) -> None:
    """Per A-line j of an image in linear intensity, into out[j], the first row of the dark
    run that reaches its end: the rows whose intensity averaged over 7 rows (scipy's uniform
    filter, 'nearest': a running sum) stays below `level`; the number of rows where that run
    is shorter than `min_rows`."""
    cols, rows = linear.shape
    for j in range(cols):
        line, run = linear[j], 0
        total = 0.0
        for t in range(rows - 4, rows + 3):
            total += line[min(max(t, 0), rows - 1)]
        for k in range(rows - 1, -1, -1):  # total: the sum over rows k - 3 .. k + 3
            if total / 7.0 >= level:
                break
            run += 1
            total += line[max(k - 4, 0)] - line[min(k + 3, rows - 1)]
        out[j] = rows - run if run >= min_rows else rows


@njit(cache=True)
def needle_rows(
    lines: FloatArray, linear: FloatArray, shadow: IntArray, bright: float, surface_rows: int,
    min_edge_db: float, sigma_z: float, out: FloatArray,
) -> None:  # fmt: skip
    """Per A-line j, into out[j], the sub-row of the needle's surface (step 3), nan where none
    is seen: in an A-line shadowed from row s (0 < s < rows) whose linear intensity smoothed
    along it (sigma 1 px) reaches `bright` in rows [s - surface_rows, s], the largest gradient
    of the image smoothed along it (sigma_z px) in those rows if it reaches `min_edge_db`."""
    cols, rows = lines.shape
    taps_lin, taps_z = gaussian_taps(1.0), gaussian_taps(sigma_z)
    grad = np.empty(rows)
    for j in range(cols):
        out[j] = np.nan
        s = shadow[j]
        if s <= 0 or s >= rows:
            continue
        lo = s - surface_rows
        peak = -np.inf
        for r in range(max(lo, 0), s + 1):
            peak = max(peak, smoothed(linear[j], r, taps_lin))
        if peak < bright:
            continue
        first = max(lo, 1)  # the rows `largest_peak` reads
        gradients(lines[j], first, min(s + 1, rows - 1), taps_z, grad[first:])
        k = largest_peak(grad, lo, s + 1, min_edge_db)
        if k >= 0:
            out[j] = refine(lines[j], k, 0, 0, taps_z)


@njit(cache=True)
def layer_limit(shadow: IntArray, top_row: FloatArray) -> IntArray:
    """Per A-line, the row above which the layers are searched: 2 rows above the row of the
    needle's surface where one was found, else the first row of the shadow."""
    limit = shadow.copy()
    for j in range(limit.size):
        if not np.isnan(top_row[j]):
            limit[j] = int(np.floor(top_row[j])) - 2
    return limit


@njit(cache=True)
def clip_below(
    lines: FloatArray, floor: float, limit: IntArray, clipped: FloatArray, below: FloatArray
) -> int:
    """The image clipped from below at `floor` [dB] into `clipped`, and into the start of
    `below` (1-D, at least as long as the image) its clipped values in the rows from limit[j]
    on of each A-line j, in order; returns how many."""
    cols, rows = lines.shape
    count = 0
    for j in range(cols):
        line, out = lines[j], clipped[j]
        start = min(max(limit[j], 0), rows)
        for k in range(rows):
            out[k] = max(line[k], floor)
            if k >= start:
                below[count] = out[k]
                count += 1
    return count


@njit(cache=True)
def fill_below(lines: FloatArray, limit: IntArray, value: float) -> None:
    """Set the rows from limit[j] on of each A-line j to `value`."""
    for j in range(lines.shape[0]):
        lines[j, max(limit[j], 0) :] = value


@njit(cache=True)
def layer_rows(
    lines: FloatArray, limit: IntArray, sep: int, step_rows: int, min_step_db: float,
    sigma_z: float, step: FloatArray, ilm: FloatArray, rpe: FloatArray,
) -> None:  # fmt: skip
    """Per A-line j, into ilm[j] and rpe[j], the sub-rows of the ILM and the RPE above row
    limit[j] (nan where not found; step 4) in `lines`, the image clipped, masked and smoothed
    across A-lines: the step detector's (into `step`, of the image's shape) first peak
    reaching `min_step_db` from row `step_rows`, and its largest at least `sep` rows below
    that, each placed by the gradient of the A-line smoothed along itself (sigma_z px) in the
    rows from 3 above to 1 below it."""
    rows = lines.shape[1]
    taps = gaussian_taps(sigma_z)
    step_detector(lines, step_rows, step)
    for j in range(lines.shape[0]):
        end = limit[j] - step_rows // 2
        k_ilm = first_peak(step[j], step_rows, end, min_step_db)
        k_rpe = largest_peak(step[j], (k_ilm if k_ilm >= 0 else rows) + sep, end, min_step_db)
        # the detector at row k spans the boundary k - 1/2, where the gradient peaks too
        ilm[j] = refine(lines[j], k_ilm, 3, 1, taps) if k_ilm >= 0 else np.nan
        rpe[j] = refine(lines[j], k_rpe, 3, 1, taps) if k_rpe >= 0 else np.nan


@njit(cache=True)
def inliers(profile: FloatArray, valid: BoolArray, tolerance: float) -> BoolArray:
    """The valid A-lines whose value lies within `tolerance` of the median of the valid values
    around it: of 5 consecutive valid values (all of them if fewer; the upper median of an even
    count), mirrored at the ends (scipy's median filter, 'mirror')."""
    idx = np.empty(valid.size, dtype=np.int64)
    n = 0
    for j in range(valid.size):
        if valid[j]:
            idx[n] = j
            n += 1
    keep = np.zeros(valid.size, dtype=np.bool_)
    size = min(5, n)
    window = np.empty(size)
    for i in range(n):
        for t in range(size):  # insertion sort of the window
            w = i + t - size // 2
            value = profile[idx[-w if w < 0 else (2 * (n - 1) - w if w >= n else w)]]
            s = t
            while s > 0 and window[s - 1] > value:
                window[s] = window[s - 1]
                s -= 1
            window[s] = value
        keep[idx[i]] = abs(profile[idx[i]] - window[size // 2]) <= tolerance
    return keep


@njit(cache=True)
def needle_tip(
    x: FloatArray, top: FloatArray, dx: float, radius: float
) -> tuple[bool, float, float]:
    """Needle tip (found, x, z) [m] on the axis from its surface points (x, top) [m], top inf
    where an A-line sees none (step 5): the least-squares line z = slope x + intercept through
    at least 3 points, its end half an A-line beyond the last point towards the tip, the tip
    one radius from it, perpendicular to the axis; not found where the line is flat."""
    n, sx, sz, lo, hi = 0, 0.0, 0.0, np.inf, -np.inf
    for j in range(x.size):
        if np.isfinite(top[j]):
            n, sx, sz = n + 1, sx + x[j], sz + top[j]
            lo, hi = min(lo, x[j]), max(hi, x[j])
    if n < 3:
        return False, 0.0, 0.0
    mx, mz = sx / n, sz / n
    sxx = sxz = 0.0
    for j in range(x.size):
        if np.isfinite(top[j]):
            sxx += (x[j] - mx) ** 2
            sxz += (x[j] - mx) * (top[j] - mz)
    slope = sxz / sxx
    if abs(slope) < 1e-3:
        return False, 0.0, 0.0
    theta = math.atan(1.0 / slope)
    xc = (hi if slope > 0 else lo) + math.copysign(0.5 * dx, slope)
    zc = mz + slope * (xc - mx)
    up = math.copysign(1.0, theta)
    return True, xc - radius * up * math.cos(theta), zc + radius * up * math.sin(theta)
