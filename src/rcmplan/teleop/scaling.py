"""Motion scaling: the master's displacement, divided by the scale, in the robot's base frame."""

from __future__ import annotations

import numpy as np

from rcmplan._validate import FloatArray, matrix, scalar
from rcmplan.exceptions import InvalidInputError

Vec3 = tuple[float, float, float]
SCALE_RANGE = (1.0, 50.0)


class MotionScaling:
    """d_base = R d_master / scale.

    Args:
        scale: Master motion per unit of tip motion, in [1, 50] (a teleoperated ophthalmic
            system found 20-30 best; 1: no scaling).
        rotation: (3, 3) rotation whose columns are the master frame's axes in the base frame
            (the eye frame: `rcmplan.scene.eye.eye_frame`).
    """

    def __init__(self, scale: float, rotation: FloatArray) -> None:
        self.scale = scalar("scale", scale, *SCALE_RANGE)
        R = matrix("rotation", rotation, (3, 3))
        if not np.allclose(R.T @ R, np.eye(3), atol=1e-9) or np.linalg.det(R) < 0.0:
            raise InvalidInputError("rotation", R, "a proper rotation (R^T R = I, det 1)")
        self.rotation = R
        self._m = [float(v) / self.scale for v in R.ravel()]

    def apply(self, d: Vec3) -> Vec3:
        """The tip displacement [m] in the base frame for a master displacement d [m]."""
        m = self._m
        x, y, z = d
        return (m[0] * x + m[1] * y + m[2] * z, m[3] * x + m[4] * y + m[5] * z,
                m[6] * x + m[7] * y + m[8] * z)  # fmt: skip

    def to_master(self, d_base: FloatArray) -> FloatArray:
        """The master displacement (N, 3) [m] that gives tip displacements d_base (N, 3)."""
        return np.asarray(np.atleast_2d(d_base) @ self.rotation * self.scale)
