"""The arguments of the MuJoCo plants, checked before a model is built."""

from __future__ import annotations

from typing import Any

from rcmplan._validate import flag, instance, text, vector
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.curved_needle import ARC_ANGLE_RANGE, RADIUS_RANGE
from rcmplan.scene.eye import Eye, EyePoints
from rcmplan.sim.mujoco.scene import EyePhantom

MODES = ("dynamic", "kinematic")


def check_scene_args(mode: Any, eye: Any, points: Any) -> None:
    """Raise InvalidInputError unless mode is one of MODES, eye an Eye, an EyePhantom or None
    and points EyePoints or None."""
    text("mode", mode, MODES)
    if eye is not None:
        instance("eye", eye, (Eye, EyePhantom), "an Eye, an EyePhantom or None (the default eye)")
    if points is not None:
        instance("points", points, EyePoints, "EyePoints or None")


def check_plant_args(
    mode: Any, gravity_compensation: Any, eye: Any, points: Any, piezo: Any, needle_arc: Any
) -> None:
    """Raise InvalidInputError naming the first argument of MujocoPlant that is not valid."""
    from rcmplan.sim.mujoco.actuators import PiezoParameters

    check_scene_args(mode, eye, points)
    flag("gravity_compensation", gravity_compensation)
    if piezo is not None:
        instance("piezo", piezo, PiezoParameters, "PiezoParameters or None (from the robot)")
    check_needle_arc(needle_arc)


def check_needle_arc(needle_arc: Any) -> tuple[float, float] | None:
    """(R [m], alpha [rad]) of a curved needle's arc as floats, or None; InvalidInputError
    naming the valid ranges otherwise."""
    if needle_arc is None:
        return None
    radius, angle = vector("needle_arc", needle_arc, 2)
    lo, hi = RADIUS_RANGE
    if not (lo <= radius <= hi and ARC_ANGLE_RANGE[0] <= angle <= ARC_ANGLE_RANGE[1]):
        valid = f"(R, alpha): R in [{lo:g}, {hi:g}] m, alpha in [0, pi/2] rad"
        raise InvalidInputError("needle_arc", needle_arc, valid)
    return float(radius), float(angle)
