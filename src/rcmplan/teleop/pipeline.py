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
    """X_ext targets "tip at p, RCM at the trocar" (`rcmplan.control.targets.rcm_target`,
    written out in floats for the per-period budget), p kept in the workspace box so that
    the needle direction it asks for stays defined."""

    def __init__(self, trocar: FloatArray, box: WorkspaceBound) -> None:
        self.trocar = tuple(float(v) for v in trocar)
        self._o = tuple(float(v) for v in box.origin)
        self._R = [float(v) for v in np.asarray(box.rotation).ravel()]
        self._lo, self._hi = box.lower, box.upper

    def clamp(self, p: Vec3) -> Vec3:
        """p [m] moved into the box (along the box axes); p itself if inside."""
        R, o = self._R, self._o
        d = (p[0] - o[0], p[1] - o[1], p[2] - o[2])
        c = [R[i] * d[0] + R[3 + i] * d[1] + R[6 + i] * d[2] for i in range(3)]
        k = [min(max(c[i], self._lo[i]), self._hi[i]) for i in range(3)]
        if k == c:
            return p
        return tuple(o[j] + R[3 * j] * k[0] + R[3 * j + 1] * k[1] + R[3 * j + 2] * k[2]
                     for j in range(3))  # type: ignore[return-value]  # fmt: skip

    def target(self, p: Vec3) -> FloatArray:
        """X_ext (6,) for the tip at p (clamped into the box) and the RCM at the trocar."""
        x, y, z = self.clamp(p)
        cx, cy, cz = self.trocar
        ux, uy, uz = x - cx, y - cy, z - cz
        phi = math.atan2(uz, -ux)
        psi = math.atan2(-uy, math.hypot(ux, uz))
        return np.array([x, phi, psi, cx, cy, cz])
