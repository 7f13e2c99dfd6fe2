"""The teleoperation pipeline: master sample -> tremor filter -> clutch -> scaling -> desired
tip -> X_ext target. One call per control period, in plain Python floats (see filters.py).

The filter runs on the master position at every period, engaged or not, so an adaptive
canceller keeps its lock on the tremor while the clutch is released; the clutch re-indexes on
the filtered position, so the desired tip starts where the needle is.
"""

from __future__ import annotations

import math

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.control.limits import WorkspaceBound
from rcmplan.robot.needle import axis_angles
from rcmplan.teleop.clutch import Clutch
from rcmplan.teleop.filters import TremorFilter, Vec3
from rcmplan.teleop.samples import MasterSample
from rcmplan.teleop.scaling import MotionScaling


class Pipeline:
    """Filter, clutch and scaling of one session.

    Args:
        tremor_filter: The tremor filter.
        scaling: The motion scaling (with the master-to-base rotation).
        clutch: The clutch (default: a new one).
    """

    def __init__(
        self, tremor_filter: TremorFilter, scaling: MotionScaling, clutch: Clutch | None = None
    ) -> None:
        self.filter = tremor_filter
        self.scaling = scaling
        self.clutch = clutch or Clutch()
        self.filtered: Vec3 = (0.0, 0.0, 0.0)

    def reset(self, master: Vec3, tip: Vec3) -> None:
        """At rest: the filter at the master position, the clutch released holding at tip."""
        self.filter.reset(master)
        self.clutch.reset(tip)
        self.filtered = master

    def step(self, t: float, sample: MasterSample, tip: Vec3) -> Vec3:
        """The desired tip [m] in the base frame for this period's sample, given the needle
        tip's measured position `tip` [m]."""
        p = sample.position
        xf = self.filter.step((float(p[0]), float(p[1]), float(p[2])))
        self.filtered = xf
        d = self.clutch.step(t, sample.clutch, xf, tip)
        if d is None:
            return self.clutch.hold
        a = self.clutch.tip_anchor
        dx, dy, dz = self.scaling.apply(d)
        return (a[0] + dx, a[1] + dy, a[2] + dz)


class TargetMaker:
    """X_ext targets "tip at p, RCM at the trocar" (`rcmplan.control.targets.rcm_target`, in
    floats for the per-period budget, its angles by `needle.axis_angles`), with p first brought
    into the allowed region: the workspace box and the ball `allowed_radius` about the eye
    centre (the retina less its no-go margin).

    The QP holds the fixtures whatever the target; bringing the target in makes the needle
    stop where the hand's path leaves the allowed region (the closest allowed point) instead
    of sliding along the fixture towards the X_ext compromise of an unreachable target, and
    keeps the needle direction (tip to trocar) defined.
    """

    def __init__(
        self, trocar: FloatArray, box: WorkspaceBound, centre: FloatArray, allowed_radius: float
    ) -> None:
        self.trocar = tuple(float(v) for v in trocar)
        self._o = tuple(float(v) for v in box.origin)
        self._R = [float(v) for v in np.asarray(box.rotation).ravel()]
        self._lo, self._hi = box.lower, box.upper
        self._c = tuple(float(v) for v in centre)
        self._r = float(allowed_radius)

    def clamp_box(self, p: Vec3) -> Vec3:
        """p [m] moved into the box (along the box axes); p itself if inside."""
        R, o, lo, hi = self._R, self._o, self._lo, self._hi
        d0, d1, d2 = p[0] - o[0], p[1] - o[1], p[2] - o[2]
        c0 = R[0] * d0 + R[3] * d1 + R[6] * d2
        c1 = R[1] * d0 + R[4] * d1 + R[7] * d2
        c2 = R[2] * d0 + R[5] * d1 + R[8] * d2
        if lo[0] <= c0 <= hi[0] and lo[1] <= c1 <= hi[1] and lo[2] <= c2 <= hi[2]:
            return p
        k0, k1, k2 = (min(max(c0, lo[0]), hi[0]), min(max(c1, lo[1]), hi[1]),
                      min(max(c2, lo[2]), hi[2]))  # fmt: skip
        return (o[0] + R[0] * k0 + R[1] * k1 + R[2] * k2,
                o[1] + R[3] * k0 + R[4] * k1 + R[5] * k2,
                o[2] + R[6] * k0 + R[7] * k1 + R[8] * k2)  # fmt: skip

    def clamp_ball(self, p: Vec3) -> Vec3:
        """p [m] moved radially into the allowed ball; p itself if inside."""
        c, r = self._c, self._r
        d = (p[0] - c[0], p[1] - c[1], p[2] - c[2])
        n = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        if n <= r:
            return p
        f = r / n
        return (c[0] + f * d[0], c[1] + f * d[1], c[2] + f * d[2])

    def allowed(self, p: Vec3) -> Vec3:
        """p brought into the box and the ball (alternating projections onto the two convex
        sets, two rounds: the box's faces lie far from the ball's surface by default)."""
        q = self.clamp_ball(self.clamp_box(p))
        return self.clamp_ball(self.clamp_box(q)) if q is not p else q

    def target(self, p: Vec3) -> FloatArray:
        """X_ext (6,) for the tip at p (brought into the allowed region), RCM at the trocar."""
        x, y, z = self.allowed(p)
        cx, cy, cz = self.trocar
        phi, psi = axis_angles(x - cx, y - cy, z - cz)
        return np.array([x, phi, psi, cx, cy, cz])
