"""A depth limit in tissue: the tip kept shallower than a moving layer (the RPE less a margin)."""

from __future__ import annotations

import numpy as np

from rcmplan._validate import FloatArray, scalar, vector
from rcmplan.control.limits.base import Constraint, Kinematics, StepInput
from rcmplan.control.limits.rows import RECOVERY, radial_gap, sphere_row
from rcmplan.robot.model import RobotModel

# The limit as the compiled QP reads it (`pack`): centre (3,), floor radius, gain, recovery.
PACKED = 6
FLOOR_AT = 3  # the floor radius's place in the packed numbers (a block loop moves it there)


class TissueDepthLimit:
    """|tip - centre| <= `floor_radius_m`: the tip's radial distance from the eye centre (its
    depth along the local normal of a spherical wall) kept at or below a sphere, one velocity-
    damper row at `gain` (1: the step may close the whole gap; `rows.sphere_row`). The sphere
    moves: the caller sets `floor_radius_m` [m] every period from the estimated layer position
    (for a subretinal injection, the estimated RPE radius less a margin). Past the sphere (the
    layer moved towards the tip) the tip must not go deeper and backs out by up to `recovery`
    [m] per step.

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

    def set_center(self, center: FloatArray) -> None:
        """Move the sphere's centre to `center` (3,) [m] (checked): an eye that moves."""
        self.center = vector("center", center, 3)

    def gap_m(self, tip: FloatArray) -> float:
        """floor_radius_m - |tip - centre| [m]: positive while the tip is within the bound."""
        return radial_gap(self.center, self.floor_radius_m, vector("tip", tip, 3))

    def pack(self, out: FloatArray) -> None:
        """Write the limit as the compiled QP reads it (`PACKED` numbers) into out."""
        out[:3] = self.center
        out[FLOOR_AT], out[4], out[5] = self.floor_radius_m, self.gain, self.recovery

    def constraint(self, robot: RobotModel, inp: StepInput, kin: Kinematics) -> Constraint:
        """One damper row on the gap along the outward normal at the tip."""
        G, h = np.empty((1, kin.T.shape[1])), np.empty(1)
        gap = radial_gap(self.center, self.floor_radius_m, kin.tip)
        sphere_row(kin.JT_tip, kin.tip, self.center, gap, 0.0, self.gain, self.recovery, G, h, 0)
        return Constraint.rows(G, h)
