"""The tip trace of a run, thinned to a drawable number of segments, each coloured by the
largest RCM deviation among the records it spans (so thinning never hides a peak)."""

from __future__ import annotations

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.control.log import RunLog

MAX_SEGMENTS = 4000


def rcm_deviation_norm(log: RunLog) -> FloatArray:
    """|p_rcm - trocar| per record (N,) in [m]; NaN where no RCM is held."""
    return np.asarray(np.linalg.norm(log.rcm_deviation(), axis=1))


def trace_segments(
    tip: FloatArray, deviation: FloatArray, max_segments: int = MAX_SEGMENTS
) -> tuple[FloatArray, FloatArray]:
    """(segments (k, 2, 3) [m], deviation (k,) [m]) of the tip path (N, 3), k <= max_segments.

    Segment j joins records idx[j] and idx[j + 1] of an even thinning; its deviation is the
    largest over records idx[j]..idx[j + 1] (NaN when none of them holds an RCM).
    """
    n = len(tip)
    if n < 2:
        return np.zeros((0, 2, 3)), np.zeros(0)
    idx = np.unique(np.round(np.linspace(0, n - 1, min(n, max_segments + 1))).astype(int))
    seg = np.stack([tip[idx[:-1]], tip[idx[1:]]], axis=1)
    d = np.asarray(deviation, dtype=float)
    with np.errstate(invalid="ignore"):
        span = np.fmax.reduceat(d[: idx[-1]], idx[:-1])  # records idx[j] .. idx[j+1] - 1
    span = np.fmax(span, d[idx[1:]])  # ... and the segment's end record
    return seg, span
