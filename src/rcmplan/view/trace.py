"""The tip trace of a run, simplified to what the eye can see, coloured by RCM deviation.

A browser redraws every segment of the trace in every frame, and without a GPU (software
WebGL) each segment costs: an even thinning to 4,000 segments made a scrub of a MuJoCo run take
about 220 ms from click to drawn scene, against about 65 ms at 400 (benchmarks/bench_view.py).
The trace is therefore simplified in the way of Ramer-Douglas-Peucker, refined greedily where
it is worst: a segment is split at the record farthest from it until every record lies within
`tol` of the segment drawn through it and no segment is longer than `max_length` (so a colour
places its deviation along the path), or the segment budget is spent. Each segment is coloured
by the largest deviation among the records it draws, so a peak is never hidden. The distance
left is measured and reported with the trace, never assumed.
"""

from __future__ import annotations

import heapq
import itertools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray
from rcmplan.control.log import RunLog

MAX_SEGMENTS = 400
TOLERANCE = 1e-3  # of the eye's radius: 12 um on a 12 mm eye, under a pixel at the default view
LONGEST = 0.02  # of the eye's radius: a segment's colour places its deviation within 240 um


def rcm_deviation_norm(log: RunLog) -> FloatArray:
    """|p_rcm - trocar| per record (N,) in [m]; NaN where no RCM is held."""
    return np.asarray(np.linalg.norm(log.rcm_deviation(), axis=1))


@dataclass(frozen=True)
class Trace:
    """A simplified tip trace.

    Attributes:
        records: Indices of the records kept as vertices (k + 1,), increasing, first and last
            included. points: Their tips (k + 1, 3) [m]. deviation: Per segment (k,), the
            largest RCM deviation of the records it draws [m], NaN if none holds an RCM.
        position_error_m: The largest distance of any record from the segment drawn through it
            [m]. longest_m: The longest segment [m].
    """

    records: NDArray[np.int64]
    points: FloatArray
    deviation: FloatArray
    position_error_m: float
    longest_m: float

    @property
    def segments(self) -> FloatArray:
        """The segments (k, 2, 3) [m] joining consecutive vertices."""
        return np.stack([self.points[:-1], self.points[1:]], axis=1)

    def describe(self) -> str:
        """One sentence: how many records, drawn as how many segments, how closely."""
        n = int(self.records[-1]) + 1 if len(self.records) else 0
        return (
            f"The trace draws {n:,} records as {len(self.deviation):,} segments, every record "
            f"within {1e6 * self.position_error_m:.1f} um of its segment, each segment at most "
            f"{1e6 * self.longest_m:.0f} um long."
        )


def span_error(
    tip: FloatArray, i: int, j: int, tol: float, max_length: float
) -> tuple[float, int, float]:
    """How badly the segment from record i to j draws the records between them:
    (the larger of the farthest record's distance / tol and the segment's length / max_length,
    the record to split at, the farthest distance [m]). Too far: split at the farthest record;
    too long: at the record nearest the segment's middle."""
    if j - i < 2:
        return 0.0, i, 0.0
    a, b, p = tip[i], tip[j], tip[i + 1 : j]
    ab = b - a
    length = float(np.sqrt(ab @ ab))
    t = np.clip((p - a) @ ab / length**2, 0.0, 1.0) if length > 0.0 else np.zeros(len(p))
    dist = np.linalg.norm(p - (a + t[:, None] * ab), axis=1)
    far = int(np.argmax(dist))
    if dist[far] / tol >= length / max_length:
        return float(dist[far] / tol), i + 1 + far, float(dist[far])
    return length / max_length, i + 1 + int(np.argmin(np.abs(t - 0.5))), float(dist[far])


def simplify_trace(
    tip: FloatArray, deviation: FloatArray, tol: float, max_length: float,
    max_segments: int = MAX_SEGMENTS,
) -> Trace:  # fmt: skip
    """The tip path (N, 3) [m] as at most `max_segments` segments, split where the drawing is
    worst until every record lies within `tol` [m] of its segment and no segment is longer than
    `max_length` [m]; each segment carries the largest RCM deviation (N,) [m] of its records.
    The records where the needle enters or leaves the eye (deviation turns to or from NaN) are
    vertices while the budget allows."""
    tip = np.asarray(tip, dtype=float)
    deviation = np.asarray(deviation, dtype=float)
    n = len(tip)
    if tol <= 0.0 or max_length <= 0.0:
        raise ValueError(f"tol and max_length must be > 0 [m], got {tol}, {max_length}")
    if max_segments < 1:
        raise ValueError(f"max_segments must be >= 1, got {max_segments}")
    if n < 2:
        return Trace(np.arange(n), tip.copy(), np.zeros(0), 0.0, 0.0)
    held = np.isfinite(deviation)
    turns = np.flatnonzero(held[1:] != held[:-1])
    turns = np.union1d(turns, turns + 1) if 2 * len(turns) < max_segments // 4 else turns[:0]
    kept = sorted({0, n - 1, *turns.tolist()})
    heap: list[tuple[float, int, int, int, float]] = []
    for i, j in itertools.pairwise(kept):
        err, k, dist = span_error(tip, i, j, tol, max_length)
        heapq.heappush(heap, (-err, i, j, k, dist))
    while len(kept) - 1 < max_segments and -heap[0][0] > 1.0:
        _, i, j, k, _ = heapq.heappop(heap)
        kept.append(k)
        for lo, hi in ((i, k), (k, j)):
            err, split, dist = span_error(tip, lo, hi, tol, max_length)
            heapq.heappush(heap, (-err, lo, hi, split, dist))
    records = np.array(sorted(kept), dtype=np.int64)
    with np.errstate(invalid="ignore"):
        span = np.fmax.reduceat(deviation[: records[-1]], records[:-1])  # records i .. j - 1
    span = np.fmax(span, deviation[records[1:]])  # ... and the segment's end record
    points = tip[records]
    return Trace(
        records, points, span, max(h[4] for h in heap),
        float(np.linalg.norm(np.diff(points, axis=0), axis=1).max()),
    )  # fmt: skip


def trace_of(tip: FloatArray, deviation: FloatArray, eye_radius: float) -> Trace:
    """The view's trace of a run: `simplify_trace` with tolerances scaled to the eye."""
    return simplify_trace(tip, deviation, TOLERANCE * eye_radius, LONGEST * eye_radius)
