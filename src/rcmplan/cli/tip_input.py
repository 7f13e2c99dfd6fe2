"""Tip targets given on the command line: `--target X,Y,Z` and `--path FILE.csv`, in mm.

Both are in the eye frame: origin at the eye centre, z along the insertion axis (from the
trocar through the eye centre), x = z x z_base / |z x z_base| (horizontal in the robot base
frame), y = z x x. It is the trocar frame (e1, e2, n) of the figures, moved to the eye centre.
With the default eye the trocar lies at (0, 0, -12) mm and the retina is the sphere of radius
11 mm about the origin.

`--target` (up to four, visited in order from p3 like the injection's p4..p7) runs the
injection with these points; `--path` runs approach, align, insert, a straight move to the
path's first point, the path, back to p3, retract and withdraw.
"""

from __future__ import annotations

import csv
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.control.phase import Phase
from rcmplan.control.targets import rcm_target, solve_pose
from rcmplan.exceptions import InvalidInputError, UnreachableTargetError
from rcmplan.robot.model import RobotModel
from rcmplan.robot.registry import make_robot
from rcmplan.scene.eye import Eye
from rcmplan.scene.eye_text import MM, eye_frame_reason, to_base
from rcmplan.scene.procedures import check_inside, path_procedure
from rcmplan.scene.scenario import Scenario

SLOTS = ("p4", "p5", "p6", "p7")


def parse_point(text: str) -> tuple[float, float, float]:
    """ "X,Y,Z" (mm) -> a tuple; InvalidInputError naming the expected form otherwise."""
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 3 or not np.all(np.isfinite(values)):
        raise InvalidInputError("--target", text, "three finite numbers in mm: X,Y,Z")
    return (values[0], values[1], values[2])


def read_path_csv(path: str | Path) -> FloatArray:
    """Tip points (N, 3) in mm from a CSV of rows x,y,z (an optional header row is skipped)."""
    try:
        with open(path, newline="") as fh:
            rows = [r for r in csv.reader(fh) if r and not r[0].lstrip().startswith("#")]
    except OSError as exc:
        raise InvalidInputError("--path", str(path), f"a readable CSV file ({exc})") from exc
    if rows and not _numeric(rows[0]):
        rows = rows[1:]
    bad = [i for i, r in enumerate(rows) if len(r) != 3 or not _numeric(r)]
    if bad or len(rows) < 2:
        raise InvalidInputError("--path", str(path), "at least 2 rows of three numbers x,y,z "
                                f"in mm (bad rows: {bad[:5]})")  # fmt: skip
    return np.array([[float(v) for v in r] for r in rows])


def _numeric(row: list[str]) -> bool:
    try:
        return all(np.isfinite(float(v)) for v in row)
    except ValueError:
        return False


def with_targets(sc: Scenario, targets_eye_mm: list[tuple[float, float, float]]) -> Scenario:
    """The scenario's injection visiting the given eye-frame points (mm) instead of p4..p7,
    each checked before any motion (`check_tip_points`)."""
    if not 1 <= len(targets_eye_mm) <= len(SLOTS):
        raise InvalidInputError("--target", len(targets_eye_mm), "1 to 4 targets")
    robot = sc.needle.fit(make_robot(sc.robot))  # the model the run moves
    eye = sc.eye(robot)
    points = np.array(targets_eye_mm, dtype=float)
    check_tip_points(robot, eye, points, lambda i: f"--target {_typed(points[i])}")
    # In the frame of the scenario's points (`Scenario.point_frame`): the base frame [m], or
    # the eye frame [m] as given.
    given = to_base(eye, points) if sc.point_frame == "base" else points * MM
    overrides = dict(sc.point_overrides)
    overrides.update({s: tuple(p) for s, p in zip(SLOTS, given, strict=False)})
    return replace(sc, procedure="injection", point_overrides=overrides,
                   visits=SLOTS[: len(targets_eye_mm)])  # fmt: skip


@dataclass(frozen=True)
class PathScenario(Scenario):
    """A scenario whose procedure follows a given tip path (base frame, m) from p3."""

    path_m: tuple[tuple[float, float, float], ...] = ()

    def phases(self, robot: RobotModel) -> list[Phase]:
        """Approach, align, insert, to the path, the path, back to p3, retract, withdraw."""
        eye = self.eye(robot)
        return path_procedure(robot, eye, self.points(eye), np.array(self.path_m), self.steps)


def with_path(sc: Scenario, path_eye_mm: FloatArray) -> PathScenario:
    """The scenario following the given eye-frame tip path (mm) from p3; every point checked
    inside the eye and some (`POSED_PATH_POINTS` spread over the path, and its last) for a
    pose, before any motion (`check_tip_points`)."""
    robot = sc.needle.fit(make_robot(sc.robot))  # the model the run moves
    eye = sc.eye(robot)
    points = np.asarray(path_eye_mm, dtype=float)
    every = max(1, len(points) // POSED_PATH_POINTS)
    check_tip_points(robot, eye, points, lambda i: f"--path point {i + 1} "
                     f"({_typed(points[i], ', ')})", every)  # fmt: skip
    fields = {f: getattr(sc, f) for f in sc.__dataclass_fields__}
    fields["procedure"] = "path"
    path_m = tuple((float(p[0]), float(p[1]), float(p[2])) for p in to_base(eye, points))
    return PathScenario(**fields, path_m=path_m)


POSED_PATH_POINTS = 24  # path points checked for a pose before motion (the procedure's count)


def check_tip_points(
    robot: RobotModel, eye: Eye, points_eye_mm: FloatArray, label: Callable[[int], str],
    every: int = 1,
) -> None:  # fmt: skip
    """Raise UnreachableTargetError, in the eye frame and in mm and naming point i as
    `label(i)` gives it, unless each point lies inside the retina and in front of the trocar
    and each `every`-th point (and the last) has a pose with the RCM at the trocar."""
    base = to_base(eye, points_eye_mm)
    posed = {*range(0, len(base), every), len(base) - 1}
    for i, p in enumerate(base):
        try:
            check_inside(eye, "the point", p)
            if i in posed:
                solve_pose(robot, rcm_target(p, eye.port))
        except UnreachableTargetError as exc:
            why = eye_frame_reason(exc, robot, eye, points_eye_mm[i])
            raise UnreachableTargetError(f"{label(i)} (mm, eye frame) {why}") from exc


def _typed(p: FloatArray, sep: str = ",") -> str:
    """A point's coordinates as typed: 1.5,-2,6."""
    return sep.join(f"{v:g}" for v in p)
