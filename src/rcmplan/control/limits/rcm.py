"""The RCM: the needle line through the trocar, as an equality or a box (eq. 3.10)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rcmplan._jit import njit
from rcmplan._validate import FloatArray, scalar
from rcmplan.control.limits.base import Constraint, Kinematics, StepInput
from rcmplan.control.limits.rows import SCALE
from rcmplan.robot.chain_singular import needle_normals
from rcmplan.robot.model import RobotModel


@njit(cache=True, borrows=True)
def normal_basis(axis: FloatArray, N: FloatArray) -> None:
    """Two unit vectors N (2, 3) normal to a unit axis (3,) and to each other
    (`chain_singular.needle_normals`: n1 = axis x e_k normalised, e_k the first axis of smallest
    |axis_k|, and n2 = axis x n1)."""
    n1, n2, _, _ = needle_normals(axis[0], axis[1], axis[2])
    for i in range(3):
        N[0, i], N[1, i] = n1[i], n2[i]


@njit(cache=True, borrows=True)
def rcm_rows(JT_rcm: FloatArray, rcm: FloatArray, trocar: FloatArray, axis: FloatArray,
             tol: float, N: FloatArray, G: FloatArray, h: FloatArray, r: int) -> int:  # fmt: skip
    """The RCM's rows from row r: normal to the needle, N JT_rcm x = -N (p(lambda) - trocar) /
    SCALE as two equality rows when tol is 0, else the box |N (p + JT_rcm x SCALE - trocar)|
    <= tol / sqrt(2) per normal axis (four rows: +, then -). N (2, 3) is scratch. Returns the
    next row."""
    normal_basis(axis, N)
    box = tol / math.sqrt(2.0)
    for a in range(2):
        dev = 0.0
        for i in range(3):
            dev += N[a, i] * (rcm[i] - trocar[i])
        for j in range(JT_rcm.shape[1]):
            acc = N[a, 0] * JT_rcm[0, j] + N[a, 1] * JT_rcm[1, j] + N[a, 2] * JT_rcm[2, j]
            G[r + a, j] = acc
            if tol > 0.0:
                G[r + 2 + a, j] = -acc
        if tol == 0.0:
            h[r + a] = -dev / SCALE
        else:
            h[r + a] = (box - dev) / SCALE
            h[r + 2 + a] = (box + dev) / SCALE
    return r + (4 if tol > 0.0 else 2)


@dataclass(frozen=True)
class RcmLimit:
    """Normal to the needle (the along-needle part is lambda's bookkeeping): N J_c T x =
    -N r / SCALE with r = p(lambda) - trocar, the trocar the target's RCM point (its last three
    entries), as an equality (`tolerance` 0) or a box of half-width tolerance / sqrt(2) per
    normal axis, so the deviation stays within the tolerance to first order (`rcm_rows`).

    Attributes:
        tolerance: Largest distance in [m] from the trocar to the needle line, in [0, 5 mm].
    """

    tolerance: float = 0.5e-6

    def __post_init__(self) -> None:
        object.__setattr__(self, "tolerance", scalar("tolerance", self.tolerance, 0.0, 5e-3))

    def constraint(self, robot: RobotModel, inp: StepInput, kin: Kinematics) -> Constraint:
        """The two rows (equality) or four (box)."""
        tol = self.tolerance
        G, h = np.empty((4, kin.T.shape[1])), np.empty(4)
        trocar = np.ascontiguousarray(inp.target[-3:])
        r = rcm_rows(kin.JT_rcm, kin.rcm, trocar, kin.axis, tol, np.empty((2, 3)), G, h, 0)
        return Constraint.rows(G[:r], h[:r], equality=tol == 0.0)
