"""The scene of a run as summary.json records it (`scene` block), and read back.

A run's log holds the robot's motion; the eye it moved in, the trocar and the named points
depend on the scenario and the robot (`Scenario.eye`), so the run writes them beside the log,
in the robot base frame in [m], and readers (the 3D view) need neither the scenario file nor
the options of the command that ran it. Written by `rcmplan.analysis.report.summary_json` and
`rcmplan.teleop.summary`.

Block layout (FORMAT "rcmplan-scene-1")::

    "scene": {"format": "rcmplan-scene-1", "frame": "robot base, m",
              "eye_center_m": [x, y, z], "eye_radius_m": R, "eye_wall_m": w,
              "trocar_m": [x, y, z], "trocar_radius_m": r,
              "points": [{"name": "p1", "position_m": [x, y, z]}, ...], "visits": ["p4", ...],
              "needle_arc": {"radius_m": R, "angle_rad": a} or null}
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.exceptions import InvalidInputError, RcmplanError
from rcmplan.robot.model import RobotModel
from rcmplan.scene.eye import Eye
from rcmplan.scene.scenario import Scenario

FORMAT = "rcmplan-scene-1"  # a string: every number in summary.json carries a unit


@dataclass(frozen=True)
class SceneRecord:
    """The eye, trocar and named points of a run, robot base frame, [m].

    Attributes:
        eye_center: Eye centre (3,). eye_radius: Outer radius. eye_wall: Wall thickness.
        trocar: Trocar point (3,). trocar_radius: Radius of the trocar port.
        points: Named points (p1..p7), each (3,). visits: The names the procedure visits.
        needle_arc: (R [m], alpha [rad]) of a curved needle's arc, or None.
    """

    eye_center: FloatArray
    eye_radius: float
    eye_wall: float
    trocar: FloatArray
    trocar_radius: float
    points: dict[str, FloatArray]
    visits: tuple[str, ...] = ()
    needle_arc: tuple[float, float] | None = None

    @property
    def retina_radius(self) -> float:
        """Radius of the retina (inner sphere) in [m]."""
        return self.eye_radius - self.eye_wall

    @property
    def axis(self) -> FloatArray:
        """Unit insertion axis from the trocar to the eye centre."""
        d = self.eye_center - self.trocar
        return np.asarray(d / np.linalg.norm(d))

    @classmethod
    def of(
        cls, eye: Eye, points: dict[str, FloatArray], visits: tuple[str, ...] = ()
    ) -> SceneRecord:
        """The record of an eye and its named points (a straight needle)."""
        return cls(eye.center, eye.radius, eye.wall, eye.port, eye.trocar_radius,
                   {n: np.asarray(p, dtype=float) for n, p in points.items()}, visits)  # fmt: skip

    def labelled_points(self) -> dict[str, FloatArray]:
        """p1 (outside), p2 (trocar), p3 (vitreous) and the visited points, in visit order."""
        names: list[str] = [n for n in ("p1", "p2", "p3") if n in self.points]
        names += [n for n in self.visits if n in self.points and n not in names]
        return {n: self.points[n] for n in names}


def scene_record(scenario: Scenario, robot: RobotModel) -> dict[str, Any] | None:
    """The `scene` block of a run of `scenario` on `robot`, or None when the scenario's eye
    cannot be placed for the robot (the run then stopped before motion and says why)."""
    try:
        eye = scenario.eye(robot)
        points = scenario.points(eye).as_dict()
    except RcmplanError:
        return None
    visits = list(scenario.visits) if scenario.procedure == "injection" else []
    return eye_record(eye, points, visits, scenario.needle.arc())


def eye_record(
    eye: Eye,
    points: dict[str, Any] | None = None,
    visits: list[str] | None = None,
    arc: tuple[float, float] | None = None,
) -> dict[str, Any]:
    """The `scene` block of a run in `eye` with the named points (base frame, [m]), the
    injection's visits and a curved needle's arc (radius, angle), if any."""
    return {
        "format": FORMAT,
        "frame": "robot base, m",
        "eye_center_m": eye.center.tolist(),
        "eye_radius_m": eye.radius,
        "eye_wall_m": eye.wall,
        "trocar_m": eye.port.tolist(),
        "trocar_radius_m": eye.trocar_radius,
        "points": [
            {"name": n, "position_m": np.asarray(p, dtype=float).tolist()}
            for n, p in (points or {}).items()
        ],
        "visits": list(visits or []),
        "needle_arc": None if arc is None else {"radius_m": arc[0], "angle_rad": arc[1]},
    }


def read_scene_record(block: Any) -> SceneRecord:
    """A SceneRecord from a `scene` block; InvalidInputError naming the key that is wrong."""
    if not isinstance(block, dict):
        raise InvalidInputError("scene", block, "an object with the eye, trocar and points")
    if block.get("format") != FORMAT:
        raise InvalidInputError("scene.format", block.get("format"), repr(FORMAT))
    arc = block.get("needle_arc")
    if arc is not None and not isinstance(arc, dict):
        raise InvalidInputError("scene.needle_arc", arc, "null or {radius_m, angle_rad}")
    points = block.get("points")
    if not isinstance(points, list) or not all(
        isinstance(p, dict) and isinstance(p.get("name"), str) for p in points
    ):
        raise InvalidInputError("scene.points", points, "a list of {name, position_m}")
    visits = block.get("visits", [])
    if not isinstance(visits, list) or not all(isinstance(v, str) for v in visits):
        raise InvalidInputError("scene.visits", visits, "a list of point names")
    return SceneRecord(
        eye_center=_point("eye_center_m", block.get("eye_center_m")),
        eye_radius=_positive("eye_radius_m", block.get("eye_radius_m")),
        eye_wall=_positive("eye_wall_m", block.get("eye_wall_m")),
        trocar=_point("trocar_m", block.get("trocar_m")),
        trocar_radius=_positive("trocar_radius_m", block.get("trocar_radius_m")),
        points={p["name"]: _point(f"points.{p['name']}", p.get("position_m")) for p in points},
        visits=tuple(visits),
        needle_arc=None
        if arc is None
        else (
            _positive("needle_arc.radius_m", arc.get("radius_m")),
            _positive("needle_arc.angle_rad", arc.get("angle_rad"), zero=True),
        ),
    )


def _point(key: str, value: Any) -> FloatArray:
    ok = isinstance(value, list) and len(value) == 3
    ok = ok and all(isinstance(v, int | float) and math.isfinite(v) for v in value)
    if not ok:
        raise InvalidInputError(f"scene.{key}", value, "a list of 3 finite numbers [m]")
    return np.array(value, dtype=float)


def _positive(key: str, value: Any, zero: bool = False) -> float:
    ok = isinstance(value, int | float) and math.isfinite(value)
    if not ok or value < 0 or (value == 0 and not zero):
        raise InvalidInputError(f"scene.{key}", value, "a non-negative number" if zero else
                                "a positive number")  # fmt: skip
    return float(value)
