"""Points and refusals in the eye frame, in mm: how a user states points (`--target`,
`--path`, a scenario's points) and how a refusal answers them.

The eye frame: origin at the eye centre, z along the insertion axis from the trocar inwards
(`eye.eye_frame`).
"""

from __future__ import annotations

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.control.targets import target_tips
from rcmplan.exceptions import ActuatorLimitError, UnreachableTargetError
from rcmplan.robot.model import RobotModel
from rcmplan.scene.eye import Eye, eye_frame, from_eye_frame

MM = 1e-3


def to_base(eye: Eye, points_eye_mm: FloatArray) -> FloatArray:
    """Points (N, 3) in mm in the eye frame -> points (N, 3) in m in the robot base frame."""
    return from_eye_frame(eye, np.asarray(points_eye_mm, dtype=float) * MM)


def to_eye_mm(eye: Eye, points_base: FloatArray) -> FloatArray:
    """Points (N, 3) or (3,) in m in the robot base frame -> the same in mm in the eye frame."""
    return np.asarray((np.asarray(points_base, dtype=float) - eye.center) @ eye_frame(eye) / MM)


ROUNDING_MM = 1e-9  # [mm] a coordinate below this is the frames' rounding: written as 0


def eye_point_text(point_eye_mm: FloatArray) -> str:
    """(x, y, z) mm (eye frame), each to 4 significant digits; a coordinate within ROUNDING_MM
    of 0 (a point typed in the eye frame, carried through the base frame and back) as 0."""
    coords = ", ".join(f"{0.0 if abs(v) < ROUNDING_MM else v:.4g}" for v in point_eye_mm)
    return f"({coords}) mm (eye frame)"


def eye_frame_reason(
    exc: UnreachableTargetError, robot: RobotModel, eye: Eye, point_eye_mm: FloatArray
) -> str:
    """Why a point is out of reach, in mm: an actuator's travel and the retina in the user's
    terms, the check's own words where they carry no position, and any other reason labelled
    as the robot's base frame it is stated in."""
    cause = exc.__cause__
    if isinstance(cause, ActuatorLimitError):
        kind = str(cause).split(" ", 1)[0]  # "slider" or "joint", as the model names them
        k, unit = (1e3, "mm") if robot.actuator_units[cause.index] == "m" else (1.0, "rad")
        value, lo, hi = k * cause.value, k * cause.lower, k * cause.upper
        past = value - hi if value > hi else lo - value
        return (f"is out of reach: {kind} {cause.slider} would be at {value:.6g} {unit}, "
                f"{past:.3g} {unit} beyond its travel [{lo:.6g}, {hi:.6g}] {unit}")  # fmt: skip
    if eye.distance_to_retina(to_base(eye, point_eye_mm[None, :])[0]) < -1e-9:
        r_mm, retina_mm = float(np.linalg.norm(point_eye_mm)), 1e3 * eye.retina_radius
        return (f"lies {r_mm - retina_mm:.4g} mm outside the retina, the sphere of radius "
                f"{retina_mm:.4g} mm about the eye centre (the origin)")  # fmt: skip
    if exc.reason.startswith(FRAMELESS_REASONS):
        return f"is out of reach: {exc.reason}"
    return f"is out of reach: {exc.reason} (robot base frame)"


FRAMELESS_REASONS = ("lambda = ", "needle angles ", "the point lies")  # refusals without positions


def in_eye_frame(exc: UnreachableTargetError, eye: Eye) -> UnreachableTargetError:
    """The refusal of an RCM target (X_ext (6,) or a curved needle's X_c (7,), its roll then
    too) with its tip stated in the eye frame in mm, as a user states points, in place of the
    target's numbers in the robot base frame; exc itself when it carries no such target."""
    target = exc.target
    if target is None or np.shape(target) not in ((6,), (7,)):
        return exc
    try:
        tip = target_tips(np.asarray(target, dtype=float)[None, :])[0]
    except UnreachableTargetError:  # X_ext that fixes no tip: its numbers stay
        return exc
    if not np.all(np.isfinite(tip)):
        return exc
    x, y, z = (f"{v:.4g}" for v in to_eye_mm(eye, tip))
    roll = f", the needle's roll {target[3]:.4g} rad" if len(target) == 7 else ""
    return exc.restated(stated=f"its tip at x = {x}, y = {y}, z = {z} mm in the eye frame{roll}")
