"""The retina margin: a velocity damper keeping the tip off the retina, except at a contact."""

from __future__ import annotations

import numpy as np
from numba import njit

from rcmplan._validate import FloatArray
from rcmplan.control.eye_model import EyeModel
from rcmplan.control.limits.base import Constraint, Kinematics, StepInput, no_rows
from rcmplan.control.limits.rows import RECOVERY, near_any, sphere_row
from rcmplan.control.qp_limits import QpLimits
from rcmplan.control.targets import target_tip
from rcmplan.robot.model import RobotModel


@njit(cache=True)
def contact_floor(margin: float, target_depth: float, tip_target: FloatArray,
                  contacts: FloatArray, tol: float) -> float:  # fmt: skip
    """The retina floor of a step [m]: `margin`, or at a contact target (its tip within `tol`
    of the retina, depth `target_depth`, or of a row of `contacts` (k, 3)) the target's own
    depth when shallower (never below 0)."""
    if abs(target_depth) <= tol or near_any(tip_target, contacts, tol):
        return min(margin, max(target_depth, 0.0))
    return margin


def is_contact(eye: EyeModel, lim: QpLimits, tip_target: FloatArray) -> bool:
    """True if the target tip lies on the retina or on a listed contact point."""
    if abs(eye.distance_to_retina(tip_target)) <= lim.contact_tolerance:
        return True
    return near_any(tip_target, contact_points(lim), lim.contact_tolerance)


def contact_points(lim: QpLimits) -> FloatArray:
    """The listed contact points as a (k, 3) array [m]."""
    return np.array(lim.contacts, dtype=np.float64).reshape(-1, 3)


def retina_recovery(lim: QpLimits, dt: float) -> float:
    """How far past its floor the tip may move back per step [m]: RECOVERY, or with a tip speed
    bound as far as the damper's gain lets it (eye_gain x tip_speed x dt)."""
    if lim.tip_speed is None:
        return RECOVERY
    return max(RECOVERY, lim.eye_gain * lim.tip_speed * dt)


class RetinaBarrier:
    """distance_to_retina(tip) kept above `retina_margin` (at a contact target: above the
    target's own depth), approached at `eye_gain`; off with no eye, and while the tip is within
    `port_zone` of the trocar (it passes the wall there, at the pars plana). Past its floor
    (leaving a contact for a target inside the margin) the tip recovers by up to
    `retina_recovery` per step (`rows.sphere_row`, `contact_floor`)."""

    def constraint(self, robot: RobotModel, inp: StepInput, kin: Kinematics) -> Constraint:
        """One damper row, or none."""
        eye, lim = inp.eye, inp.limits
        if eye is None or np.linalg.norm(kin.tip - eye.port) <= lim.port_zone:
            return no_rows(kin)
        tip_target = target_tip(inp.target)
        floor = contact_floor(lim.retina_margin, eye.distance_to_retina(tip_target), tip_target,
                              contact_points(lim), lim.contact_tolerance)  # fmt: skip
        G, h = np.empty((1, kin.T.shape[1])), np.empty(1)
        center = np.asarray(eye.center, dtype=np.float64)
        sphere_row(kin.JT_tip, kin.tip, center, eye.distance_to_retina(kin.tip), floor,
                   lim.eye_gain, retina_recovery(lim, inp.dt), G, h, 0)  # fmt: skip
        return Constraint.rows(G, h)
