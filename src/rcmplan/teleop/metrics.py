"""Figures of a session, read from its log and trace (SI units).

- Tremor: the 6-16 Hz band (zero-phase fourth-order Butterworth band-pass over the whole
  session), RMS of its 3-D magnitude over the engaged periods: at the tip
  (`tip_tremor_rms_m`) and in the scaled input (`input_tremor_rms_m`, the raw master
  position divided by the scale); `tremor_reduction` = 1 - tip / input, given only when the
  input's band holds at least MIN_INPUT_TREMOR_M (a tremor-free input leaves the ratio of two
  figures of the controller's own resolution: with `--tremor-um 0` the tip's band holds about
  0.1 um).
- Reference: the scaled intended motion through the same clutch mapping: the tip anchor of
  each engagement plus the intended master displacement since the engagement, scaled and
  rotated. The intended motion is the input's own (a synthetic surgeon's) or, for a recorded
  input, a zero-phase 2 Hz low-pass of it (`intended_source` says which).
- Tracking: RMS of |tip - reference| over the engaged periods in free space, where the
  desired tip lies at least FREE_GUARD_M inside every fixture (at a fixture the needle stops
  by design: the dampers slow it within about v dt / gain of it).
- Added lag: the delay tau [s] that best aligns the tip with the reference (least squares over
  the same periods, both low-passed at 5 Hz zero-phase), searched over [0, MAX_LAG_S].
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import signal

from rcmplan._validate import FloatArray

BAND_HZ = (6.0, 16.0)
FREE_GUARD_M = 0.1e-3
MAX_LAG_S = 0.3
INTENDED_CUTOFF_HZ = 2.0
ALIGN_CUTOFF_HZ = 5.0
EDGE_S = 0.5
MIN_INPUT_TREMOR_M = 1e-6  # below it, the input has no tremor to reduce (module docstring)

Mask = NDArray[np.bool_]


def band_rms(x: FloatArray, mask: Mask, rate_hz: float) -> float | None:
    """RMS [m] of the 6-16 Hz band of x (N, 3) over mask; None with too few samples."""
    if x.shape[0] < 100 or not mask.any():
        return None
    sos = signal.butter(4, BAND_HZ, "bandpass", fs=rate_hz, output="sos")
    xb = signal.sosfiltfilt(sos, x - x[0], axis=0)
    return float(math.sqrt(np.mean(np.sum(xb[mask] ** 2, axis=1))))


def estimate_intended(master: FloatArray, rate_hz: float) -> FloatArray:
    """A zero-phase 2 Hz low-pass of master positions (N, 3) (voluntary motion lies below
    2 Hz, Riviere et al. 1997)."""
    if master.shape[0] < 100:
        return master.copy()
    sos = signal.butter(4, INTENDED_CUTOFF_HZ, fs=rate_hz, output="sos")
    return np.asarray(master[0] + signal.sosfiltfilt(sos, master - master[0], axis=0))


def reference(
    tip: FloatArray, segment: NDArray[np.int64], intended: FloatArray, to_tip: FloatArray
) -> FloatArray:
    """The scaled intended motion through the clutch mapping (N, 3) [m], NaN while released.

    Args:
        tip: Measured tips (N, 3); each engagement's first one is its anchor.
        segment: Engagement index per period (-1 released).
        intended: Intended master positions (N, 3).
        to_tip: (3, 3) map from master displacement to tip displacement (R / scale).
    """
    ref = np.full_like(tip, np.nan)
    for seg in np.unique(segment[segment >= 0]):
        idx = np.flatnonzero(segment == seg)
        k = idx[0]
        ref[idx] = tip[k] + (intended[idx] - intended[k]) @ to_tip.T
    return ref


def free_mask(retina_distance: FloatArray, box_depth: FloatArray, margin: float) -> Mask:
    """Periods whose desired tip lies at least FREE_GUARD_M inside the retina margin (its
    distance to the retina, (N,) [m]) and inside the box (its depth in the box, (N,) [m])."""
    return np.asarray((retina_distance >= margin + FREE_GUARD_M) & (box_depth >= FREE_GUARD_M))


def tracking_rms(tip: FloatArray, ref: FloatArray, mask: Mask) -> float | None:
    """RMS of |tip - ref| [m] over mask, None if empty."""
    if not mask.any():
        return None
    d = tip[mask] - ref[mask]
    return float(math.sqrt(np.mean(np.sum(d * d, axis=1))))


def added_lag(tip: FloatArray, ref: FloatArray, mask: Mask, rate_hz: float) -> float | None:
    """The delay tau [s] minimising the RMS of tip(t) - ref(t - tau) over mask (module
    docstring), to 0.01 ms, leaving out EDGE_S at each end (where the zero-phase filter's
    padding differs between the two); None with too few periods to tell."""
    edge = int(EDGE_S * rate_hz)
    mask = mask.copy()
    mask[:edge] = False
    mask[max(mask.shape[0] - edge, 0) :] = False
    if mask.sum() < 200:
        return None
    sos = signal.butter(4, ALIGN_CUTOFF_HZ, fs=rate_hz, output="sos")
    filled = np.where(np.isfinite(ref), ref, tip)
    a = tip[0] + signal.sosfiltfilt(sos, tip - tip[0], axis=0)
    b = tip[0] + signal.sosfiltfilt(sos, filled - tip[0], axis=0)
    t = np.arange(tip.shape[0]) / rate_hz

    def cost(tau: float) -> float:
        shifted = np.column_stack([np.interp(t[mask] - tau, t, b[:, i]) for i in range(3)])
        return float(np.mean(np.sum((a[mask] - shifted) ** 2, axis=1)))

    grid = np.arange(0.0, MAX_LAG_S, 1.0 / rate_hz)
    best = float(grid[int(np.argmin([cost(x) for x in grid]))])
    fine = np.arange(max(best - 1.0 / rate_hz, 0.0), best + 1.0 / rate_hz, 1e-5)
    return float(fine[int(np.argmin([cost(x) for x in fine]))])


def speed_excess(sliders: FloatArray, speed: FloatArray, dt: float) -> FloatArray:
    """Per period (N,), how far the fastest actuator moved beyond speed x dt since the last
    period, relative to its bound (0 within; first period 0)."""
    if sliders.shape[0] < 2:
        return np.zeros(sliders.shape[0])
    step = np.abs(np.diff(sliders, axis=0)) / (speed * dt)
    return np.concatenate([[0.0], np.maximum(step.max(axis=1) - 1.0, 0.0)])


def summary_band(values: dict[str, Any]) -> dict[str, Any]:
    """Tremor reduction ratio from tip and input tremor (None when either is missing, or when
    the input's tremor is below MIN_INPUT_TREMOR_M)."""
    tip, inp = values.get("tip_tremor_rms_m"), values.get("input_tremor_rms_m")
    ratio = None if tip is None or inp is None or inp < MIN_INPUT_TREMOR_M else 1.0 - tip / inp
    return {"tremor_reduction": ratio}
