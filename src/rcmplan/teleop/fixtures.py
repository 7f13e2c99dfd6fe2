"""Virtual fixtures of a teleoperated session, held as limits of the QP at every period.

- RCM: the needle line through the trocar within `rcm_tolerance` (the QP's RCM box); a
  deviation beyond `rcm_limit` counts as a violation.
- Retina no-go margin: the tip at least `retina_margin` from the retina, approached as a
  velocity damper at `gain` (never relaxed: a teleoperated tip has no planned contacts).
- Workspace bound: the tip inside a box in the eye frame (`WorkspaceBound`); by default
  +-6 mm sideways and from 4 mm inside the trocar on (the retina margin bounds the depth).
- Actuator travel and speed: each actuator within travel less `travel_margin`, moving at most
  its speed (the robot's) per period.

The desired tip itself is not limited (the surgeon may push through a fixture: the needle
stops at it); only the X_ext target's tip is kept in the box, so that the needle direction it
asks for (tip to trocar) stays defined.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rcmplan._validate import FloatArray, scalar, vector
from rcmplan.control.limits import WorkspaceBound
from rcmplan.control.qp_limits import QpLimits
from rcmplan.exceptions import InvalidInputError
from rcmplan.scene.eye import Eye, eye_frame

MIN_DEPTH = 1e-3  # [m] the box must lie at least this far inside the trocar along the axis


@dataclass(frozen=True)
class Fixtures:
    """Fixture settings, SI units; the box in the eye frame (origin at the eye centre, z along
    the insertion axis).

    Attributes:
        retina_margin: Closest approach of the tip to the retina [m].
        rcm_tolerance: The QP's RCM box half-width [m] (QpLimits.rcm_tolerance).
        rcm_limit: RCM deviation [m] beyond which a period counts as a violation.
        workspace_lower, workspace_upper: Box faces (3,) [m] in the eye frame.
        gain: Damper gain in (0, 1] of the retina margin and the box: the gap to a fixture
            shrinks at most by this fraction per period (0.02: the tip slows from about
            v dt / 0.02 before a fixture, over about 50 periods, instead of stopping at once).
        travel_margin: Distance kept from each actuator's travel ends [m].
        plant_guard: Added to the retina margin and taken off the box in the QP [m] on a
            plant that does not reach its commands exactly (MuJoCo's piezo servo stops short
            of its command: docs/teleop.md); violations still count against the fixtures
            themselves. Exact plants get no guard.
    """

    retina_margin: float = 0.25e-3
    rcm_tolerance: float = 0.5e-6
    rcm_limit: float = 2e-6
    workspace_lower: tuple[float, float, float] = (-6e-3, -6e-3, -8e-3)
    workspace_upper: tuple[float, float, float] = (6e-3, 6e-3, 12e-3)
    gain: float = 0.02
    travel_margin: float = 0.5e-3
    plant_guard: float = 1e-6

    def __post_init__(self) -> None:
        scalar("retina_margin", self.retina_margin, 0.0, 5e-3)
        scalar("rcm_tolerance", self.rcm_tolerance, 0.0, 1e-4)
        scalar("rcm_limit", self.rcm_limit, self.rcm_tolerance, 1e-3, low_open=True)
        lo = vector("workspace_lower", self.workspace_lower, 3)
        hi = vector("workspace_upper", self.workspace_upper, 3)
        if np.any(hi <= lo):
            raise InvalidInputError("workspace", (lo, hi), "lower < upper on every axis")
        scalar("gain", self.gain, 0.0, 1.0, low_open=True)
        scalar("travel_margin", self.travel_margin, 0.0, 0.01)
        scalar("plant_guard", self.plant_guard, 0.0, 1e-4)

    def qp_limits(self, guard: float = 0.0) -> QpLimits:
        """The QP's own limits: RCM box, travel margin, retina margin plus `guard` [m] (no
        contacts)."""
        return QpLimits(
            rcm_tolerance=self.rcm_tolerance,
            travel_margin=self.travel_margin,
            retina_margin=self.retina_margin + guard,
            eye_gain=self.gain,
            contact_tolerance=0.0,
        )

    def workspace(self, eye: Eye, guard: float = 0.0) -> WorkspaceBound:
        """The box as a QP limit, shrunk by `guard` [m] on every side, checked to lie inside
        the trocar (MIN_DEPTH)."""
        floor = -eye.radius + MIN_DEPTH
        if self.workspace_lower[2] < floor:
            raise InvalidInputError(
                "workspace_lower[2]", self.workspace_lower[2],
                f"at least {floor:g} m (the box must lie {MIN_DEPTH:g} m inside the trocar, "
                f"which is at z = {-eye.radius:g} m)",
            )  # fmt: skip
        R = eye_frame(eye)
        lo = tuple(v + guard for v in self.workspace_lower)
        hi = tuple(v - guard for v in self.workspace_upper)
        return WorkspaceBound(tuple(eye.center), tuple(map(tuple, R)), lo, hi,  # type: ignore[arg-type]
                              self.gain)  # fmt: skip

    def check_start(self, eye: Eye, tip: FloatArray) -> None:
        """Raise InvalidInputError unless a start tip lies inside the box and the margin."""
        box = self.workspace(eye)
        out = float(box.outside(tip)[0])
        if out > 0.0:
            raise InvalidInputError("start tip", box.coordinates(tip),
                                    f"inside the workspace box {self.workspace_lower} to "
                                    f"{self.workspace_upper} m (eye frame)")  # fmt: skip
        depth = eye.distance_to_retina(tip)
        if depth < self.retina_margin:
            raise InvalidInputError("start tip", box.coordinates(tip),
                                    f"at least the retina margin {self.retina_margin:g} m from "
                                    f"the retina (it is {depth:g} m)")  # fmt: skip
