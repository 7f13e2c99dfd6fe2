"""The RCM: the needle line through the trocar, as an equality or a box (eq. 3.10)."""

from __future__ import annotations

import math

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.control.limits.base import SCALE, Constraint, Kinematics, StepInput
from rcmplan.robot.model import RobotModel
from rcmplan.robot.needle import cross3


def normal_basis(axis: FloatArray) -> FloatArray:
    """Two unit vectors (2, 3) normal to a unit axis and to each other."""
    helper = np.zeros(3)
    helper[int(np.argmin(np.abs(axis)))] = 1.0
    n1 = cross3(axis, helper)
    n1 /= math.sqrt(n1 @ n1)
    return np.array([n1, cross3(axis, n1)])


class RcmLimit:
    """Normal to the needle (the along-needle part is lambda's bookkeeping): N J_c T x =
    -N r / SCALE with r = p(lambda) - trocar (equality, `rcm_tolerance` 0), or a box of
    half-width tol / sqrt(2) per normal axis, so the deviation stays within tol to first order."""

    def constraint(self, robot: RobotModel, inp: StepInput, kin: Kinematics) -> Constraint:
        """The two rows (equality) or four (box)."""
        N = normal_basis(kin.axis)
        Jc = N @ kin.J_rcm @ kin.T
        r = N @ (kin.rcm - inp.target[-3:])
        tol = inp.limits.rcm_tolerance
        if tol == 0.0:
            return Constraint.rows(Jc, -r / SCALE, equality=True)
        box = tol / math.sqrt(2.0)
        return Constraint.rows(np.vstack([Jc, -Jc]), np.concatenate([box - r, box + r]) / SCALE)
