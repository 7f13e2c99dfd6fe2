"""The scenario file's schema: every section and key with its kind and range, and the checks
that turn a parsed TOML table into validated values (still in the file's units).

A value is refused here, naming the key and the valid range, whenever the run would refuse it
before any motion: a boolean where a number belongs (TOML's `true` is a Python bool, and a
bool is an int), a step the loop would not take, a visit list longer than a run may plan.
"""

from __future__ import annotations

import math
from typing import Any

from rcmplan.control.phase import MAX_TARGETS, LoopSettings
from rcmplan.exceptions import InvalidInputError, ScenarioError, did_you_mean
from rcmplan.scene.eye import POINT_NAMES

# The loop refuses an RCM phase whose targets' tips jump farther than this [m] (between two
# targets, and from where the tip stopped to the phase's first target), so a plan's steps
# cannot be longer: `[steps] position_mm` is at most this, less the tip's position tolerance.
MAX_JUMP_M: float = LoopSettings().max_target_step or math.inf
# Each visit plans at least two targets (to the point and back to p3).
MAX_VISITS = MAX_TARGETS // 2

# section -> key -> (kind, low, high); kind: "float", "int", "bool", "str", "vecN", "strlist",
# "vec3list"
SCHEMA: dict[str, dict[str, tuple[str, float, float]]] = {
    "": {"name": ("str", 0, 0), "procedure": ("str", 0, 0), "plant": ("str", 0, 0),
         "robot": ("str", 0, 0), "description": ("str", 0, 0)},
    "eye": {"radius_mm": ("float", 3, 20), "wall_mm": ("float", 0.1, 3),
            "trocar_radius_mm": ("float", 0.05, 2), "trocar_offset_mm": ("vec3", -60, 60),
            "insertion_angles_rad": ("vec2", -1.2, 1.2)},
    "points": {"outside_mm": ("float", 0.5, 30), "depth_mm": ("float", 0.5, 24),
               "spread_rad": ("float", 0, 0.6), "visits": ("strlist", 1, MAX_VISITS),
               "frame": ("str", 0, 0),
               **{f"{n}_mm": ("vec3", -500, 500) for n in POINT_NAMES}},
    "steps": {"position_mm": ("float", 1e-4, MAX_JUMP_M * 1e3),
              "angle_mrad": ("float", 1e-3, 100)},
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


def is_number(v: Any) -> bool:
    """True for an int (not a bool: TOML's `true` is one) or a finite float."""
    return (isinstance(v, int) and not isinstance(v, bool)) or (
        isinstance(v, float) and math.isfinite(v)
    )


def check(section: str, key: str, value: Any) -> Any:
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
        if not isinstance(value, list) or not lo <= len(value) <= hi:
            raise ScenarioError(where, _sized(value), f"a list of {lo:g} to {hi:,.0f} names")
        if not all(isinstance(v, str) for v in value):
            raise ScenarioError(where, _sized(value), "a list of point names")
        return tuple(value)
    if kind == "vec3list":
        if not isinstance(value, list) or not value:
            raise ScenarioError(where, value, "a non-empty list of [x, y, z] lists")
        return tuple(check_vec(where, v, 3, lo, hi) for v in value)
    if kind == "int":
        if not isinstance(value, int) or isinstance(value, bool) or not lo <= value <= hi:
            raise ScenarioError(where, value, f"an integer in [{lo:g}, {hi:g}]")
        return value
    n = int(kind[3:]) if kind.startswith("vec") else 1
    out = check_vec(where, value, n, lo, hi)
    return out[0] if n == 1 else out


def _sized(value: Any) -> Any:
    """value, or for a long list its length (an error message quotes it)."""
    long = isinstance(value, list) and len(value) > 20
    return f"a list of {len(value):,} items" if long else value


def check_vec(where: str, value: Any, n: int, lo: float, hi: float) -> tuple[float, ...]:
    """n numbers in [lo, hi] as a tuple of floats, else ScenarioError."""
    items = value if isinstance(value, list) and n > 1 else [value]
    if not (len(items) == n and all(is_number(v) for v in items)):
        want = "a number" if n == 1 else f"a list of {n} numbers"
        raise ScenarioError(where, value, f"{want} in [{lo:g}, {hi:g}]")
    if any(not lo <= v <= hi for v in items):  # compared before any int becomes a float
        raise ScenarioError(
            where, value, f"{'a number' if n == 1 else 'numbers'} in [{lo:g}, {hi:g}]"
        )
    return tuple(float(v) for v in items)


def check_qp(key: str, value: Any) -> Any:
    """Validate one [qp] option as the QP controller will read it; numbers must be numbers
    (the QP's own reader would take `true` as 1 and "5" as 5)."""
    from rcmplan.control.qp_backends import check_backend
    from rcmplan.control.qp_limits import EXTRA_KEYS, QpLimits

    where = f"[qp] {key}"
    if key in EXTRA_KEYS and not is_number(value):
        raise ScenarioError(where, value, "a number")
    points = value if key == "contacts_mm" and isinstance(value, list) else []
    if not all(isinstance(p, list) and all(is_number(v) for v in p) for p in points):
        raise ScenarioError(where, value, "a list of points [x, y, z] of numbers in mm")
    try:
        if key == "solver":
            return check_backend(value)
        QpLimits.from_extra({key: value})
    except InvalidInputError as exc:
        raise ScenarioError(where, value, exc.valid) from exc
    return value


def sections(data: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """Split and validate the TOML table into checked sections."""
    out: dict[str, dict[str, Any]] = {s: {} for s in SCHEMA}
    for key, value in data.items():
        if isinstance(value, dict):
            if key not in SCHEMA or key == "":
                names = sorted(k for k in SCHEMA if k)
                raise ScenarioError("section", key, f"one of {names}{did_you_mean(key, names)}")
            for k, v in value.items():
                if key == "qp":
                    out["qp"][k] = check_qp(k, v)
                    continue
                if k not in SCHEMA[key]:
                    names = sorted(SCHEMA[key])
                    raise ScenarioError(f"[{key}] key", k,
                                        f"one of {names}{did_you_mean(k, names)}")  # fmt: skip
                out[key][k] = check(key, k, v)
        elif key in SCHEMA[""]:
            out[""][key] = check("", key, value)
        else:
            names = sorted(SCHEMA[""])
            close = did_you_mean(key, [*names, *(k for k in SCHEMA if k)])
            raise ScenarioError("key", key, f"one of {names} or a section{close}")
    return out


def check_step(position_mm: float, tolerance_position_m: float) -> float:
    """The plan's tip step in [mm], refused when the loop would refuse the plan: a phase's
    first target lies one step from where the tip stopped, which is within the position
    tolerance per axis (sqrt(3) x tolerance in distance), and the loop takes no jump above
    MAX_JUMP_M. Steps are equal divisions, longer than the step by at most 1e-9 of it."""
    largest_mm = (MAX_JUMP_M - math.sqrt(3.0) * tolerance_position_m) / (1.0 + 1e-9) * 1e3
    if position_mm > largest_mm:
        valid = (
            f"at most {largest_mm:.6g} mm: the loop refuses a tip jump above "
            f"{MAX_JUMP_M * 1e3:g} mm between targets, and a phase starts within sqrt(3) x "
            f"tolerance_position_m = {math.sqrt(3.0) * tolerance_position_m * 1e3:.3g} mm of "
            "the last target"
        )
        raise ScenarioError("[steps] position_mm", position_mm, valid)
    return position_mm
