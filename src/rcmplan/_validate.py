"""Argument checks shared by the public API: shapes, finiteness, ranges."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from rcmplan.exceptions import InvalidInputError

FloatArray = NDArray[np.float64]


def vector(name: str, value: Any, size: int | None = None) -> FloatArray:
    """Return value as a finite 1-D float64 array of the given size, or raise."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InvalidInputError(name, value, "a sequence of real numbers") from exc
    if arr.ndim != 1 or (size is not None and arr.shape[0] != size):
        want = f"shape ({size},)" if size is not None else "a 1-D array"
        raise InvalidInputError(name, value, f"{want}, got shape {arr.shape}")
    if not np.isfinite(arr).all():
        raise InvalidInputError(name, value, "finite numbers (no NaN or inf)")
    return arr


def matrix(name: str, value: Any, shape: tuple[int, ...]) -> FloatArray:
    """Return value as a finite float64 array of exactly this shape, or raise."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InvalidInputError(name, value, "an array of real numbers") from exc
    if arr.shape != shape:
        raise InvalidInputError(name, value, f"shape {shape}, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError(name, value, "finite numbers (no NaN or inf)")
    return arr


def scalar(
    name: str,
    value: Any,
    low: float = -np.inf,
    high: float = np.inf,
    *,
    low_open: bool = False,
    high_open: bool = False,
) -> float:
    """Return value as a finite float within [low, high] (open ends on request), or raise."""
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InvalidInputError(name, value, "a real number") from exc
    lo_bad = x <= low if low_open else x < low
    hi_bad = x >= high if high_open else x > high
    if not np.isfinite(x) or lo_bad or hi_bad:
        lb = "(" if low_open else "["
        hb = ")" if high_open else "]"
        raise InvalidInputError(name, value, f"a finite number in {lb}{low:g}, {high:g}{hb}")
    return x
