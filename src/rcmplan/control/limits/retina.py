"""The retina margin: a velocity damper keeping the tip off the retina, except at a contact."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from rcmplan._jit import njit
from rcmplan._validate import FloatArray, scalar
from rcmplan.control.eye_model import EyeModel, check_eye
from rcmplan.control.limits.base import Constraint, Kinematics, StepInput, no_rows
from rcmplan.control.limits.rows import RECOVERY, near_any, sphere_row
from rcmplan.control.targets import target_tip
from rcmplan.robot.model import RobotModel

MAX_MARGIN = 0.02  # [m] the largest retina margin


@njit(cache=True, borrows=True)
def on_contact(target_depth: float, tip_target: FloatArray, contacts: FloatArray,
               tol: float) -> bool:  # fmt: skip
    """True if a target's tip lies within `tol` of the retina (its depth `target_depth`) or of
    a row of `contacts` (k, 3)."""
    return abs(target_depth) <= tol or near_any(tip_target, contacts, tol)


@njit(cache=True, borrows=True)
def contact_floor(margin: float, target_depth: float, tip_target: FloatArray,
                  contacts: FloatArray, tol: float) -> float:  # fmt: skip
    """The retina floor of a step [m]: `margin`, or at a contact target (`on_contact`) the
    target's own depth when shallower (never below 0)."""
    if on_contact(target_depth, tip_target, contacts, tol):
        return min(margin, max(target_depth, 0.0))
    return margin


@dataclass(frozen=True, eq=False)
class RetinaBarrier:
    """distance_to_retina(tip) kept above `margin` (at a contact target: above the target's own
    depth), approached at `gain`; off while the tip is within `port_zone` of the trocar (it
    passes the wall there, at the pars plana). Past its floor (leaving a contact for a target
    inside the margin) the tip recovers by up to `recovery` per step (`rows.sphere_row`,
    `contact_floor`).

    Attributes:
        eye: The eye (an `EyeModel`).
        margin: Distance kept from the retina in [m], in [0, MAX_MARGIN].
        gain: Damper gain in (0, 1].
        port_zone: Radius around the trocar point in [m] inside which the barrier is off.
        contact_tolerance: A target tip within this distance [m] of the retina (or of a point
            in `contacts`) is a contact: the floor is relaxed to the target's own depth.
        contacts: Extra contact points, a (k, 3) array in [m].
        recovery: Largest push back per step past the floor in [m].
    """

    eye: EyeModel
    margin: float = 0.25e-3
    gain: float = 0.5
    port_zone: float = 2e-3
    contact_tolerance: float = 1e-6
    contacts: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))
    recovery: float = RECOVERY

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "eye", check_eye("eye", self.eye))
        set_(self, "margin", scalar("margin", self.margin, 0.0, MAX_MARGIN))
        set_(self, "gain", scalar("gain", self.gain, 0.0, 1.0, low_open=True))
        set_(self, "port_zone", scalar("port_zone", self.port_zone, 0.0, 0.02))
        tol = scalar("contact_tolerance", self.contact_tolerance, 0.0, 1e-3)
        set_(self, "contact_tolerance", tol)
        set_(self, "contacts", np.array(self.contacts, dtype=np.float64).reshape(-1, 3))
        set_(self, "recovery", scalar("recovery", self.recovery, 0.0, 1e-3, low_open=True))

    def is_contact(self, tip_target: FloatArray) -> bool:
        """True if the target tip lies on the retina or on a listed contact point."""
        depth = self.eye.distance_to_retina(tip_target)
        return on_contact(depth, tip_target, self.contacts, self.contact_tolerance)

    def floor(self, tip: FloatArray, tip_target: FloatArray) -> float:
        """The retina gap [m] kept by a step from a tip at `tip` towards `tip_target`: the
        margin, or at a contact target its own depth when shallower (`contact_floor`); NaN
        while the tip is within `port_zone` of the trocar (the barrier is off)."""
        eye = self.eye
        if np.linalg.norm(tip - eye.port) <= self.port_zone:
            return math.nan
        return contact_floor(self.margin, eye.distance_to_retina(tip_target), tip_target,
                             self.contacts, self.contact_tolerance)  # fmt: skip

    def constraint(self, robot: RobotModel, inp: StepInput, kin: Kinematics) -> Constraint:
        """One damper row, or none."""
        floor = self.floor(kin.tip, target_tip(inp.target))
        if math.isnan(floor):
            return no_rows(kin)
        G, h = np.empty((1, kin.T.shape[1])), np.empty(1)
        eye = self.eye
        center = np.asarray(eye.center, dtype=np.float64)
        sphere_row(kin.JT_tip, kin.tip, center, eye.distance_to_retina(kin.tip), floor,
                   self.gain, self.recovery, G, h, 0)  # fmt: skip
        return Constraint.rows(G, h)
