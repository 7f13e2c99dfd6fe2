"""A curved needle: a straight shaft, then a circular arc ending at the tip (thesis ch. 5).

In the needle's mount frame the shaft runs from the origin along +z for l_s; the arc of radius R
and arc angle alpha then bends towards the mount's +x axis (the bevel direction), in the mount's
x-z plane. Along the arc, at angle t in [0, alpha]:

    p(t) = (R (1 - cos t), 0, l_s + R sin t),    tangent (sin t, 0, cos t).

The RCM lies on the shaft only: lambda in [0, 1] parametrises the shaft, p(lambda) = lambda l_s z.
With alpha = 0 the tip is the shaft's end: the straight needle of length l_s.

Default values (assumed, with their sources): R = 12 mm, the radius of the adult eye, as the
Curved-Micro-Drainer is curved to follow the spherical globe (Biomedical Microdevices
18:65, 2016, a 5 mm curved part); a sub-Tenon cannula curved with R = 14 mm for the same reason
(mvupgo.com, sub-Tenon cannula). alpha = 0.25 rad gives a 3 mm arc (the drainer's curved part is
5 mm): entering through the trocar turns the shaft by alpha about it; alpha = 0.4 rad takes
iRAM!S's sliders beyond their assumed +-40 mm travel for each bend direction tried
(docs/robots.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from rcmplan._validate import FloatArray, pose, scalar
from rcmplan.robot.needle import StraightNeedle

DEFAULT_RADIUS = 12e-3  # [m] the eye's radius (see the module docstring)
DEFAULT_ARC_ANGLE = 0.25  # [rad] a 3 mm arc at R = 12 mm
RADIUS_RANGE = (1e-3, 1.0)  # [m] tighter than 1 mm does not pass a 20G-25G trocar
ARC_ANGLE_RANGE = (0.0, 0.5 * math.pi)  # [rad] up to a quarter circle


@dataclass(frozen=True)
class CurvedNeedle:
    """A straight shaft of length l_s then an arc of radius R and angle alpha (module docstring).

    Attributes:
        shaft_length: l_s in [m], in (0, 1].
        radius: R in [m], in [1 mm, 1 m].
        arc_angle: alpha in [rad], in [0, pi/2]; 0 is the straight needle of length l_s.
        mount: (4, 4) pose of the needle base in the tool frame: the shaft along its +z, the arc
            bending towards its +x.
    """

    shaft_length: float
    radius: float = DEFAULT_RADIUS
    arc_angle: float = DEFAULT_ARC_ANGLE
    mount: FloatArray = field(default_factory=lambda: np.eye(4))

    def __post_init__(self) -> None:
        checked = {
            "shaft_length": scalar(
                "needle.shaft_length", self.shaft_length, 0.0, 1.0, low_open=True
            ),
            "radius": scalar("needle.radius", self.radius, *RADIUS_RANGE),
            "arc_angle": scalar("needle.arc_angle", self.arc_angle, *ARC_ANGLE_RANGE),
            "mount": pose("needle.mount", self.mount),
        }
        for name, value in checked.items():
            object.__setattr__(self, name, value)

    @property
    def name(self) -> str:
        """ "curved", or "straight" when alpha = 0."""
        return "curved" if self.curved else "straight"

    @property
    def curved(self) -> bool:
        """True when the arc bends (alpha > 0)."""
        return self.arc_angle > 0.0

    @property
    def arc_length(self) -> float:
        """R alpha in [m]."""
        return self.radius * self.arc_angle

    def shaft(self) -> StraightNeedle:
        """The straight shaft as a StraightNeedle (the needle the RCM lies on)."""
        return StraightNeedle(self.shaft_length, self.mount)

    def arc_local(self, t: float) -> FloatArray:
        """The arc point at angle t in [0, alpha], in needle-base (mount) coordinates [m]
        (any finite t: the arc's circle)."""
        return arc_point(self.radius, self.shaft_length, scalar("t", t))

    def tangent_local(self, t: float) -> FloatArray:
        """The unit tangent of the arc at angle t, mount coordinates."""
        t = scalar("t", t)
        return np.array([math.sin(t), 0.0, math.cos(t)])

    def tip_local(self) -> FloatArray:
        """The tip (t = alpha), mount coordinates [m]."""
        return self.arc_local(self.arc_angle)

    def tip_direction_local(self) -> FloatArray:
        """The unit tip tangent (t = alpha), mount coordinates."""
        return self.tangent_local(self.arc_angle)

    def chord_angle(self, depth: float) -> float:
        """Angle in [rad] between the shaft and the line from a shaft point `depth` [m] before
        the shaft's end to the tip; depth finite."""
        depth = scalar("depth", depth)
        p = self.tip_local()
        return math.atan2(p[0], p[2] - self.shaft_length + depth)


def arc_point(radius: float, shaft_length: float, t: float) -> FloatArray:
    """p(t) = (R (1 - cos t), 0, l_s + R sin t) [m] in the mount frame (module docstring): the
    point at angle t of the arc of radius R after a shaft of length l_s (0: from the shaft's
    end). The scenes' drawn arcs and `CurvedNeedle.arc_local` take it from here."""
    return np.array([radius * (1.0 - math.cos(t)), 0.0, shaft_length + radius * math.sin(t)])
