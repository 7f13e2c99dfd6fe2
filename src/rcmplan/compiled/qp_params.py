"""The QP controller's settings as the compiled kernels read them: one float64 vector Q.

No numba here (the runner checks whether the compiled QP applies without loading it); the
kernels (`qp_kernels`) read the indices below as compile-time constants.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.control.eye_model import EyeModel
from rcmplan.control.limits.workspace import WorkspaceBound
from rcmplan.robot.model import RobotModel

if TYPE_CHECKING:
    from rcmplan.control.qp import QpSolver

# Indices of Q: `QpLimits` fields in SI units, the solver's dt [s] and damping, the eye
# (HAS_EYE 1 or 0, retina radius [m], centre (3,) and trocar point (3,) [m]), slider speeds (6,).
RCM_TOL, TRAVEL_MARGIN, RETINA_MARGIN, EYE_GAIN, PORT_ZONE, CONTACT_TOL = range(6)
SINGULAR_FLOOR, SINGULAR_GAIN, ANGLE_WEIGHT, RCM_WEIGHT, DT, DAMPING = range(6, 12)
HAS_EYE, RETINA_RADIUS, CENTER, PORT, SPEED = 12, 13, 14, 17, 20
# A workspace box (`limits.workspace.WorkspaceBound`, the one extra limit the kernels hold):
# HAS_BOX 1 or 0, origin (3,), rotation R (3, 3) row by row, lower (3,), upper (3,), gain.
HAS_BOX, BOX_ORIGIN, BOX_R, BOX_LOWER, BOX_UPPER, BOX_GAIN = 26, 27, 30, 39, 42, 45
Q_SIZE = 46

_PROBES = np.array([[0.0, 0.0, 0.0], [3e-3, -2e-3, 7e-3], [-0.02, 0.01, 0.03]])


def spherical_eye(eye: EyeModel) -> bool:
    """True if the eye's retina distance is the sphere's, retina_radius - |p - center| (the
    kernels' formula), at probe points around its centre (1e-15 m)."""
    c, r = np.asarray(eye.center, dtype=float), float(eye.retina_radius)
    for p in c + _PROBES:
        if abs(eye.distance_to_retina(p) - (r - float(np.linalg.norm(p - c)))) > 1e-15:
            return False
    return True


def qp_params(robot: RobotModel, solver: QpSolver) -> tuple[FloatArray, FloatArray] | None:
    """(Q, contacts (k, 3) [m]) of a QP solver driving `robot`; None if its eye is not one the
    kernels reproduce (`spherical_eye`), it bounds the tip's speed, or it holds extra limits
    other than one workspace box (no compiled rows)."""
    lim, eye = solver.limits, solver.eye
    extra = solver.extra_limits
    if lim.tip_speed is not None or len(extra) > 1:
        return None
    box = extra[0] if extra else None
    if box is not None and not (isinstance(box, WorkspaceBound) and type(box) is WorkspaceBound):
        return None
    Q = np.zeros(Q_SIZE)
    if box is not None:
        Q[HAS_BOX], Q[BOX_GAIN] = 1.0, box.gain
        Q[BOX_ORIGIN : BOX_ORIGIN + 3] = box.origin
        Q[BOX_R : BOX_R + 9] = np.asarray(box.rotation, dtype=float).ravel()
        Q[BOX_LOWER : BOX_LOWER + 3], Q[BOX_UPPER : BOX_UPPER + 3] = box.lower, box.upper
    Q[RCM_TOL], Q[TRAVEL_MARGIN], Q[RETINA_MARGIN] = (
        lim.rcm_tolerance, lim.travel_margin, lim.retina_margin
    )  # fmt: skip
    Q[EYE_GAIN], Q[PORT_ZONE], Q[CONTACT_TOL] = lim.eye_gain, lim.port_zone, lim.contact_tolerance
    Q[SINGULAR_FLOOR], Q[SINGULAR_GAIN] = lim.singular_floor(robot), lim.singular_gain
    Q[ANGLE_WEIGHT], Q[RCM_WEIGHT] = lim.angle_weight, lim.rcm_weight
    Q[DT], Q[DAMPING] = solver.dt, solver.damping
    Q[SPEED : SPEED + 6] = robot.speed
    if eye is not None:
        if not spherical_eye(eye):
            return None
        Q[HAS_EYE], Q[RETINA_RADIUS] = 1.0, eye.retina_radius
        Q[CENTER : CENTER + 3], Q[PORT : PORT + 3] = eye.center, eye.port
    contacts = np.array(lim.contacts, dtype=np.float64).reshape(-1, 3)
    return Q, contacts
