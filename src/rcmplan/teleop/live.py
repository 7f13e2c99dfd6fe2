"""Live master input: any device (a haptic handle, the browser view's draggable target) pushes
positions from its own thread; the control loop reads the latest one each period."""

from __future__ import annotations

import threading
import time

import numpy as np

from rcmplan._validate import FloatArray, scalar
from rcmplan.teleop.samples import MasterSample, check_position


class LiveInput:
    """The latest master sample, shared between threads (a lock guards it).

    Before the first `push`, `latest()` is a released sample at `initial_position`: the needle
    holds until a device sends.

    Args:
        initial_position: Master position (3,) [m] reported before any push.
    """

    def __init__(self, initial_position: FloatArray | None = None) -> None:
        p = check_position("live input", np.zeros(3) if initial_position is None
                           else initial_position)  # fmt: skip
        self._lock = threading.Lock()
        self._sample = MasterSample(time.monotonic(), p, False)
        self.pushes = 0

    def push(self, position_m: FloatArray, clutch: bool = True, t: float | None = None) -> None:
        """Record the latest master position (3,) [m] in the master frame (the eye frame's
        axes) and the clutch (True: engaged), stamped `t` [s] on `time.monotonic()`'s clock
        (default: now). Raises InputStreamError for a position that is not 3 finite numbers
        within 1 m, InvalidInputError for a time stamp that is not finite."""
        p = check_position("live input", position_m)
        stamp = time.monotonic() if t is None else scalar("t", t)
        sample = MasterSample(stamp, p, bool(clutch))
        with self._lock:
            self._sample = sample
            self.pushes += 1

    def latest(self) -> MasterSample:
        """The latest sample (its position array is never changed afterwards)."""
        with self._lock:
            return self._sample
