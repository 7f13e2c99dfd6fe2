"""The extended task X_ext = (x, phi, psi, x_rcm, y_rcm, z_rcm) and its augmented Jacobian J_a.

Eqs. 3.14 and 3.15. Two variants of J_a:

- "exact": rows 2 and 3 are the exact derivatives of the needle angles phi and psi defined in
  `rcmplan.control.tasks`; det J_a = l6 cos^2(q1) cos^2(q3).
- "thesis": the thesis's eq. 6.1, whose rows 2 and 3 are the geometric angular velocities
  omega_y = dq1 and omega_z = cos(q1) dq3 (a cos q1-scaled approximation of d psi, NOTES.md);
  det J_a = l6 cos^3(q1) cos^2(q3). Kept for reproduction.

Both are singular exactly when cos q1 = 0 or cos q3 = 0 (eq. 3.16 of the thesis is wrong).
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.control.tasks import (
    needle_angles,
    needle_angles_jacobian,
    needle_angles_jacobian_thesis,
    rcm_jacobian,
    rcm_point,
    tip_position_jacobian,
)
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.iramis import Iramis

JacobianVariant = Literal["exact", "thesis"]
VARIANTS: tuple[str, ...] = ("exact", "thesis")


def extended_task(robot: Iramis, q: FloatArray, lam: float) -> FloatArray:
    """X_ext = (x_tip [m], phi [rad], psi [rad], p_rcm [m]) at (q, lambda), a (6,) array."""
    phi, psi = needle_angles(robot, q)
    out = np.empty(6)
    out[0] = robot.needle_point(q, 1.0)[0]
    out[1] = phi
    out[2] = psi
    out[3:] = rcm_point(robot, q, lam)
    return out


def augmented_jacobian(
    robot: Iramis, q: FloatArray, lam: float, variant: JacobianVariant = "exact"
) -> FloatArray:
    """J_a = d X_ext / d(q0..q4, lambda), a (6, 6) array (eq. 3.15; eq. 6.1 for "thesis")."""
    J = np.empty((6, 6))
    J[0] = tip_position_jacobian(robot, q)[0]
    if variant == "exact":
        J[1:3] = needle_angles_jacobian()
    elif variant == "thesis":
        J[1:3] = needle_angles_jacobian_thesis(q)
    else:
        raise InvalidInputError("jacobian variant", variant, f"one of {VARIANTS}")
    J[3:] = rcm_jacobian(robot, q, lam)
    return J
