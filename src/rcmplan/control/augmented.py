"""The extended task X_ext = (x, phi, psi, x_rcm, y_rcm, z_rcm) and its augmented Jacobian J_a.

Eqs. 3.14 and 3.15, as the stacking of the tasks `x_ext_tasks` over theta_ext = (q[active],
lambda). Two variants of J_a:

- "exact": rows 2 and 3 are the exact derivatives of the needle angles phi and psi defined in
  `rcmplan.robot.needle`; on iRAM!S det J_a = l6 cos^2(q1) cos^2(q3).
- "thesis": the thesis's eq. 6.1, whose rows 2 and 3 are the geometric angular velocities
  omega_y and omega_z (on iRAM!S dq1 and cos(q1) dq3, a cos q1-scaled approximation of d psi,
  NOTES.md); det J_a = l6 cos^3(q1) cos^2(q3). Kept for reproduction.

On iRAM!S both are singular exactly when cos q1 = 0 or cos q3 = 0 (eq. 3.16 of the thesis is
wrong). J_a is square for a robot with five active joints, (6, m + 1) for m active joints.
"""

from __future__ import annotations

from rcmplan._validate import FloatArray
from rcmplan.control.tasks import JacobianVariant, stack_jacobian, stack_value, x_ext_tasks
from rcmplan.robot.model import RobotModel


def extended_task(robot: RobotModel, q: FloatArray, lam: float) -> FloatArray:
    """X_ext = (x_tip [m], phi [rad], psi [rad], p_rcm [m]) at (q, lambda), a (6,) array."""
    return stack_value(x_ext_tasks(), robot, q, lam)


def augmented_jacobian(
    robot: RobotModel, q: FloatArray, lam: float, variant: JacobianVariant = "exact"
) -> FloatArray:
    """J_a = d X_ext / d(q[active], lambda), (6, m + 1) (eq. 3.15; eq. 6.1 for "thesis")."""
    return stack_jacobian(x_ext_tasks(variant), robot, q, lam)
