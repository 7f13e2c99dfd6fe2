"""Scenarios: eye, points, procedure and controller settings, from TOML files validated on load.

Keys carry their unit (`radius_mm`, `angle_mrad`); values are converted to SI on load. Every
error names the section and key and the allowed values or range. Scenarios shipped with rcmplan
are registered by name (`rcmplan.scene.scenario.SCENARIOS`): `default` (the injection) and
`spiral`, plus the constrained scenarios for the QP controller.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from rcmplan.choices import CURVED_METHODS, METHODS, PLANTS
from rcmplan.control.methods import MethodSettings
from rcmplan.control.phase import MAX_TARGETS, LoopSettings, Phase
from rcmplan.control.solvers import Tolerance
from rcmplan.exceptions import InvalidInputError, PlanTooLargeError, ScenarioError, did_you_mean
from rcmplan.robot.curved import CurvedTipRobot
from rcmplan.robot.model import RobotModel
from rcmplan.robot.registry import check_robot, is_robot_file
from rcmplan.scene.curved_procedure import NeedleOptions, curved_injection
from rcmplan.scene.eye import (
    POINT_NAMES,
    Eye,
    EyePoints,
    default_eye,
    default_points,
    from_eye_frame,
)
from rcmplan.scene.procedures import DEFAULT_VISITS, Spiral, Steps, injection, spiral
from rcmplan.scene.schema import SCHEMA, check_step, sections
from rcmplan.scene.shipped import scenario_names, shipped_text

__all__ = [
    "SCHEMA",
    "Scenario",
    "load_scenario",
    "scenario_from_dict",
    "scenario_names",
    "shipped_text",
]

PROCEDURES = ("injection", "spiral")
POINT_FRAMES = ("base", "eye")  # of [points] p1_mm..p7_mm: the robot's base frame, the eye's
MM = 1e-3


@dataclass(frozen=True)
class Scenario:
    """Everything a run needs besides the robot."""

    name: str = "default"
    procedure: str = "injection"
    plant: str = "kinematic"
    method: str = "pinv"
    robot: str = "iramis"
    eye_options: dict[str, Any] = field(default_factory=dict)
    point_options: dict[str, Any] = field(default_factory=dict)
    point_overrides: dict[str, tuple[float, ...]] = field(default_factory=dict)
    point_frame: str = "base"
    visits: tuple[str, ...] = DEFAULT_VISITS
    steps: Steps = field(default_factory=Steps)
    method_settings: MethodSettings = field(default_factory=MethodSettings)
    loop: LoopSettings = field(default_factory=LoopSettings)
    spiral: Spiral = field(default_factory=Spiral)
    dt: float = 1e-3
    needle: NeedleOptions = field(default_factory=NeedleOptions)

    def __post_init__(self) -> None:
        if self.point_frame not in POINT_FRAMES:
            raise ScenarioError("[points] frame", self.point_frame, f"one of {POINT_FRAMES}")
        if self.needle.kind == "curved" and self.method not in CURVED_METHODS:
            raise ScenarioError("method", self.method,
                                f"one of {CURVED_METHODS} for a curved needle")  # fmt: skip

    def eye(self, robot: RobotModel) -> Eye:
        """The eye placed for this robot."""
        return default_eye(robot, **self.eye_options)

    def points(self, eye: Eye) -> EyePoints:
        """The seven named points, defaults overridden by explicit ones (base frame [m]; given
        in the eye frame (`point_frame` "eye"), placed in this eye)."""
        pts = default_points(eye, **self.point_options).as_dict()
        for k, v in self.point_overrides.items():
            p = np.asarray(v, dtype=float)
            pts[k] = from_eye_frame(eye, p) if self.point_frame == "eye" else p
        return EyePoints(**pts)

    def phases(self, robot: RobotModel) -> list[Phase]:
        """The procedure's phases, every target checked before motion."""
        eye = self.eye(robot)
        pts = self.points(eye)
        self._check_plan_size(pts)
        if self.needle.kind == "curved":
            return self._curved_phases(self.needle.fit(robot), eye, pts)
        if self.procedure == "spiral":
            return spiral(robot, eye, pts, self.spiral, self.steps)
        return injection(robot, eye, pts, self.steps, self.visits)

    def _check_plan_size(self, pts: EyePoints) -> None:
        """Refuse, before any target is planned, visits that plan more targets than a run
        allows: each goes from p3 to its point and back, straight in steps of at most
        `steps.position` (a lower bound of what the injection plans; the curved needle's
        path is not straight, so at least one target each way)."""
        if self.procedure != "injection":
            return
        p = pts.as_dict()
        legs = {
            name: 1 if self.needle.kind == "curved" else
            self.steps.count(float(np.linalg.norm(p[name] - p["p3"])))
            for name in set(self.visits)
        }  # fmt: skip
        planned = sum(2 * legs[name] for name in self.visits)
        if planned > MAX_TARGETS:
            valid = f"at most {MAX_TARGETS:,} targets per run (fewer visits or longer steps)"
            raise PlanTooLargeError(f"targets of {len(self.visits):,} visits", planned, valid)

    def _curved_phases(self, robot: RobotModel, eye: Eye, pts: EyePoints) -> list[Phase]:
        if self.procedure != "injection" or not isinstance(robot, CurvedTipRobot):
            raise ScenarioError("needle", "curved", "the injection on a robot fitted with it")
        n = self.needle
        return curved_injection(robot, eye, pts, self.visits, n.directions, n.tolerance,
                                self.steps)  # fmt: skip

    def with_method(self, method: str) -> Scenario:
        """The same scenario run with another method."""
        if method not in METHODS:
            raise InvalidInputError("method", method, f"one of {METHODS}")
        return _replace(self, method=method)

    def with_robot(self, robot: str) -> Scenario:
        """The same scenario with another robot, a name or a robot file (the eye is placed for
        it). ScenarioError if the scenario states a point or direction in its own robot's base
        frame: it names no place on another robot (points in the eye frame go with the eye)."""
        robot = check_robot(robot)
        stated = self._base_frame_values() if robot != self.robot else []
        if stated:
            key, value, instead = stated[0]
            why = f"the scenario states it in the base frame of its own robot, {self.robot}"
            raise ScenarioError(key, value, f"{instead} to run on robot {robot}: {why}")
        return _replace(self, robot=robot)

    def _base_frame_values(self) -> list[tuple[str, Any, str]]:
        """(key, value in the file's unit, what would run on another robot) of each point or
        direction this scenario states in its robot's base frame."""
        out: list[tuple[str, Any, str]] = []
        if self.point_frame == "base":
            out += [(f"[points] {k}_mm", [round(x / MM, 9) for x in v],
                     'the point in the eye frame ([points] frame = "eye")')
                    for k, v in self.point_overrides.items()]  # fmt: skip
        contacts = self.method_settings.extra.get("contacts_mm")
        if contacts:
            out.append(("[qp] contacts_mm", contacts, "no contact points"))
        if self.needle.directions is not None:
            out.append(("[lateral] directions", self.needle.directions, "no directions"))
        return out

    def with_plant(self, plant: str) -> Scenario:
        """The same scenario on another plant."""
        if plant not in PLANTS:
            raise InvalidInputError("plant", plant, f"one of {sorted(PLANTS)}")
        return _replace(self, plant=plant)


def _replace(s: Scenario, **changes: Any) -> Scenario:
    from dataclasses import replace

    return replace(s, **changes)


def scenario_from_dict(data: dict[str, Any], folder: Path | None = None) -> Scenario:
    """A Scenario from a parsed TOML table; raises ScenarioError naming the bad key. A robot
    file named by a relative path is found from `folder` (the scenario file's), if given."""
    sec = sections(data)
    top, eye, pts, st, ctl, sp, nd, lat = (
        sec[k] for k in ("", "eye", "points", "steps", "controller", "spiral", "needle", "lateral")
    )
    procedure = top.get("procedure", "injection")
    if procedure not in PROCEDURES:
        raise ScenarioError("procedure", procedure, f"one of {PROCEDURES}")
    plant = top.get("plant", "kinematic")
    if plant not in PLANTS:
        raise ScenarioError("plant", plant, f"one of {sorted(PLANTS)}")
    robot = _robot(top.get("robot", "iramis"), folder)
    method = ctl.get("method", "pinv")
    if method not in METHODS:
        raise ScenarioError("[controller] method", method, f"one of {METHODS}")
    visits = pts.pop("visits", DEFAULT_VISITS)
    unknown = sorted(set(visits) - set(POINT_NAMES[2:]))
    if unknown:
        raise ScenarioError("[points] visits", unknown, f"names among {POINT_NAMES[2:]}")
    eye_opts = {
        "radius": eye.get("radius_mm", 12.0) * MM,
        "wall": eye.get("wall_mm", 1.0) * MM,
        "trocar_radius": eye.get("trocar_radius_mm", 0.45) * MM,
        "trocar_offset": tuple(v * MM for v in eye.get("trocar_offset_mm", (-8.0, 0.0, 0.0))),
        "insertion_angles": eye.get("insertion_angles_rad", (0.05, 0.12)),
    }
    point_opts = {
        "outside": pts.get("outside_mm", 5.0) * MM,
        "depth": pts.get("depth_mm", 8.0) * MM,
        "spread": pts.get("spread_rad", 0.12),
    }
    overrides = {n: tuple(v * MM for v in pts[f"{n}_mm"]) for n in POINT_NAMES if f"{n}_mm" in pts}
    point_frame = pts.get("frame", "base")  # checked by Scenario
    tol = Tolerance(ctl.get("tolerance_position_m", 1e-8), ctl.get("tolerance_angle_rad", 1e-7))
    settings = MethodSettings(
        K=ctl.get("K", (1.0,) * 6), damping=ctl.get("damping", 1e-4), tolerance=tol, extra=sec["qp"]
    )
    sp_opts = {
        "offset": tuple(v * MM for v in sp.get("offset_mm", (1.0, 0.5))),
        "radius": sp.get("radius_mm", 2.5) * MM,
        "turns": sp.get("turns", 3.0),
        "pitch": sp.get("pitch_mm", 0.5) * MM,
        "points_per_turn": sp.get("points_per_turn", 120),
    }
    return Scenario(
        name=top.get("name", "unnamed"),
        procedure=procedure,
        plant=plant,
        method=method,
        robot=robot,
        eye_options=eye_opts,
        point_options=point_opts,
        point_overrides=overrides,
        point_frame=point_frame,
        visits=visits,
        steps=Steps(
            check_step(st.get("position_mm", 0.2), tol.position) * MM,
            st.get("angle_mrad", 2.0) * 1e-3,
        ),
        method_settings=settings,
        loop=LoopSettings(
            ctl.get("max_iterations", LoopSettings.max_iterations),
            ctl.get("drift_correction", True),
            rcm_bound=ctl.get("rcm_bound_um", 45.0) * 1e-6,
            rcm_tolerance=ctl.get("rcm_tolerance_um", 0.8) * 1e-6,
        ),
        spiral=Spiral(**sp_opts),
        dt=ctl.get("dt_s", 1e-3),
        needle=_needle(nd, lat),
    )


def _robot(robot: str, folder: Path | None) -> str:
    """A robot name, or a robot file's path (relative paths from `folder`)."""
    if is_robot_file(robot) and folder is not None and not Path(robot).is_absolute():
        robot = str(folder / robot)
    try:
        return check_robot(robot)
    except InvalidInputError as exc:
        raise ScenarioError("robot", robot, exc.valid) from exc


def _needle(nd: dict[str, Any], lat: dict[str, Any]) -> NeedleOptions:
    """[needle] and [lateral] as NeedleOptions (kind, R, alpha, directions, tolerance)."""
    kind = nd.get("kind", "straight")
    if kind not in ("straight", "curved"):
        raise ScenarioError("[needle] kind", kind, "'straight' or 'curved'")
    return NeedleOptions(
        kind=kind,
        radius=nd.get("radius_mm", NeedleOptions.radius * 1e3) * MM,
        arc_angle=nd.get("arc_angle_rad", NeedleOptions.arc_angle),
        directions=lat.get("directions"),
        tolerance=lat.get("tolerance_mrad", NeedleOptions.tolerance * 1e3) * 1e-3,
    )


def load_scenario(source: str | Path) -> Scenario:
    """Load a scenario by registered name or from a TOML file path."""
    if not isinstance(source, str | PathLike):
        raise ScenarioError("scenario", source, f"a TOML file path or one of {scenario_names()}")
    text = _read(source)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError("scenario file", str(source), f"valid TOML ({exc})") from exc
    except RecursionError as exc:  # arrays or tables nested thousands deep
        raise ScenarioError("scenario file", str(source), "TOML nested less deeply") from exc
    shipped = str(source) in scenario_names()
    return scenario_from_dict(data, None if shipped else Path(source).parent)


MAX_FILE_BYTES = 1 << 20  # a scenario is a few hundred bytes; the shipped ones are under 2 KiB


def _read(source: str | Path) -> str:
    name = str(source)
    if name in scenario_names():
        return shipped_text(name)
    path = Path(source)
    if not path.is_file():
        valid = f"a TOML file or one of {scenario_names()}"
        if name.endswith(".toml") or len(path.parts) > 1:  # a file meant
            valid += f"; there is no file {str(path.absolute())!r}"
        else:
            valid += did_you_mean(name, scenario_names())
        raise ScenarioError("scenario", name, valid)
    try:
        with open(path, "rb") as fh:
            data = fh.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise ScenarioError("scenario file", name, f"a readable file ({exc.strerror})") from exc
    if len(data) > MAX_FILE_BYTES:
        raise ScenarioError("scenario file", name, f"at most {MAX_FILE_BYTES:,} bytes")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        byte = data[exc.start : exc.start + 1].hex()
        valid = f"UTF-8 text (byte 0x{byte} at offset {exc.start} is not)"
        raise ScenarioError("scenario file", name, valid) from exc
