"""The QP controller's settings as the compiled kernels read them: one float64 vector Q.

No numba here (the runner checks whether the compiled QP applies without loading it); the
kernels (`qp_rows`, `qp_kernels`, `arm_qp_kernels`) read the indices below as compile-time
constants. The rows themselves are the limits' own kernels (`control/limits/`), which the
Python QP calls too.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.control.eye_model import EyeModel
from rcmplan.control.limits.tissue_depth import PACKED as DEPTH_PACKED
from rcmplan.control.limits.tissue_depth import TissueDepthLimit
from rcmplan.control.limits.workspace import PACKED as BOX_PACKED
from rcmplan.control.limits.workspace import WorkspaceBound
from rcmplan.robot.model import RobotModel

if TYPE_CHECKING:
    from rcmplan.control.qp import QpSolver

# Indices of Q: `QpLimits` fields in SI units, the solver's dt [s] and damping, the retina's
# recovery per step [m], the tip's step bound tip_speed x dt [m] (0: none), the eye (HAS_EYE 1
# or 0, retina radius [m], centre (3,) and trocar point (3,) [m]), the cost's row weights (6, or
# 7 for a curved needle's X_c; a straight needle's seventh is unused).
RCM_TOL, TRAVEL_MARGIN, RETINA_MARGIN, EYE_GAIN, PORT_ZONE, CONTACT_TOL = range(6)
SINGULAR_FLOOR, SINGULAR_GAIN, DT, DAMPING, RETINA_RECOVERY, TIP_STEP = range(6, 12)
HAS_EYE, RETINA_RADIUS, CENTER, PORT, WEIGHTS = 12, 13, 14, 17, 20
# Extra limits the kernels hold, in the solver's order: N_EXTRA, then per limit a slot of
# EXTRA_SLOT numbers, its kind (one of EXTRA_KINDS) and its packed parameters.
N_EXTRA, EXTRA = 27, 28
BOX, DEPTH = 1.0, 2.0
EXTRA_KINDS: dict[type, tuple[float, int]] = {WorkspaceBound: (BOX, BOX_PACKED),
                                              TissueDepthLimit: (DEPTH, DEPTH_PACKED)}  # fmt: skip
EXTRA_SLOT = 1 + max(n for _, n in EXTRA_KINDS.values())
MAX_EXTRA = 2
# Last, the speeds of the robot's active actuators (m,) in [m/s] or [rad/s], in the order of
# `RobotModel.active`: Q holds Q_SIZE + m numbers.
SPEED = Q_SIZE = EXTRA + MAX_EXTRA * EXTRA_SLOT

_PROBES = np.array([[0.0, 0.0, 0.0], [3e-3, -2e-3, 7e-3], [-0.02, 0.01, 0.03]])


def spherical_eye(eye: EyeModel) -> bool:
    """True if the eye's retina distance is the sphere's, retina_radius - |p - center| (the
    kernels' formula), at probe points around its centre (1e-15 m)."""
    c, r = np.asarray(eye.center, dtype=float), float(eye.retina_radius)
    for p in c + _PROBES:
        if abs(eye.distance_to_retina(p) - (r - float(np.linalg.norm(p - c)))) > 1e-15:
            return False
    return True


def compiled_extras(solver: QpSolver) -> bool:
    """True if the kernels hold each of the solver's extra limits (at most MAX_EXTRA, each
    exactly one of the EXTRA_KINDS classes)."""
    extra = solver.extra_limits
    return len(extra) <= MAX_EXTRA and all(type(lim) in EXTRA_KINDS for lim in extra)


def pack_extras(solver: QpSolver, Q: FloatArray) -> None:
    """Write the solver's extra limits into Q as they are now (a moving limit's current
    parameters: call before each step)."""
    Q[N_EXTRA] = len(solver.extra_limits)
    for i, lim in enumerate(solver.extra_limits):
        kind, n = EXTRA_KINDS[type(lim)]
        slot = EXTRA + i * EXTRA_SLOT
        Q[slot] = kind
        if isinstance(lim, WorkspaceBound):
            Q[slot + 1 : slot + 1 + n] = lim.packed
        elif isinstance(lim, TissueDepthLimit):
            lim.pack(Q[slot + 1 : slot + 1 + n])


def qp_params(robot: RobotModel, solver: QpSolver) -> tuple[FloatArray, FloatArray] | None:
    """(Q, contacts (k, 3) [m]) of a QP solver driving `robot`; None if its eye is not one the
    kernels reproduce (`spherical_eye`), it holds extra limits the kernels do not
    (`compiled_extras`) or extra cost terms."""
    lim, eye = solver.limits, solver.eye
    if not compiled_extras(solver) or (eye is not None and not spherical_eye(eye)):
        return None
    if solver.objectives:  # cost terms the kernels do not assemble
        return None
    active = list(robot.active)
    Q = np.zeros(Q_SIZE + len(active))
    pack_extras(solver, Q)
    Q[RCM_TOL], Q[TRAVEL_MARGIN], Q[RETINA_MARGIN] = (
        lim.rcm_tolerance, lim.travel_margin, lim.retina_margin
    )  # fmt: skip
    Q[EYE_GAIN], Q[PORT_ZONE], Q[CONTACT_TOL] = lim.eye_gain, lim.port_zone, lim.contact_tolerance
    Q[SINGULAR_FLOOR], Q[SINGULAR_GAIN] = lim.singular_floor(robot), lim.singular_gain
    Q[DT], Q[DAMPING] = solver.dt, solver.damping
    Q[RETINA_RECOVERY] = lim.retina_recovery(solver.dt)
    Q[TIP_STEP] = 0.0 if lim.tip_speed is None else lim.tip_speed * solver.dt
    Q[SPEED:] = robot.speed[active]
    Q[WEIGHTS : WEIGHTS + len(solver.weights)] = solver.weights
    if eye is not None:
        Q[HAS_EYE], Q[RETINA_RADIUS] = 1.0, eye.retina_radius
        Q[CENTER : CENTER + 3], Q[PORT : PORT + 3] = eye.center, eye.port
    return Q, np.array(lim.contacts, dtype=np.float64).reshape(-1, 3)
