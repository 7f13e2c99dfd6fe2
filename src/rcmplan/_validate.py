"""Argument checks shared by the public API: types, shapes, finiteness, ranges.

Numbers are real numbers: int, float and numpy's integer and float scalars. Text ("0.1"),
booleans, complex numbers, None and arrays where one number is expected are refused, as are
arrays of text, booleans or objects where numbers are expected: each check raises
InvalidInputError naming the argument, its value and what is valid.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rcmplan.exceptions import InvalidInputError

FloatArray = NDArray[np.float64]
F64 = np.dtype(np.float64)  # the native float64 dtype, one object: tested by identity (fast)
NOT_NUMBERS = (str, bytes, bool, np.bool_, complex, np.complexfloating)
RIGID_TOLERANCE = 1e-6  # largest |R^T R - I| entry of a pose's rotation
SMALL = 16  # vectors up to this length are tested for finiteness by one sum
WORKSPACE_M = 10.0  # a bound on any point a needle robot is asked to reach, in [m]


def _real_array(name: str, value: Any, valid: str) -> FloatArray:
    """value as a float64 array if it holds only real numbers (no text, booleans, objects)."""
    if value.__class__ is np.ndarray and value.dtype is F64:
        return value
    if isinstance(value, str | bytes):
        raise InvalidInputError(name, value, valid)
    try:
        raw = np.asarray(value)
        kind = raw.dtype.kind
        if kind == "O":  # huge ints, None, ragged or mixed sequences
            flat = raw.ravel().tolist() if raw.ndim else [raw.item()]
            if any(isinstance(v, NOT_NUMBERS) or v is None for v in flat):
                raise InvalidInputError(name, value, valid)
        elif kind not in "iuf":  # text, booleans, complex numbers, dates
            raise InvalidInputError(name, value, valid)
        return np.asarray(raw, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        if isinstance(exc, InvalidInputError):
            raise
        raise InvalidInputError(name, value, valid) from exc


def vector(name: str, value: Any, size: int | None = None) -> FloatArray:
    """Return value as a finite 1-D float64 array of the given size, or raise."""
    arr = _real_array(name, value, "a sequence of real numbers")
    if arr.ndim != 1 or (size is not None and arr.shape[0] != size):
        want = f"shape ({size},)" if size is not None else "a 1-D array"
        raise InvalidInputError(name, value, f"{want}, got shape {arr.shape}")
    if arr.shape[0] <= SMALL and math.isfinite(sum(arr.tolist())):
        return arr  # a short vector: one sum is cheaper than np.isfinite (inf or NaN: not finite)
    if not np.isfinite(arr).all():
        raise InvalidInputError(name, value, "finite numbers (no NaN or inf)")
    return arr


def workspace_point(name: str, value: Any) -> FloatArray:
    """Return value as a point (3,) in [m] with every coordinate within +-WORKSPACE_M of the
    robot's base, or raise (beyond it, the distances it enters overflow)."""
    p = vector(name, value, 3)
    if max(map(abs, p.tolist())) > WORKSPACE_M:
        raise InvalidInputError(name, value, f"coordinates within +-{WORKSPACE_M:g} m of the base")
    return p


def matrix(name: str, value: Any, shape: tuple[int, ...]) -> FloatArray:
    """Return value as a finite float64 array of exactly this shape, or raise."""
    arr = _real_array(name, value, "an array of real numbers")
    if arr.shape != shape:
        raise InvalidInputError(name, value, f"shape {shape}, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError(name, value, "finite numbers (no NaN or inf)")
    return arr


def array(name: str, value: Any, ndim: int | tuple[int, ...]) -> FloatArray:
    """Return value as a finite float64 array with `ndim` dimensions (or one of them), or
    raise."""
    arr = _real_array(name, value, "an array of real numbers")
    dims = (ndim,) if isinstance(ndim, int) else ndim
    if arr.ndim not in dims:
        want = " or ".join(f"{d}-D" for d in dims)
        raise InvalidInputError(name, value, f"a {want} array, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError(name, value, "finite numbers (no NaN or inf)")
    return arr


def pose(name: str, value: Any) -> FloatArray:
    """Return value as a (4, 4) rigid transform: a rotation (R^T R = I, det R = +1, to 1e-6)
    and a translation, last row (0, 0, 0, 1); or raise."""
    T = matrix(name, value, (4, 4))
    R = T[:3, :3]
    rigid = np.abs(R).max() <= 1.0 + RIGID_TOLERANCE  # a rotation's entries: no overflow below
    rigid = rigid and np.abs(R.T @ R - np.eye(3)).max() <= RIGID_TOLERANCE and np.linalg.det(R) > 0
    if not rigid or np.abs(T[3] - (0.0, 0.0, 0.0, 1.0)).max() > 0.0:
        valid = "a rigid transform: a rotation (R^T R = I, det R = 1), last row (0, 0, 0, 1)"
        raise InvalidInputError(name, value, valid)
    return T


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
        if isinstance(value, NOT_NUMBERS) or (isinstance(value, np.ndarray) and value.ndim):
            raise TypeError("not a real number")
        x = float(value)
    except (TypeError, ValueError, OverflowError) as exc:
        raise _out_of_range(name, value, low, high, low_open, high_open) from exc
    lo_bad = x <= low if low_open else x < low
    hi_bad = x >= high if high_open else x > high
    if not math.isfinite(x) or lo_bad or hi_bad:
        raise _out_of_range(name, value, low, high, low_open, high_open)
    return x


def _out_of_range(
    name: str, value: Any, low: float, high: float, low_open: bool, high_open: bool
) -> InvalidInputError:
    lb = "(" if low_open else "["
    hb = ")" if high_open else "]"
    return InvalidInputError(name, value, f"a finite number in {lb}{low:g}, {high:g}{hb}")


def integer(name: str, value: Any, low: int, high: int) -> int:
    """Return value as an int in [low, high] (an int or numpy integer, not a bool), or raise."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, int | np.integer):
        raise InvalidInputError(name, value, f"an integer in [{low}, {high}]")
    if not low <= value <= high:
        raise InvalidInputError(name, value, f"an integer in [{low}, {high}]")
    return int(value)


def flag(name: str, value: Any) -> bool:
    """Return value if it is True or False (numpy's too), or raise."""
    if not isinstance(value, bool | np.bool_):
        raise InvalidInputError(name, value, "True or False")
    return bool(value)


def text(name: str, value: Any, choices: tuple[str, ...] | None = None) -> str:
    """Return value if it is a string (one of `choices`, when given), or raise."""
    if not isinstance(value, str) or (choices is not None and value not in choices):
        valid = "a string" if choices is None else "one of " + ", ".join(map(repr, choices))
        raise InvalidInputError(name, value, valid)
    return value


def file_path(name: str, value: Any) -> Path:
    """Return value as a Path if it is a string or path (not empty), or raise."""
    if not isinstance(value, str | os.PathLike) or not str(value):
        raise InvalidInputError(name, value, "a file path (a string or a pathlib.Path)")
    return Path(value)


def instance(name: str, value: Any, kind: type | tuple[type, ...], what: str) -> Any:
    """Return value if it is an instance of `kind`, else raise naming `what` it must be."""
    if not isinstance(value, kind):
        raise InvalidInputError(name, value, what)
    return value


def has_methods(name: str, value: Any, methods: tuple[str, ...], what: str) -> Any:
    """Return value if it has every one of `methods` (callable), else raise naming `what`."""
    if not all(callable(getattr(value, m, None)) for m in methods):
        raise InvalidInputError(name, value, f"{what} (with {', '.join(methods)})")
    return value
