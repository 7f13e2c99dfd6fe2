"""The settings of a run as rows a person reads: (group, setting, value, unit).

Values are shown in the units the scenario files use (mm, mrad, ms), never as Python reprs.
"""

from __future__ import annotations

from typing import Any

from rcmplan.analysis.units import fmt_setting
from rcmplan.robot.iramis import Iramis
from rcmplan.robot.model import RobotModel
from rcmplan.scene.scenario import Scenario

Row = tuple[str, str, str, str]
MM = 1e3


def _mm(v: Any) -> str:
    if isinstance(v, tuple | list):
        return fmt_setting(tuple(float(x) * MM for x in v))
    return fmt_setting(float(v) * MM)


def run_rows(sc: Scenario) -> list[Row]:
    """Procedure, method, plant, controller and loop settings."""
    ms, tol = sc.method_settings, sc.method_settings.tolerance
    rows = [
        ("run", "procedure", sc.procedure, ""),
        ("run", "method", sc.method, ""),
        ("run", "plant", sc.plant, ""),
        ("run", "control period dt", fmt_setting(sc.dt * 1e3), "ms"),
        ("controller", "gains K (diagonal)", fmt_setting(ms.K), ""),
        ("controller", "damping", fmt_setting(ms.damping), "m"),
        ("controller", "loop tolerance, position", fmt_setting(tol.position * 1e9), "nm"),
        ("controller", "loop tolerance, angle", fmt_setting(tol.angle * 1e6), "urad"),
        ("controller", "iteration cap per target", fmt_setting(sc.loop.max_iterations), ""),
        ("controller", "drift correction", fmt_setting(sc.loop.drift_correction), ""),
        ("steps", "position step", _mm(sc.steps.position), "mm"),
        ("steps", "angle step", fmt_setting(sc.steps.angle * 1e3), "mrad"),
    ]
    rows += [("qp", _name_of(k), fmt_setting(v), _unit_of(k)) for k, v in sorted(ms.extra.items())]
    return rows


def _name_of(key: str) -> str:
    """A scenario key without its unit suffix, in words (`retina_margin_mm` -> retina margin)."""
    unit = _unit_of(key).replace("/", "_per_")
    stem = key[: -len(unit) - 1] if unit and key.endswith(f"_{unit}") else key
    return stem.replace("_", " ")


def _unit_of(key: str) -> str:
    """The unit a scenario key names in its suffix (`_mm` -> mm), or ""."""
    if key.endswith("_mm_per_rad"):
        return "mm/rad"
    for unit in ("um", "mm", "mrad", "rad", "s", "m"):
        if key.endswith(f"_{unit}"):
            return unit
    return ""


def scene_rows(sc: Scenario) -> list[Row]:
    """Eye, points and spiral."""
    eye, pts = sc.eye_options, sc.point_options
    rows = [
        ("eye", "radius", _mm(eye.get("radius", 12e-3)), "mm"),
        ("eye", "wall", _mm(eye.get("wall", 1e-3)), "mm"),
        ("eye", "trocar radius", _mm(eye.get("trocar_radius", 0.45e-3)), "mm"),
        ("eye", "trocar offset from the tip at home", _mm(eye.get("trocar_offset", ())), "mm"),
        ("eye", "insertion angles (phi, psi)", fmt_setting(eye.get("insertion_angles")), "rad"),
        ("points", "p1 outside the trocar", _mm(pts.get("outside", 5e-3)), "mm"),
        ("points", "p3 depth on the axis", _mm(pts.get("depth", 8e-3)), "mm"),
        ("points", "spread of p4..p7", fmt_setting(pts.get("spread", 0.12)), "rad"),
    ]
    if sc.procedure == "injection":
        rows.append(("points", "visits", fmt_setting(sc.visits), ""))
    rows += [("points", f"{k} (set)", _mm(v), "mm") for k, v in sc.point_overrides.items()]
    path = getattr(sc, "path_m", ())
    if path:
        first, last = (_mm(tuple(p)) for p in (path[0], path[-1]))
        rows.append(("path", f"{len(path)} tip points, base frame", f"{first} ... {last}", "mm"))
    if sc.procedure == "spiral":
        s = sc.spiral
        rows += [
            ("spiral", "offset from p3 (e1, e2)", _mm(s.offset), "mm"),
            ("spiral", "radius", _mm(s.radius), "mm"),
            ("spiral", "turns", fmt_setting(s.turns), ""),
            ("spiral", "pitch per turn", _mm(s.pitch), "mm"),
            ("spiral", "points per turn", fmt_setting(s.points_per_turn), ""),
        ]
    return rows


def robot_rows(robot: RobotModel) -> list[Row]:
    """The robot's name, needle and actuator limits (iRAM!S: link lengths and PCJM spacing
    too, with the source of each assumption)."""
    rows: list[Row] = [("robot", "name", robot.name, ""),
                       ("robot", "needle length", _mm(robot.needle_length), "mm")]  # fmt: skip
    if isinstance(robot, Iramis):
        p = robot.params
        rows += [("robot", f"l{i}", _mm(getattr(p, f"l{i}")), "mm") for i in range(1, 7)]
        rows.append(("robot", "PCJM slider spacing d (assumed)", _mm(p.pcjm_spacing), "mm"))
    for i, name in enumerate(robot.actuator_names):
        unit, k = ("rad", 1.0) if robot.actuator_units[i] == "rad" else ("mm", MM)
        travel = fmt_setting((robot.lower[i] * k, robot.upper[i] * k))
        speed = fmt_setting(robot.speed[i] * k)
        rows.append(("robot", f"{name} travel; speed", f"{travel}; {speed}/s", unit))
    rows.append(("robot", "singular threshold", fmt_setting(robot.singular_threshold), ""))
    return rows


def settings_rows(sc: Scenario, robot: RobotModel) -> list[Row]:
    """Every setting of a run, grouped."""
    return run_rows(sc) + scene_rows(sc) + robot_rows(robot)
