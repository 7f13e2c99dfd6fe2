"""The intended hand motion of a synthetic session: minimum-jerk moves and a clutch schedule.

A minimum-jerk move (Flash and Hogan, J. Neurosci. 5(7), 1985, the smooth profile of human
reaching) goes from rest to rest: p(s) = p0 + d (10 s^3 - 15 s^4 + 6 s^5), s = (t - t0) / T.
A circle turns once about a centre beside the hand, its angle on the same profile.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray, scalar, vector
from rcmplan.exceptions import InvalidInputError

MM = 1e-3


class Move(NamedTuple):
    """A minimum-jerk move by `delta` (3,) [m] in the master frame, from `start` [s] for
    `duration` [s]; with `radius` > 0 [m] instead a full circle in the master x-y plane
    (starting towards +y, centre at -radius along x), `delta` unused."""

    start: float
    duration: float
    delta: tuple[float, float, float] = (0.0, 0.0, 0.0)
    radius: float = 0.0


def min_jerk(s: FloatArray) -> FloatArray:
    """The minimum-jerk profile 10 s^3 - 15 s^4 + 6 s^5 of s clipped to [0, 1]."""
    s = np.clip(s, 0.0, 1.0)
    return np.asarray(s**3 * (10.0 - 15.0 * s + 6.0 * s * s))


@dataclass(frozen=True)
class MotionPlan:
    """Moves one after another (no overlap) from the origin, and the clutch schedule.

    Attributes:
        duration: Session length [s].
        moves: The moves, in time order.
        released: Intervals (t0, t1) [s] during which the clutch is released.
    """

    duration: float
    moves: tuple[Move, ...]
    released: tuple[tuple[float, float], ...] = ()

    def __post_init__(self) -> None:
        scalar("plan.duration", self.duration, 0.1, 3600.0)
        end = 0.0
        for i, m in enumerate(self.moves):
            scalar(f"moves[{i}].duration", m.duration, 0.0, self.duration, low_open=True)
            scalar(f"moves[{i}].start", m.start, end, self.duration - m.duration)
            vector(f"moves[{i}].delta", m.delta, 3)
            scalar(f"moves[{i}].radius", m.radius, 0.0, 0.5)
            end = m.start + m.duration
        for i, (a, b) in enumerate(self.released):
            if not 0.0 <= a < b:
                raise InvalidInputError(f"released[{i}]", (a, b), "0 <= t0 < t1 [s]")

    def positions(self, t: FloatArray) -> FloatArray:
        """Intended positions (N, 3) [m] at times t (N,) [s]."""
        p = np.zeros((t.shape[0], 3))
        for m in self.moves:
            s = min_jerk((t - m.start) / m.duration)
            if m.radius > 0.0:
                angle = 2.0 * math.pi * s
                p[:, 0] += m.radius * (np.cos(angle) - 1.0)
                p[:, 1] += m.radius * np.sin(angle)
            else:
                p += s[:, None] * np.asarray(m.delta)[None, :]
        return p

    def clutch(self, t: FloatArray) -> NDArray[np.bool_]:
        """True (engaged) at times t outside every released interval."""
        engaged = np.ones(t.shape[0], dtype=bool)
        for a, b in self.released:
            engaged &= ~((t >= a) & (t < b))
        return engaged


# The default 20 s session, hand motion in mm (at scale 20 the tip moves a twentieth of it),
# starting with the tip 2 mm from the retina on the insertion axis (`TeleopSettings`):
DEFAULT_PLAN = MotionPlan(
    duration=20.0,
    moves=(
        Move(1.5, 2.0, (20 * MM, 0.0, 0.0)),  # sideways, 1 mm at the tip
        Move(3.5, 1.5, (0.0, 15 * MM, 0.0)),
        Move(5.0, 3.5, (0.0, 0.0, 40 * MM)),  # towards the retina: 0.3 mm past the margin
        Move(9.2, 1.2, (0.0, 0.0, -40 * MM)),  # clutch released: the hand repositions
        Move(10.8, 2.0, (-30 * MM, 0.0, 0.0)),
        Move(12.8, 1.5, (0.0, -15 * MM, -20 * MM)),
        Move(14.5, 4.0, radius=6 * MM),  # a circle of 0.3 mm radius at the tip
    ),
    # Settling while the filters adapt, then released while pushing past the margin (the
    # needle holds at the margin, the summary notes it), and re-engaged after repositioning.
    released=((0.0, 1.5), (9.0, 10.6)),
)
