"""The clutch: couples the master's motion to the needle while engaged, re-indexing on engage.

Engaging (the first engaged sample after a release, or the first sample of a session) takes
the master's position now and the needle tip's measured position now as the two anchors; from
then on the desired tip moves with the master's displacement from its anchor. Whatever the hand
did while released, the desired tip starts where the needle is: the needle never jumps. While
released the desired tip is the tip's measured position at the release: the needle holds
where it is (also when the surgeon released while pushing past a fixture: it holds at the
fixture, not at the unreachable point the hand asked for).
"""

from __future__ import annotations

from typing import NamedTuple

Vec3 = tuple[float, float, float]


class ClutchEvent(NamedTuple):
    """A change of the clutch: time t [s], "engaged" or "released", the needle tip [m]."""

    t: float
    kind: str
    tip: Vec3


class Clutch:
    """Anchors and the hold point (module docstring). Starts released, holding at `tip`."""

    def __init__(self, tip: Vec3 = (0.0, 0.0, 0.0)) -> None:
        self.engaged = False
        self.master_anchor: Vec3 = (0.0, 0.0, 0.0)
        self.tip_anchor: Vec3 = tip
        self.hold: Vec3 = tip
        self.events: list[ClutchEvent] = []
        self.reset(tip)

    def reset(self, tip: Vec3) -> None:
        """Released, holding at tip [m], no events."""
        self.engaged = False
        self.master_anchor = (0.0, 0.0, 0.0)
        self.tip_anchor = self.hold = tip
        self.events = []

    def step(self, t: float, engaged: bool, master: Vec3, tip: Vec3) -> Vec3 | None:
        """The master's displacement from its anchor [m] while engaged, None while released.

        Args:
            t: Time [s] (for the event list).
            engaged: The sample's clutch flag.
            master: The (filtered) master position [m].
            tip: The needle tip's measured position now [m].
        """
        if engaged != self.engaged:
            self.engaged = engaged
            self.events.append(ClutchEvent(t, "engaged" if engaged else "released", tip))
            if engaged:
                self.master_anchor, self.tip_anchor = master, tip
            else:
                self.hold = tip
        if not engaged:
            return None
        a = self.master_anchor
        return (master[0] - a[0], master[1] - a[1], master[2] - a[2])
