"""The values of a robot file's [robot] table, read and checked (`robot_file`)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from rcmplan.exceptions import RobotFileError
from rcmplan.robot.arms import NEEDLE_AXES

NEEDLE_LENGTH_MM = 60.0


def number(value: Any) -> bool:
    """An int (not a bool) or a finite float."""
    if isinstance(value, bool):
        return False
    return isinstance(value, int) or (isinstance(value, float) and math.isfinite(value))


def length(path: Path, table: dict[str, Any]) -> float:
    """needle_length_mm in (0, 1000] as metres."""
    value = table.get("needle_length_mm", NEEDLE_LENGTH_MM)
    if not number(value) or not 0.0 < value <= 1000.0:
        raise RobotFileError(path, "needle_length_mm", value, "a number in (0, 1000] mm")
    return float(value) / 1e3


def triple(value: Any) -> bool:
    """A list of three numbers."""
    return isinstance(value, list) and len(value) == 3 and all(number(v) for v in value)


def axis(path: Path, table: dict[str, Any]) -> str | tuple[float, float, float]:
    """needle_axis: one of NEEDLE_AXES, or a non-zero direction [x, y, z] made unit."""
    return _direction(path, "needle_axis", table.get("needle_axis", "+z"))


def bend(path: Path, table: dict[str, Any]) -> str | tuple[float, float, float] | None:
    """needle_bend: one of NEEDLE_AXES, or a non-zero direction [x, y, z] made unit; None when
    absent (`rcmplan.robot.arms.needle_mount` then chooses the bend)."""
    if "needle_bend" not in table:
        return None
    return _direction(path, "needle_bend", table["needle_bend"])


def _direction(path: Path, key: str, value: Any) -> str | tuple[float, float, float]:
    """One of NEEDLE_AXES as written, or a non-zero direction [x, y, z] made unit."""
    if isinstance(value, str) and value in NEEDLE_AXES:
        return value
    if triple(value) and math.hypot(*value) > 1e-9:
        x, y, z = (float(v) / math.hypot(*value) for v in value)
        return (x, y, z)
    valid = "one of " + " ".join(NEEDLE_AXES) + ", or a non-zero direction [x, y, z]"
    raise RobotFileError(path, key, value, valid)


def offset(path: Path, table: dict[str, Any]) -> tuple[float, float, float]:
    """needle_offset_mm: three numbers within 1000 mm, as metres."""
    value = table.get("needle_offset_mm", [0.0, 0.0, 0.0])
    if not triple(value) or max(abs(v) for v in value) > 1000.0:
        raise RobotFileError(path, "needle_offset_mm", value, "[x, y, z], each within 1000 mm")
    x, y, z = (float(v) / 1e3 for v in value)
    return (x, y, z)


def home(path: Path, table: dict[str, Any]) -> tuple[float, ...] | None:
    """home as a tuple of floats, or None when absent."""
    if "home" not in table:
        return None
    value = table["home"]
    if not isinstance(value, list) or not value or not all(number(v) for v in value):
        raise RobotFileError(path, "home", value, "a list of joint values in rad or m")
    return tuple(float(v) for v in value)
