"""Assumed masses and inertias of the moving bodies of the iRAM!S MuJoCo model.

The thesis gives no masses. The values below are assumptions for a small piezo-driven robot
(tens of grams per stage), each body treated as a solid box about its centre of mass:
I_xx = m (b^2 + c^2) / 12 for edge lengths (a, b, c). They matter only for dynamics; with
gravity compensation on, static sag does not depend on them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rcmplan._validate import FloatArray

MM = 1e-3


@dataclass(frozen=True)
class BodyInertia:
    """Assumed mass and box size of one body (assumed values).

    Attributes:
        mass: Mass in [kg].
        box: Edge lengths (a, b, c) in [m] of the box the inertia is computed for.
    """

    mass: float
    box: tuple[float, float, float]

    def diaginertia(self) -> FloatArray:
        """Principal inertia (I_xx, I_yy, I_zz) in [kg m^2] of the solid box."""
        a, b, c = self.box
        return self.mass / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])


# Body kind -> assumed inertia. Every value here is assumed (no source gives them).
ASSUMED_INERTIA: dict[str, BodyInertia] = {
    "slider": BodyInertia(0.015, (8 * MM, 6 * MM, 12 * MM)),  # piezo stage carriage
    "guide": BodyInertia(0.005, (6 * MM, 6 * MM, 6 * MM)),  # centre guide of a PCJM stage
    "stage1": BodyInertia(0.040, (42 * MM, 10 * MM, 10 * MM)),  # PCJM 1 coupler stage
    "stage2": BodyInertia(0.030, (42 * MM, 8 * MM, 8 * MM)),  # PCJM 2 coupler stage
    "follower": BodyInertia(0.001, (3 * MM, 3 * MM, 3 * MM)),  # pin riding in the slot
    "holder": BodyInertia(0.020, (12 * MM, 12 * MM, 20 * MM)),  # insertion (L5) stage
    "needle": BodyInertia(0.005, (6 * MM, 6 * MM, 20 * MM)),  # needle hub and roll rotor
}
