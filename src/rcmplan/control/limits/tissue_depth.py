"""A depth limit in tissue: the tip kept shallower than a moving layer (the RPE less a margin)."""

from __future__ import annotations

import numpy as np

from rcmplan._validate import FloatArray, scalar, vector
from rcmplan.control.limits.base import RECOVERY, Constraint, Kinematics, StepInput, damper_row
from rcmplan.robot.model import RobotModel


class TissueDepthLimit:
    """|tip - centre| <= `floor_radius_m`: the tip's radial distance from the eye centre (its
    depth along the local normal of a spherical wall) kept at or below a sphere, one velocity-
    damper row at `gain` (1: the step may close the whole gap). The sphere moves: the caller
    sets `floor_radius_m` [m] every period from the estimated layer position (for a subretinal
    injection, the estimated RPE radius less a margin). Past the sphere (the layer moved towards
    the tip) the tip must not go deeper and backs out by up to `recovery` [m] per step.

    Args:
        center: Eye centre (3,) in the base frame [m].
        floor_radius_m: Initial radius of the bounding sphere [m].
        gain: Damper gain in (0, 1].
        recovery: Largest push back per step past the bound [m].
    """

    def __init__(
        self,
        center: FloatArray,
        floor_radius_m: float,
        gain: float = 0.5,
        recovery: float = RECOVERY,
    ) -> None:
        self.center = vector("center", center, 3)
        self.floor_radius_m = scalar("floor_radius_m", floor_radius_m, 0.0, 0.05, low_open=True)
        self.gain = scalar("gain", gain, 0.0, 1.0, low_open=True)
        self.recovery = scalar("recovery", recovery, 0.0, 1e-3, low_open=True)

    def set_floor(self, radius_m: float) -> None:
        """Move the bounding sphere to `radius_m` [m] (checked)."""
        self.floor_radius_m = scalar("floor_radius_m", radius_m, 0.0, 0.05, low_open=True)

    def gap_m(self, tip: FloatArray) -> float:
        """floor_radius_m - |tip - centre| [m]: positive while the tip is within the bound."""
        return self.floor_radius_m - float(np.linalg.norm(np.asarray(tip) - self.center))

    def constraint(self, robot: RobotModel, inp: StepInput, kin: Kinematics) -> Constraint:
        """One damper row on the gap along the outward normal at the tip."""
        radial = kin.tip - self.center
        u = radial / np.linalg.norm(radial)
        grad = -(u @ kin.J_tip) @ kin.T  # d gap / d (x SCALE)
        g, h = damper_row(grad, self.gap_m(kin.tip), 0.0, self.gain, self.recovery)
        return Constraint(g[None, :], np.array([h]))
