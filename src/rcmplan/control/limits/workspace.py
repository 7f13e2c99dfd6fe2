"""The workspace bound: the needle tip kept inside a box, each face a velocity damper."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from rcmplan._jit import njit
from rcmplan._validate import FloatArray, array, matrix, scalar, vector
from rcmplan.control.limits.base import Constraint, Kinematics, StepInput
from rcmplan.control.limits.rows import RECOVERY, damper_bound
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.model import RobotModel

# The box as the compiled QP reads it (`pack`): origin (3,), R (3, 3) row by row, lower (3,),
# upper (3,), gain.
PACKED = 19


@njit(cache=True, borrows=True)
def box_rows(JT_tip: FloatArray, tip: FloatArray, box: FloatArray, G: FloatArray, h: FloatArray,
             r: int) -> int:  # fmt: skip
    """Six damper rows from row r keeping the tip's box coordinates c = R^T (tip - origin)
    within [lower, upper] (the box packed as `PACKED`): per axis i the lower face (gradient
    d c_i / d(x SCALE)), then the upper (minus it). Returns r + 6."""
    for i in range(3):
        c = 0.0
        for m in range(3):
            c += box[3 + 3 * m + i] * (tip[m] - box[m])
        for j in range(JT_tip.shape[1]):
            acc = 0.0
            for m in range(3):
                acc += box[3 + 3 * m + i] * JT_tip[m, j]
            G[r, j] = -acc
            G[r + 1, j] = acc
        gain = box[18]
        h[r] = damper_bound(c - box[12 + i], 0.0, gain, RECOVERY)
        h[r + 1] = damper_bound(box[15 + i] - c, 0.0, gain, RECOVERY)
        r += 2
    return r


@dataclass(frozen=True)
class WorkspaceBound:
    """lower <= R^T (tip - origin) <= upper, componentwise: a box with axes R (columns, in the
    base frame) about `origin`, all in [m]. Each face is a velocity damper at `gain` (the gap
    to a face shrinks at most by this fraction per step; past a face the tip may not go
    further and comes back by up to `limits.base.RECOVERY` per step).

    Attributes:
        origin: Box origin (3,) in the base frame [m].
        rotation: (3, 3) rotation whose columns are the box axes in the base frame.
        lower, upper: Box faces (3,) along those axes [m]; lower < upper.
        gain: Damper gain in (0, 1].
    """

    origin: tuple[float, float, float]
    rotation: tuple[tuple[float, ...], ...]
    lower: tuple[float, float, float]
    upper: tuple[float, float, float]
    gain: float = 0.5

    def __post_init__(self) -> None:
        R = matrix("workspace.rotation", self.rotation, (3, 3))
        bounded = np.abs(R).max() <= 1.0 + 1e-9  # a rotation's entries lie in [-1, 1]
        if not bounded or not np.allclose(R.T @ R, np.eye(3), atol=1e-9) or np.linalg.det(R) < 0:
            raise InvalidInputError("workspace.rotation", R, "a proper rotation (R^T R = I)")
        lo = vector("workspace.lower", self.lower, 3)
        hi = vector("workspace.upper", self.upper, 3)
        if np.any(hi <= lo):
            raise InvalidInputError("workspace box", (lo, hi), "lower < upper on every axis")
        object.__setattr__(
            self, "gain", scalar("workspace.gain", self.gain, 0.0, 1.0, low_open=True)
        )
        object.__setattr__(self, "origin", tuple(vector("workspace.origin", self.origin, 3)))
        object.__setattr__(self, "rotation", tuple(tuple(r) for r in R))
        object.__setattr__(self, "lower", tuple(lo))
        object.__setattr__(self, "upper", tuple(hi))

    @classmethod
    def cube(cls, center: FloatArray, half_width: float, gain: float = 0.5) -> WorkspaceBound:
        """The axis-aligned cube of `half_width` [m] (in (0, 1 m]) about `center` (3,) [m] of
        the base frame."""
        half = scalar("workspace.half_width", half_width, 0.0, 1.0, low_open=True)
        eye3 = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
        return cls(tuple(vector("workspace.center", center, 3)), eye3, (-half,) * 3, (half,) * 3,
                   gain)  # fmt: skip

    def coordinates(self, p: FloatArray) -> FloatArray:
        """Box coordinates R^T (p - origin) of points p (3,) or (N, 3) in [m]."""
        return np.asarray((points("p", p) - np.asarray(self.origin)) @ np.asarray(self.rotation))

    def depth(self, p: FloatArray) -> FloatArray:
        """Signed distance (N,) [m] of points p (N, 3) to the nearest face along the box axes:
        positive inside, negative outside (then minus the largest excess over a face)."""
        c = self.coordinates(np.atleast_2d(points("p", p)))
        gaps = np.minimum(c - np.asarray(self.lower), np.asarray(self.upper) - c)
        return np.asarray(gaps.min(axis=1))

    def outside(self, p: FloatArray) -> FloatArray:
        """How far points p (N, 3) lie outside the box in [m] (0 inside), per point (N,)."""
        return np.asarray(np.maximum(-self.depth(p), 0.0))

    @cached_property
    def packed(self) -> FloatArray:
        """The box as `box_rows` reads it (`PACKED` numbers)."""
        return np.concatenate([self.origin, np.asarray(self.rotation).ravel(), self.lower,
                               self.upper, [self.gain]])  # fmt: skip

    def constraint(self, robot: RobotModel, inp: StepInput, kin: Kinematics) -> Constraint:
        """Six damper rows, one per face (`box_rows`)."""
        G, h = np.empty((6, kin.T.shape[1])), np.empty(6)
        box_rows(kin.JT_tip, kin.tip, self.packed, G, h, 0)
        return Constraint.rows(G, h)


def points(name: str, p: object) -> FloatArray:
    """p as finite points (3,) or (N, 3) in [m], or InvalidInputError naming it."""
    value = array(name, p, (1, 2))
    if value.shape[-1] != 3:
        raise InvalidInputError(name, p, f"points (3,) or (N, 3), got shape {value.shape}")
    return value
