"""The timeline of a replay: play, pause, speed and a time slider over the log's records.

The slider holds the simulated time [s]; a record is shown when the slider moves, whether a
person drags it or playback advances it (playback runs in its own thread at `fps` frames per
second of wall time, `speed` simulated seconds per second). Reaching the end pauses.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.view.server import viser_race

SPEEDS = ("0.01x", "0.1x", "0.25x", "0.5x", "1x", "2x", "5x", "10x")


class Timeline:
    """Timeline controls over record times.

    Args:
        gui: A viser GuiApi. times: Record times (N,) in [s], non-decreasing.
        on_index: Called with the record index to show (from viser's or the playback thread).
        fps: Playback frames per second (wall time).
    """

    def __init__(
        self, gui: Any, times: FloatArray, on_index: Callable[[int], None], fps: float = 30.0
    ) -> None:
        self.times = np.asarray(times, dtype=float)
        self.on_index = on_index
        self.fps = fps
        self.playing = False
        self.races = 0  # frames cut short by viser's race (`server.viser_race`)
        dt = float(np.median(np.diff(self.times))) if len(self.times) > 1 else 1e-3
        with gui.add_folder("Timeline"):
            self.button = gui.add_button("Play", icon=None)
            self.speed = gui.add_dropdown("speed", SPEEDS, initial_value="1x")
            self.slider = gui.add_slider(
                "time [s]", min=float(self.times[0]), max=float(self.times[-1]),
                step=max(dt, 1e-6), initial_value=float(self.times[0]),
            )  # fmt: skip
        self.button.on_click(lambda _event: self.toggle())
        self.slider.on_update(lambda _event: self.on_index(self.index_at(self.slider.value)))
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="rcmplan-view-playback",
                                        daemon=True)  # fmt: skip
        self._thread.start()

    def index_at(self, t: float) -> int:
        """The last record at or before time t (the first record before it)."""
        i = int(np.searchsorted(self.times, t + 1e-9, side="right")) - 1
        return min(max(i, 0), len(self.times) - 1)

    def seek(self, t: float) -> None:
        """Move the slider to time t [s] (clipped to the log), showing that record."""
        self.slider.value = float(np.clip(t, self.times[0], self.times[-1]))

    def toggle(self) -> None:
        """Play from where the slider is (from the start when at the end), or pause."""
        if not self.playing and self.slider.value >= self.times[-1]:
            self.seek(self.times[0])
        self.playing = not self.playing
        self.button.label = "Pause" if self.playing else "Play"

    def speed_factor(self) -> float:
        """Simulated seconds per wall-clock second."""
        return float(str(self.speed.value).rstrip("x"))

    def _run(self) -> None:
        period = 1.0 / self.fps
        last = due = time.perf_counter()
        while True:
            due = max(due + period, time.perf_counter())  # on schedule; late frames not caught up
            if self._stop.wait(max(0.0, due - time.perf_counter())):
                return
            now = time.perf_counter()
            if self.playing:
                t = self.slider.value + (now - last) * self.speed_factor()
                try:
                    self.seek(min(t, self.times[-1]))
                    if t >= self.times[-1]:  # paused once the last record is shown, not before
                        self.toggle()
                except RuntimeError as exc:
                    if not viser_race(exc):
                        raise
                    self.races += 1  # the frame is queued; the next one goes on
            last = now

    def close(self) -> None:
        """Stop playback and its thread."""
        self._stop.set()
        self._thread.join(timeout=2.0)
