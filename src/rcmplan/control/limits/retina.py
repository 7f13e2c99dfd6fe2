"""The retina margin: a velocity damper keeping the tip off the retina, except at a contact."""

from __future__ import annotations

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.control.eye_model import EyeModel
from rcmplan.control.limits.base import (
    RECOVERY,
    Constraint,
    Kinematics,
    StepInput,
    damper_row,
    no_rows,
)
from rcmplan.control.qp_limits import QpLimits
from rcmplan.control.targets import target_tip
from rcmplan.robot.model import RobotModel


def is_contact(eye: EyeModel, lim: QpLimits, tip_target: FloatArray) -> bool:
    """True if the target tip lies on the retina or on a listed contact point."""
    if abs(eye.distance_to_retina(tip_target)) <= lim.contact_tolerance:
        return True
    return any(np.linalg.norm(tip_target - c) <= lim.contact_tolerance for c in lim.contacts)


class RetinaBarrier:
    """distance_to_retina(tip) kept above `retina_margin` (at a contact target: above the
    target's own depth), approached at `eye_gain`; off with no eye, and while the tip is within
    `port_zone` of the trocar (it passes the wall there, at the pars plana). Past its floor
    (leaving a contact for a target inside the margin) the tip recovers by up to RECOVERY per
    step, or eye_gain x tip_speed x dt with a tip speed bound."""

    def constraint(self, robot: RobotModel, inp: StepInput, kin: Kinematics) -> Constraint:
        """One damper row, or none."""
        eye, lim = inp.eye, inp.limits
        if eye is None or np.linalg.norm(kin.tip - eye.port) <= lim.port_zone:
            return no_rows(kin)
        tip_target = target_tip(inp.target)
        u = (kin.tip - eye.center) / np.linalg.norm(kin.tip - eye.center)
        grad = -(u @ kin.J_tip) @ kin.T
        floor = lim.retina_margin
        if is_contact(eye, lim, tip_target):
            floor = min(floor, max(eye.distance_to_retina(tip_target), 0.0))
        recovery = RECOVERY
        if lim.tip_speed is not None:  # the tip may move back as fast as the damper's gain lets
            recovery = max(RECOVERY, lim.eye_gain * lim.tip_speed * inp.dt)
        g, h = damper_row(grad, eye.distance_to_retina(kin.tip), floor, lim.eye_gain, recovery)
        return Constraint.rows(g[None, :], np.array([h]))
