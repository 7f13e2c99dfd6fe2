"""Master samples and recorded tracks of them, checked row by row before any motion.

A master sample is what a surgeon's input device reports: a time stamp t [s], the position
(3,) [m] of the handle in the master frame, and the clutch flag (True: engaged, the handle
drives the needle; False: released, the needle holds while the hand repositions). The master
frame has the eye frame's axes (`rcmplan.scene.eye.eye_frame`: z along the insertion axis, x
horizontal, y = z x x); its origin is arbitrary, since only displacements since the clutch
engaged move the needle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray
from rcmplan.exceptions import InputStreamError

# The slowest input accepted: no interval between samples longer than 1 / MIN_RATE_HZ.
MIN_RATE_HZ = 100.0
# [m/s] The fastest handle motion accepted between two samples, engaged or not: a hand moves
# at up to about 1 m/s in reaching; a jump faster than this is a glitch of the device or file.
MAX_SPEED_M_S = 2.0
# [m] Largest coordinate accepted (a master workspace is well inside a metre).
MAX_COORD_M = 1.0
# Slack on the interval check for time stamps written with rounding [s].
TIME_SLACK_S = 1e-9


class MasterSample(NamedTuple):
    """One master reading: time t [s], position (3,) [m] in the master frame, clutch engaged."""

    t: float
    position: FloatArray
    clutch: bool


@dataclass(frozen=True)
class MasterTrack:
    """A recorded or generated input: N samples, checked (see `check_track`).

    Attributes:
        time: (N,) time stamps [s], strictly increasing.
        position: (N, 3) master positions [m].
        clutch: (N,) True while engaged.
        intended: (N, 3) the intended part of the motion [m] when known (a synthetic
            surgeon's), else None: metrics then estimate it from the input.
        source: Where the track came from (a file name, "synthetic").
    """

    time: FloatArray
    position: FloatArray
    clutch: NDArray[np.bool_]
    intended: FloatArray | None = None
    source: str = "track"

    def __len__(self) -> int:
        return int(self.time.shape[0])

    @property
    def duration(self) -> float:
        """Time from the first sample to the last [s]."""
        return float(self.time[-1] - self.time[0])

    def player(self) -> TrackPlayer:
        """A reader of this track in time order (sample and hold)."""
        return TrackPlayer(self)


class TrackPlayer:
    """Reads a track the way a device delivers it: at time t, the latest sample whose time
    stamp is at or before t (times relative to the track's first sample). Calls must come in
    non-decreasing t (each costs O(1) on average)."""

    def __init__(self, track: MasterTrack) -> None:
        self.track = track
        self._t = (track.time - track.time[0]).tolist()
        self._p = track.position
        self._c = track.clutch.tolist()
        self._k = 0

    def index(self, t: float) -> int:
        """Index of the latest sample at or before t [s]."""
        k, times = self._k, self._t
        while k + 1 < len(times) and times[k + 1] <= t + TIME_SLACK_S:
            k += 1
        self._k = k
        return k

    def sample(self, t: float) -> MasterSample:
        """The latest sample at or before t [s], stamped with its own time."""
        k = self.index(t)
        return MasterSample(self._t[k], self._p[k], bool(self._c[k]))


def check_track(track: MasterTrack, max_speed: float = MAX_SPEED_M_S) -> MasterTrack:
    """Return the track if every row is valid, else raise InputStreamError naming the first
    bad row and its value: at least 2 samples; finite values; coordinates within MAX_COORD_M;
    strictly increasing time; no interval longer than 1 / MIN_RATE_HZ; no move between two
    samples faster than `max_speed` [m/s]."""
    src = track.source
    t, p = track.time, track.position
    n = t.shape[0]
    if n < 2 or p.shape != (n, 3) or track.clutch.shape != (n,):
        raise InputStreamError(src, None, "shape", (t.shape, p.shape, track.clutch.shape),
                               "at least 2 rows of time, x, y, z and clutch")  # fmt: skip
    _check_finite(src, "time_s", t[:, None])
    _check_finite(src, "position", p)
    if track.intended is not None:
        _check_finite(src, "intended", track.intended)
    problems = [_first(np.any(np.abs(p) > MAX_COORD_M, axis=1), 0)]
    dt = np.diff(t)
    gap = 1.0 / MIN_RATE_HZ
    speed = np.linalg.norm(np.diff(p, axis=0), axis=1) / np.where(dt > 0.0, dt, np.inf)
    problems += [_first(dt <= 0.0, 1), _first(dt > gap + TIME_SLACK_S, 1),
                 _first(speed > max_speed, 1)]  # fmt: skip
    k = min(problems)
    if k > n:
        return track
    kind = problems.index(k)
    before = float(t[k - 1]) if k else 0.0
    if kind == 0:
        raise InputStreamError(src, k, "position_m", p[k], f"coordinates within +-{MAX_COORD_M} m")
    if kind == 1:
        raise InputStreamError(src, k, "time_s", float(t[k]),
                               f"later than the previous row's {before!r} s (time must "
                               "increase strictly)")  # fmt: skip
    if kind == 2:
        raise InputStreamError(src, k, "time_s", float(t[k]),
                               f"at most {gap:g} s after the previous row's {before!r} s "
                               f"(a sample rate of at least {MIN_RATE_HZ:g} Hz)")  # fmt: skip
    raise InputStreamError(src, k, "position_m", p[k],
                           f"a move from the previous row at most {max_speed:g} m/s "
                           f"(this one: {float(speed[k - 1]):.4g} m/s)")  # fmt: skip


def _first(bad: np.ndarray, offset: int) -> int:
    """Row index of the first true entry (plus offset: checks on differences name the later
    row), or a number past every row."""
    idx = np.flatnonzero(bad)
    return int(idx[0]) + offset if idx.size else 1 << 62


def _check_finite(src: str, column: str, values: FloatArray) -> None:
    bad = np.flatnonzero(~np.all(np.isfinite(values), axis=1))
    if bad.size:
        k = int(bad[0])
        value = values[k] if values.shape[1] > 1 else float(values[k, 0])
        raise InputStreamError(src, k, column, value, "finite numbers (no NaN or inf)")


def check_position(name: str, position: object) -> FloatArray:
    """A live sample's position as a finite (3,) array within MAX_COORD_M, else raise."""
    try:
        p = np.asarray(position, dtype=np.float64).reshape(3)
    except (TypeError, ValueError) as exc:
        raise InputStreamError(name, None, "position_m", position, "3 numbers in m") from exc
    if not all(math.isfinite(v) and abs(v) <= MAX_COORD_M for v in p.tolist()):
        raise InputStreamError(name, None, "position_m", p,
                               f"3 finite numbers within +-{MAX_COORD_M} m")  # fmt: skip
    return p
