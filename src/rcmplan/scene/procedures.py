"""Procedures as phases of targets: the injection of thesis section 3.4 and the spiral of fig. 4.6.

Every tip path inside the eye is a straight line in Cartesian space (or the spiral's curve),
sampled in equal steps no longer than `step_position`; each sample becomes an X_ext target with
the RCM at the trocar. The pivot that aligns the needle with the trocar is sampled in needle
angle, steps no larger than `step_angle`.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from rcmplan._validate import FloatArray, array, instance, integer, scalar, vector
from rcmplan.control.phase import Phase, check_plan_size, interpolate, step_count
from rcmplan.control.targets import pivot_target, rcm_target, rcm_targets, solve_pose
from rcmplan.exceptions import InvalidInputError, UnreachableTargetError
from rcmplan.robot.checks import robot_model
from rcmplan.robot.model import RobotModel
from rcmplan.robot.needle import angle_between, angles_from_axis
from rcmplan.scene.eye import Eye, EyePoints
from rcmplan.scene.eye_text import eye_frame_reason, eye_point_text, to_eye_mm

DEFAULT_VISITS = ("p4", "p5", "p6", "p7")


@dataclass(frozen=True)
class Steps:
    """Step sizes of Algorithm 2: position in [m], angle in [rad]."""

    position: float = 0.2e-3
    angle: float = 2e-3

    def __post_init__(self) -> None:
        scalar("steps.position", self.position, 0.0, 5e-3, low_open=True)
        scalar("steps.angle", self.angle, 0.0, 0.1, low_open=True)

    def count(self, distance: float, angle: float = 0.0) -> int:
        """Number of equal steps that keeps each step within both sizes (at least 1)."""
        distance = scalar("distance", distance, 0.0)
        ratio = max(distance / self.position, scalar("angle", angle, 0.0) / self.angle)
        return step_count(ratio - 1e-9, "steps")  # rounding noise must not add a step


def densify(path: FloatArray, trocar: FloatArray, steps: Steps) -> FloatArray:
    """Resample a tip path (N, 3) so that each step moves the tip at most `steps.position` and
    turns the needle about the trocar at most `steps.angle`; the first point is left out."""
    counts = [
        steps.count(float(np.linalg.norm(b - a)), angle_between(a - trocar, b - trocar))
        for a, b in itertools.pairwise(path)
    ]
    check_plan_size(sum(counts) + len(path), "targets of the path")
    return np.concatenate(
        [interpolate(a, b, n) for (a, b), n in zip(itertools.pairwise(path), counts, strict=True)]
    )


def path_targets(path: FloatArray, trocar: FloatArray, steps: Steps) -> FloatArray:
    """X_ext targets moving the tip along a polyline (N, 3), RCM at the trocar.

    A sample on the trocar itself (tip at the port, lambda = 1) keeps the needle direction of
    the path point farthest from the trocar.
    """
    pts = densify(path, trocar, steps)
    far = path[int(np.argmax(np.linalg.norm(path - trocar, axis=1)))]
    targets = rcm_targets(pts, trocar)
    on_port = np.linalg.norm(pts - trocar, axis=1) < 1e-12
    if on_port.any():
        targets[on_port, 1:3] = angles_from_axis((far - trocar) / np.linalg.norm(far - trocar))
    return targets


def line_targets(
    start: FloatArray, end: FloatArray, trocar: FloatArray, steps: Steps
) -> FloatArray:
    """X_ext targets moving the tip straight from start to end, RCM at the trocar."""
    return path_targets(np.array([start, end]), trocar, steps)


def approach_phase(
    robot: RobotModel, target: FloatArray, steps: Steps, name: str = "approach"
) -> Phase:
    """Free-space tip motion in a straight line from wherever the tip is to `target`."""

    def plan(q: FloatArray) -> FloatArray:
        start = robot.tip(q)
        return interpolate(start, target, steps.count(float(np.linalg.norm(target - start))))

    return Phase(name, plan, "free")


def align_phase(robot: RobotModel, eye: Eye, steps: Steps) -> Phase:
    """Pivot about the tip at the trocar (lambda = 1) until the needle lies on the trocar axis."""
    phi1, psi1 = angles_from_axis(eye.axis)

    def plan(q: FloatArray) -> FloatArray:
        x0 = np.array([robot.tip(q)[0], *angles_from_axis(robot.needle_axis(q)), *eye.port])
        x1 = pivot_target(eye.port[0], phi1, psi1, eye.port)
        return interpolate(x0, x1, steps.count(0.0, float(np.max(np.abs(x1[1:3] - x0[1:3])))))

    return Phase("align", plan, "rcm")


def check_inside(eye: Eye, name: str, p: FloatArray) -> None:
    """Raise if p is not inside the eye (on or within the retina) or lies behind the trocar."""
    if eye.distance_to_retina(p) < -1e-9:
        raise UnreachableTargetError(
            f"{name} lies {1e3 * -eye.distance_to_retina(p):.3f} mm outside the retina", p
        )
    if float(np.dot(p - eye.port, eye.axis)) <= 0.0:
        raise UnreachableTargetError(f"{name} lies behind the trocar (outside the eye)", p)


def check_point(robot: RobotModel, eye: Eye, label: str, p: FloatArray) -> None:
    """Raise UnreachableTargetError naming the point as `label`, in the eye frame and in mm,
    unless p (3,) [m] lies inside the eye, in front of the trocar, and has a pose with the RCM
    at the trocar (`eye_text.eye_frame_reason`)."""
    try:
        check_inside(eye, "the point", p)
        solve_pose(robot, rcm_target(p, eye.port))
    except UnreachableTargetError as exc:
        mm = to_eye_mm(eye, p)
        why = eye_frame_reason(exc, robot, eye, mm)
        raise UnreachableTargetError(f"{label} at {eye_point_text(mm)} {why}") from exc


def injection(
    robot: RobotModel,
    eye: Eye,
    points: EyePoints,
    steps: Steps | None = None,
    visits: tuple[str, ...] = DEFAULT_VISITS,
) -> list[Phase]:
    """The injection of section 3.4: approach, align, insert, visit 3 -> 4 -> 3 -> ..., retract.

    Every point inside the eye is checked before any motion: inside the eye, in front of the
    trocar, within the needle's reach and the sliders' travel.
    """
    steps = check_scene(robot, eye, points, steps)
    pts = points.as_dict()
    if not isinstance(visits, tuple | list):
        raise InvalidInputError("visits", visits, "names among p3..p7")
    for name in visits:
        if not isinstance(name, str) or name not in pts or name in ("p1", "p2"):
            raise InvalidInputError("visits", visits, "names among p3..p7")
    for name in ("p3", *visits):
        check_point(robot, eye, f"point {name}", pts[name])
    c = eye.port
    phases = [approach_phase(robot, points.p2, steps), align_phase(robot, eye, steps)]
    phases.append(Phase("insert", line_targets(points.p2, points.p3, c, steps)))
    for name in visits:
        phases.append(Phase(f"p3-{name}", line_targets(points.p3, pts[name], c, steps)))
        phases.append(Phase(f"{name}-p3", line_targets(pts[name], points.p3, c, steps)))
    phases.append(Phase("retract", line_targets(points.p3, points.p2, c, steps)))
    phases.append(approach_phase(robot, points.p1, steps, name="withdraw"))
    return phases


@dataclass(frozen=True)
class Spiral:
    """An off-axis spiral traced by the tip (fig. 4.6).

    Attributes:
        offset: Centre of the spiral relative to p3, in the plane normal to the trocar axis,
            as (along e1, along e2) in [m], each within +-50 mm.
        radius: Final radius in [m]; the radius grows linearly from 0 over the turns.
        turns: Number of turns.
        pitch: Advance along the trocar axis per turn in [m] (0: a flat spiral).
        points_per_turn: Samples per turn, an integer in [8, 10000].
    """

    offset: tuple[float, float] = (1.0e-3, 0.5e-3)
    radius: float = 2.5e-3
    turns: float = 3.0
    pitch: float = 0.5e-3
    points_per_turn: int = 120

    def __post_init__(self) -> None:
        offset = vector("spiral.offset", self.offset, 2)
        if np.abs(offset).max() > 0.05:
            raise InvalidInputError("spiral.offset", self.offset, "within +-50 mm of p3 per axis")
        turns = scalar("spiral.turns", self.turns, 0.0, 50.0, low_open=True)
        per_turn = integer("spiral.points_per_turn", self.points_per_turn, 8, 10_000)
        checked = {
            "offset": (float(offset[0]), float(offset[1])),
            "radius": scalar("spiral.radius", self.radius, 0.0, 10e-3, low_open=True),
            "turns": turns,
            "pitch": scalar("spiral.pitch", self.pitch, -5e-3, 5e-3),
            "points_per_turn": per_turn,
        }
        if turns * per_turn < 1.0:
            valid = "turns x points_per_turn >= 1 (a path of two points or more)"
            raise InvalidInputError("spiral.turns", self.turns, valid)
        for name, value in checked.items():
            object.__setattr__(self, name, value)

    def path(self, eye: Eye, p3: FloatArray) -> FloatArray:
        """The tip path (N, 3) in [m]; the eye's insertion axis must not be vertical (the
        spiral's plane axes e1 = axis x z and e2 = axis x e1)."""
        instance("eye", eye, Eye, "an Eye (default_eye(robot))")
        p3 = vector("p3", p3, 3)
        n_axis = eye.axis
        e1 = np.cross(n_axis, [0.0, 0.0, 1.0])
        if np.linalg.norm(e1) < 1e-6:
            raise InvalidInputError(
                "eye", eye.axis.tolist(), "an insertion axis that is not vertical"
            )
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(n_axis, e1)
        centre = p3 + self.offset[0] * e1 + self.offset[1] * e2
        t = np.linspace(0.0, 1.0, int(self.turns * self.points_per_turn) + 1)
        theta = 2 * math.pi * self.turns * t
        r = self.radius * t
        return (
            centre
            + (r * np.cos(theta))[:, None] * e1
            + (r * np.sin(theta))[:, None] * e2
            + (self.pitch * self.turns * t)[:, None] * n_axis
        )


def path_procedure(
    robot: RobotModel,
    eye: Eye,
    points: EyePoints,
    path: FloatArray,
    steps: Steps | None = None,
    name: str = "path",
) -> list[Phase]:
    """Approach, align, insert to p3, move to the path's start, follow the tip path (N, 3),
    return to p3, retract, withdraw. Every path point is checked inside the eye, and points along
    it (every 1/24 of the path and its end) for a pose, before any motion; a refusal names the
    point in the eye frame, in mm (`check_point`)."""
    steps = check_scene(robot, eye, points, steps)
    path = np.atleast_2d(array("path", path, 2))
    if path.shape[1] != 3 or len(path) < 2:
        raise InvalidInputError("path", path.shape, "tip points (N, 3), N >= 2")
    c = eye.port
    for i, p in enumerate(path):
        check_inside(eye, f"{name} point {i}", p)
    for i in {*range(0, len(path), max(1, len(path) // 24)), len(path) - 1}:
        check_point(robot, eye, f"{name} point {i}", path[i])
    targets = path_targets(path, c, steps)
    return [
        approach_phase(robot, points.p2, steps),
        align_phase(robot, eye, steps),
        Phase("insert", line_targets(points.p2, points.p3, c, steps)),
        Phase(f"to-{name}", line_targets(points.p3, path[0], c, steps)),
        Phase(name, targets),
        Phase(f"from-{name}", line_targets(path[-1], points.p3, c, steps)),
        Phase("retract", line_targets(points.p3, points.p2, c, steps)),
        approach_phase(robot, points.p1, steps, name="withdraw"),
    ]


def spiral(
    robot: RobotModel,
    eye: Eye,
    points: EyePoints,
    shape: Spiral | None = None,
    steps: Steps | None = None,
) -> list[Phase]:
    """Approach, align, insert to p3, move to the spiral start, trace it, return, retract."""
    check_scene(robot, eye, points, steps)
    shape = Spiral() if shape is None else instance("shape", shape, Spiral, "a Spiral or None")
    return path_procedure(robot, eye, points, shape.path(eye, points.p3), steps, "spiral")


def check_scene(robot: RobotModel, eye: Eye, points: EyePoints, steps: Steps | None) -> Steps:
    """The step sizes (default Steps()), or InvalidInputError naming the first argument of a
    procedure that is not a robot, an Eye, EyePoints or Steps."""
    robot_model("robot", robot)
    instance("eye", eye, Eye, "an Eye (default_eye(robot))")
    instance("points", points, EyePoints, "EyePoints (default_points(eye))")
    if steps is None:
        return Steps()
    checked: Steps = instance("steps", steps, Steps, "Steps or None (the defaults)")
    return checked
