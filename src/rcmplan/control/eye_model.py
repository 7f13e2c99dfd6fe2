"""What the controller's limits need of an eye: its spheres and its trocar (`scene.eye.Eye`
is one; any object with these members serves)."""

from __future__ import annotations

from typing import Any, Protocol

from rcmplan._validate import FloatArray
from rcmplan.exceptions import InvalidInputError

MEMBERS = ("center", "wall", "trocar_radius", "port", "retina_radius", "distance_to_retina")


class EyeModel(Protocol):
    """A spherical eye with one trocar, lengths in [m], points in the world frame."""

    @property
    def center(self) -> FloatArray:
        """Eye centre (3,)."""
        ...

    @property
    def wall(self) -> float:
        """Wall thickness."""
        ...

    @property
    def trocar_radius(self) -> float:
        """Radius of the trocar port."""
        ...

    @property
    def port(self) -> FloatArray:
        """The trocar point (3,)."""
        ...

    @property
    def retina_radius(self) -> float:
        """Radius of the retina sphere."""
        ...

    def distance_to_retina(self, p: FloatArray) -> float:
        """Signed distance from p to the retina, positive inside the vitreous."""
        ...


def check_eye(name: str, eye: Any) -> EyeModel:
    """eye if it has the members of an EyeModel, else InvalidInputError naming `name`."""
    if not all(hasattr(eye, m) for m in MEMBERS) or not callable(eye.distance_to_retina):
        raise InvalidInputError(name, eye, "an eye (rcmplan.Eye, default_eye(robot))")
    checked: EyeModel = eye
    return checked
