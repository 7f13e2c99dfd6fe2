"""Constraint settings of the QP controller, checked before any motion.

Scenario files and `MethodSettings.extra` name these options with their unit in the key
(`travel_margin_mm`); `QpLimits.from_extra` converts them to SI.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from rcmplan._validate import FloatArray, scalar, vector
from rcmplan.control.eye_model import EyeModel
from rcmplan.control.limits import (
    ActuatorLimit,
    Limit,
    RcmLimit,
    RetinaBarrier,
    SingularMargin,
    TipSpeed,
)
from rcmplan.control.limits.rows import RECOVERY
from rcmplan.exceptions import InvalidInputError, did_you_mean
from rcmplan.robot.model import RobotModel

# extra key -> (field, factor to SI)
EXTRA_KEYS: dict[str, tuple[str, float]] = {
    "rcm_tolerance_um": ("rcm_tolerance", 1e-6),
    "travel_margin_mm": ("travel_margin", 1e-3),
    "retina_margin_mm": ("retina_margin", 1e-3),
    "eye_gain": ("eye_gain", 1.0),
    "port_zone_mm": ("port_zone", 1e-3),
    "contact_tolerance_um": ("contact_tolerance", 1e-6),
    "singular_margin": ("singular_margin", 1.0),
    "singular_gain": ("singular_gain", 1.0),
    "angle_weight_mm_per_rad": ("angle_weight", 1e-3),
    "rcm_weight": ("rcm_weight", 1.0),
    "tip_speed_mm_s": ("tip_speed", 1e-3),
}


@dataclass(frozen=True)
class QpLimits:
    """What the QP holds at every step, SI units.

    Attributes:
        rcm_tolerance: Largest distance in [m] from the trocar point to the needle line (a
            linearised box of half-width tol/sqrt(2) on the two axes normal to the needle); 0
            makes the RCM a linearised equality. Must be below
            the trocar radius. Default 0.5 um, about 0.1 % of the thesis's 0.45 mm port.
        travel_margin: Distance kept from each slider's hard travel end in [m].
        retina_margin: Distance kept from the retina by the tip in [m], except at a contact.
        eye_gain: Velocity-damper gain in (0, 1]: the gap to a floor shrinks at most by this
            fraction per step.
        port_zone: Radius around the trocar point in [m] inside which the retina field is off
            (the tip passes the wall there, at the pars plana, not over the retina).
        contact_tolerance: A target tip within this distance [m] of the retina (or of a point in
            `contacts`) is a contact: the margin is relaxed to the target's own depth.
        contacts: Extra contact points (each (3,) in [m]) where the margin is relaxed.
        singular_margin: Smallest value of the robot's singular terms kept (iRAM!S: cos q1 and
            cos q3); None: 1.5 times the robot's singular threshold (iRAM!S: 0.15).
        singular_gain: Damper gain in (0, 1] of the singular margin.
        angle_weight: Weight of the needle-angle rows in [m/rad] (1 mrad counts as 10 um).
        rcm_weight: Weight of the RCM rows (dimensionless).
        tip_speed: Largest tip speed in [m/s] along each base axis (None: no bound beyond the
            actuators'). Bounds the step of a fast robot (an arm whose joints turn at rad/s),
            whose RCM deviation per step is second order in the step; the retina recovery then
            runs at up to eye_gain x tip_speed x dt per step.
    """

    rcm_tolerance: float = 0.5e-6
    travel_margin: float = 0.5e-3
    retina_margin: float = 0.25e-3
    eye_gain: float = 0.5
    port_zone: float = 2e-3
    contact_tolerance: float = 1e-6
    contacts: tuple[tuple[float, float, float], ...] = ()
    singular_margin: float | None = None
    singular_gain: float = 0.5
    angle_weight: float = 10e-3
    rcm_weight: float = 1.0
    tip_speed: float | None = None

    def __post_init__(self) -> None:
        scalar("rcm_tolerance", self.rcm_tolerance, 0.0, 5e-3)
        scalar("travel_margin", self.travel_margin, 0.0, 0.1)
        scalar("retina_margin", self.retina_margin, 0.0, 0.02)
        scalar("eye_gain", self.eye_gain, 0.0, 1.0, low_open=True)
        scalar("port_zone", self.port_zone, 0.0, 0.02)
        scalar("contact_tolerance", self.contact_tolerance, 0.0, 1e-3)
        scalar("singular_gain", self.singular_gain, 0.0, 1.0, low_open=True)
        scalar("angle_weight", self.angle_weight, 0.0, 1.0, low_open=True)
        scalar("rcm_weight", self.rcm_weight, 0.0, 1e6, low_open=True)
        if self.tip_speed is not None:
            scalar("tip_speed", self.tip_speed, 0.0, 1.0, low_open=True)
        if self.singular_margin is not None:
            scalar("singular_margin", self.singular_margin, 0.0, 1.0, low_open=True, high_open=True)
        pts = tuple(tuple(vector(f"contacts[{i}]", c, 3)) for i, c in enumerate(self.contacts))
        object.__setattr__(self, "contacts", pts)

    @classmethod
    def from_extra(cls, extra: Mapping[str, Any]) -> QpLimits:
        """Limits from unit-suffixed keys (see EXTRA_KEYS; `contacts_mm`: a list of points)."""
        kwargs: dict[str, Any] = {}
        for key, value in extra.items():
            if key == "contacts_mm":
                kwargs["contacts"] = _contacts(value)
            elif key in EXTRA_KEYS:
                name, factor = EXTRA_KEYS[key]
                kwargs[name] = scalar(key, value) * factor
            else:
                valid = sorted([*EXTRA_KEYS, "contacts_mm", "solver"])
                raise InvalidInputError(
                    "qp option", key, f"one of {valid}{did_you_mean(key, valid)}"
                )
        return cls(**kwargs)

    def singular_floor(self, robot: RobotModel) -> float:
        """The smallest singular term the QP keeps (iRAM!S: min(cos q1, cos q3))."""
        return SingularMargin(self.singular_margin).floor_for(robot)

    def retina_recovery(self, dt: float) -> float:
        """How far past its floor the tip may move back per step [m]: RECOVERY, or with a tip
        speed bound as far as the damper's gain lets it (eye_gain x tip_speed x dt)."""
        if self.tip_speed is None:
            return RECOVERY
        return max(RECOVERY, self.eye_gain * self.tip_speed * dt)

    def rows(self, eye: EyeModel | None, dt: float) -> tuple[Limit, ...]:
        """The limits these settings hold, each with its own parameters, in the QP's row order:
        the RCM, the retina (with an eye), the singular margin, the tip's speed (if set)."""
        rows: list[Limit] = [RcmLimit(self.rcm_tolerance)]
        if eye is not None:
            rows.append(RetinaBarrier(eye, self.retina_margin, self.eye_gain, self.port_zone,
                                      self.contact_tolerance, np.array(self.contacts),
                                      self.retina_recovery(dt)))  # fmt: skip
        rows.append(SingularMargin(self.singular_margin, self.singular_gain))
        if self.tip_speed is not None:
            rows.append(TipSpeed(self.tip_speed))
        return tuple(rows)

    def bounds(self) -> ActuatorLimit:
        """The actuator bounds these settings hold."""
        return ActuatorLimit(self.travel_margin)

    def weights(self, rows: int) -> FloatArray:
        """The task rows' weights in the QP's cost: X_ext (tip x, angle x2, RCM x3) or a curved
        needle's X_c (tip x3, roll, RCM x3)."""
        aw, rw = self.angle_weight, self.rcm_weight
        if rows == 7:
            return np.array([1.0, 1.0, 1.0, aw, rw, rw, rw])
        return np.array([1.0, aw, aw, rw, rw, rw])

    def check(self, robot: RobotModel, eye: EyeModel | None) -> QpLimits:
        """Raise InvalidInputError for limits inconsistent with the robot or the eye."""
        check_robot_limits(robot, self.travel_margin)
        if self.singular_floor(robot) <= robot.singular_threshold:
            raise InvalidInputError(
                "singular_margin",
                self.singular_margin,
                f"above the robot's singular threshold {robot.singular_threshold:g}",
            )
        if eye is not None:
            check_eye_limits(self, eye)
        return self


MAX_CONTACTS = 100


def _contacts(value: Any) -> tuple[tuple[float, ...], ...]:
    """`contacts_mm` (a list of up to MAX_CONTACTS points in [mm]) in [m]."""
    valid = f"a list of up to {MAX_CONTACTS} points [x, y, z] in mm"
    if not isinstance(value, list | tuple) or len(value) > MAX_CONTACTS:
        raise InvalidInputError("contacts_mm", value, valid)
    return tuple(tuple(1e-3 * vector(f"contacts_mm[{i}]", c, 3)) for i, c in enumerate(value))


def check_robot_limits(robot: RobotModel, margin: float) -> None:
    """Slider travel must be ordered with room for the margin; speeds positive and finite."""
    lo, hi, v = robot.lower, robot.upper, robot.speed
    bad = np.flatnonzero(~(hi - lo > 2.0 * margin))
    if bad.size:
        raise InvalidInputError(
            "slider travel",
            (lo.tolist(), hi.tolist()),
            f"lower < upper with room for twice the travel margin {margin:g} m "
            f"(fails for slider index {bad.tolist()})",
        )
    if not np.all(np.isfinite(v)) or np.any(v <= 0.0):
        raise InvalidInputError("slider speed", v.tolist(), "positive finite speeds")


def check_eye_limits(lim: QpLimits, eye: EyeModel) -> None:
    """The RCM tolerance must fit in the port; the port zone must clear the wall and margin."""
    if lim.rcm_tolerance >= eye.trocar_radius:
        raise InvalidInputError(
            "rcm_tolerance",
            lim.rcm_tolerance,
            f"below the trocar radius {eye.trocar_radius:g} m",
        )
    need = eye.wall + lim.retina_margin
    if lim.port_zone <= need:
        raise InvalidInputError(
            "port_zone",
            lim.port_zone,
            f"above wall + retina margin = {need:g} m, or retraction through the port is blocked",
        )
    if lim.retina_margin >= eye.retina_radius:
        raise InvalidInputError("retina_margin", lim.retina_margin, "below the retina radius")
