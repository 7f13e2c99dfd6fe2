"""Scenarios: eye, points, procedure and controller settings, from TOML files validated on load.

Keys carry their unit (`radius_mm`, `angle_mrad`); values are converted to SI on load. Every
error names the section and key and the allowed values or range. Scenarios shipped with rcmplan
are registered by name (`rcmplan.scene.scenario.SCENARIOS`): `default` (the injection) and
`spiral`, plus the constrained scenarios for the QP controller.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from rcmplan.control.methods import METHODS, MethodSettings
from rcmplan.control.phase import LoopSettings, Phase
from rcmplan.control.solvers import Tolerance
from rcmplan.exceptions import InvalidInputError, ScenarioError
from rcmplan.robot.curved import CurvedTipRobot
from rcmplan.robot.model import RobotModel
from rcmplan.robot.registry import check_robot, is_robot_file
from rcmplan.scene.curved_procedure import NeedleOptions, curved_injection
from rcmplan.scene.eye import POINT_NAMES, Eye, EyePoints, default_eye, default_points
from rcmplan.scene.procedures import DEFAULT_VISITS, Spiral, Steps, injection, spiral

PROCEDURES = ("injection", "spiral")
# The plants a scenario may name; `rcmplan.sim.registry.PLANTS` builds each (a test checks that
# the two agree). Named here so that scenes do not import the simulators.
PLANTS = ("kinematic", "mujoco", "mujoco-kinematic")
MM = 1e-3

# section -> key -> (kind, low, high); kind: "float", "int", "bool", "str", "vecN", "strlist"
SCHEMA: dict[str, dict[str, tuple[str, float, float]]] = {
    "": {"name": ("str", 0, 0), "procedure": ("str", 0, 0), "plant": ("str", 0, 0),
         "robot": ("str", 0, 0), "description": ("str", 0, 0)},
    "eye": {"radius_mm": ("float", 3, 20), "wall_mm": ("float", 0.1, 3),
            "trocar_radius_mm": ("float", 0.05, 2), "trocar_offset_mm": ("vec3", -60, 60),
            "insertion_angles_rad": ("vec2", -1.2, 1.2)},
    "points": {"outside_mm": ("float", 0.5, 30), "depth_mm": ("float", 0.5, 24),
               "spread_rad": ("float", 0, 0.6), "visits": ("strlist", 0, 0),
               **{f"{n}_mm": ("vec3", -500, 500) for n in POINT_NAMES}},
    "steps": {"position_mm": ("float", 1e-4, 5), "angle_mrad": ("float", 1e-3, 100)},
    "controller": {"method": ("str", 0, 0), "K": ("vec6", 1e-9, 1.999999),
                   "damping": ("float", 1e-6, 10), "tolerance_position_m": ("float", 1e-13, 1e-4),
                   "tolerance_angle_rad": ("float", 1e-13, 1e-3),
                   "max_iterations": ("int", 1, 100000), "drift_correction": ("bool", 0, 0),
                   "rcm_bound_um": ("float", 0.01, 10000),
                   "rcm_tolerance_um": ("float", 0.001, 1000),
                   "dt_s": ("float", 1e-5, 0.1)},
    "spiral": {"offset_mm": ("vec2", -10, 10), "radius_mm": ("float", 0.01, 10),
               "turns": ("float", 0.1, 50), "pitch_mm": ("float", -5, 5),
               "points_per_turn": ("int", 8, 10000)},
    "needle": {"kind": ("str", 0, 0), "radius_mm": ("float", 1, 1000),
               "arc_angle_rad": ("float", 0, 1.5707963)},
    "lateral": {"directions": ("vec3list", -1e3, 1e3), "tolerance_mrad": ("float", 1e-3, 3141.59)},
    "qp": {},  # method-specific options, passed through to the QP controller as extra
}  # fmt: skip


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
    visits: tuple[str, ...] = DEFAULT_VISITS
    steps: Steps = field(default_factory=Steps)
    method_settings: MethodSettings = field(default_factory=MethodSettings)
    loop: LoopSettings = field(default_factory=LoopSettings)
    spiral: Spiral = field(default_factory=Spiral)
    dt: float = 1e-3
    needle: NeedleOptions = field(default_factory=NeedleOptions)

    def eye(self, robot: RobotModel) -> Eye:
        """The eye placed for this robot."""
        return default_eye(robot, **self.eye_options)

    def points(self, eye: Eye) -> EyePoints:
        """The seven named points, defaults overridden by explicit ones."""
        pts = default_points(eye, **self.point_options).as_dict()
        pts.update({k: np.asarray(v, dtype=float) for k, v in self.point_overrides.items()})
        return EyePoints(**pts)

    def phases(self, robot: RobotModel) -> list[Phase]:
        """The procedure's phases, every target checked before motion."""
        eye = self.eye(robot)
        pts = self.points(eye)
        if self.needle.kind == "curved":
            return self._curved_phases(self.needle.fit(robot), eye, pts)
        if self.procedure == "spiral":
            return spiral(robot, eye, pts, self.spiral, self.steps)
        return injection(robot, eye, pts, self.steps, self.visits)

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
        it)."""
        return _replace(self, robot=check_robot(robot))

    def with_plant(self, plant: str) -> Scenario:
        """The same scenario on another plant."""
        if plant not in PLANTS:
            raise InvalidInputError("plant", plant, f"one of {sorted(PLANTS)}")
        return _replace(self, plant=plant)


def _replace(s: Scenario, **changes: Any) -> Scenario:
    from dataclasses import replace

    return replace(s, **changes)


def _check(section: str, key: str, value: Any) -> Any:
    """Validate one value against the schema; return it converted."""
    where = f"[{section}] {key}" if section else key
    kind, lo, hi = SCHEMA[section][key]
    if kind == "str":
        if not isinstance(value, str):
            raise ScenarioError(where, value, "a string")
        return value
    if kind == "bool":
        if not isinstance(value, bool):
            raise ScenarioError(where, value, "true or false")
        return value
    if kind == "strlist":
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise ScenarioError(where, value, "a list of point names")
        return tuple(value)
    if kind == "vec3list":
        if not isinstance(value, list) or not value:
            raise ScenarioError(where, value, "a non-empty list of [x, y, z] lists")
        return tuple(_check_vec(where, v, 3, lo, hi) for v in value)
    if kind == "int":
        if not isinstance(value, int) or isinstance(value, bool) or not lo <= value <= hi:
            raise ScenarioError(where, value, f"an integer in [{lo:g}, {hi:g}]")
        return value
    n = int(kind[3:]) if kind.startswith("vec") else 1
    out = _check_vec(where, value, n, lo, hi)
    return out[0] if n == 1 else out


def _check_vec(where: str, value: Any, n: int, lo: float, hi: float) -> tuple[float, ...]:
    """n numbers in [lo, hi] as a tuple of floats, else ScenarioError."""
    items = value if isinstance(value, list) and n > 1 else [value]
    numbers = len(items) == n and all(
        (isinstance(v, int) and not isinstance(v, bool))
        or (isinstance(v, float) and math.isfinite(v))
        for v in items
    )  # ints of any size are finite, and compare exactly with the bounds below
    if not numbers:
        want = "a number" if n == 1 else f"a list of {n} numbers"
        raise ScenarioError(where, value, f"{want} in [{lo:g}, {hi:g}]")
    if any(not lo <= v <= hi for v in items):  # compared before any int becomes a float
        raise ScenarioError(
            where, value, f"{'a number' if n == 1 else 'numbers'} in [{lo:g}, {hi:g}]"
        )
    return tuple(float(v) for v in items)


def _check_qp(key: str, value: Any) -> Any:
    """Validate one [qp] option as the QP controller will read it."""
    from rcmplan.control.qp_backends import check_backend
    from rcmplan.control.qp_limits import QpLimits

    try:
        if key == "solver":
            return check_backend(value)
        QpLimits.from_extra({key: value})
    except InvalidInputError as exc:
        raise ScenarioError(f"[qp] {key}", value, exc.valid) from exc
    return value


def _sections(data: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """Split and validate the TOML table into checked sections."""
    out: dict[str, dict[str, Any]] = {s: {} for s in SCHEMA}
    for key, value in data.items():
        if isinstance(value, dict):
            if key not in SCHEMA or key == "":
                raise ScenarioError("section", key, f"one of {sorted(k for k in SCHEMA if k)}")
            for k, v in value.items():
                if key == "qp":
                    out["qp"][k] = _check_qp(k, v)
                    continue
                if k not in SCHEMA[key]:
                    raise ScenarioError(f"[{key}] key", k, f"one of {sorted(SCHEMA[key])}")
                out[key][k] = _check(key, k, v)
        elif key in SCHEMA[""]:
            out[""][key] = _check("", key, value)
        else:
            raise ScenarioError("key", key, f"one of {sorted(SCHEMA[''])} or a section")
    return out


def scenario_from_dict(data: dict[str, Any], folder: Path | None = None) -> Scenario:
    """A Scenario from a parsed TOML table; raises ScenarioError naming the bad key. A robot
    file named by a relative path is found from `folder` (the scenario file's), if given."""
    sec = _sections(data)
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
    if not visits or any(v not in POINT_NAMES[2:] for v in visits):
        raise ScenarioError(
            "[points] visits", list(visits), f"a non-empty list of {POINT_NAMES[2:]}"
        )
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
        visits=visits,
        steps=Steps(st.get("position_mm", 0.2) * MM, st.get("angle_mrad", 2.0) * 1e-3),
        method_settings=settings,
        loop=LoopSettings(
            ctl.get("max_iterations", 100),
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


def shipped_text(name: str) -> str:
    """The TOML text of the scenario shipped as `name`; ScenarioError naming the shipped ones
    when there is none."""
    names = scenario_names()
    if name not in names:
        raise ScenarioError("shipped scenario", name, "one of " + ", ".join(names))
    return resources.files("rcmplan.scenarios").joinpath(f"{name}.toml").read_text()


def _read(source: str | Path) -> str:
    name = str(source)
    if name in scenario_names():
        return shipped_text(name)
    path = Path(source)
    if not path.is_file():
        raise ScenarioError("scenario", name, f"a TOML file or one of {scenario_names()}")
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


def scenario_names() -> list[str]:
    """Names of the scenarios shipped with rcmplan."""
    files = resources.files("rcmplan.scenarios").iterdir()
    return sorted(f.name[:-5] for f in files if f.name.endswith(".toml"))
