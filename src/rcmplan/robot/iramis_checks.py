"""Argument checks of the `Iramis` model: its parameters once, joint vectors and lambda on every
call at the cost of a type test (the controller calls the kinematics thousands of times per
run: a float64 array of shape (6,) and a float pass through, anything else is checked in full,
and non-finite values show as a non-finite result, which the caller tests)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from rcmplan._validate import F64, FloatArray, scalar, vector
from rcmplan.exceptions import InvalidInputError

LENGTH_M = 1.0  # a bound on |l1|..|l6| and the PCJM spacing, in [m]
LAM_VALID = "a finite number: 0 at the needle base, 1 at the tip, beyond them its line"


def joints(q: Any, name: str = "q") -> FloatArray:
    """q as a float64 array (6,) for the kernels; InvalidInputError unless it holds 6 real
    numbers (a float64 array passes unchecked for finiteness: the caller tests the result)."""
    if q.__class__ is np.ndarray and q.dtype is F64 and q.shape == (6,):
        return q
    return vector(name, q, 6)


def lam(value: Any) -> float:
    """lambda as a float: a float passes (NaN shows in the result), any other real number is
    converted; text, booleans and non-finite values raise InvalidInputError naming lam."""
    if value.__class__ is float:
        return float(value)
    return scalar("lam", value)


def invalid_point(q: Any, lam_value: Any) -> None:
    """Raise InvalidInputError naming the argument of needle_point that is not valid."""
    vector("q", q, 6)
    scalar("lam", lam_value)
    raise InvalidInputError(
        "(q, lam)", (q, lam_value), "joints and lambda whose needle point is finite (|lam| and "
        "the prismatic joints far below 1e300)",
    )  # fmt: skip


def check_finite(value: float, q: Any, name: str = "q") -> None:
    """Raise InvalidInputError naming q when a result of q is not finite."""
    if not math.isfinite(value):
        vector(name, q, 6)  # names the non-finite entry
        raise InvalidInputError(name, q, "joints whose result is finite (far below 1e300)")


def checked_parameters(p: Any) -> dict[str, Any]:
    """An `IramisParameters`' values as floats and tuples of floats, or InvalidInputError for
    a geometry or travel that is not finite or out of range (before any kinematics)."""
    out: dict[str, Any] = {
        name: scalar(name, getattr(p, name), -LENGTH_M, LENGTH_M)
        for name in ("l1", "l2", "l3", "l4", "l5")
    }
    out["l6"] = scalar("l6", p.l6, 0.0, LENGTH_M, low_open=True)
    out["pcjm_spacing"] = scalar("pcjm_spacing", p.pcjm_spacing, 0.0, LENGTH_M, low_open=True)
    lower = vector("slider_lower", p.slider_lower, 6)
    upper = vector("slider_upper", p.slider_upper, 6)
    if np.any(lower >= upper):
        i = int(np.argmax(lower >= upper))
        valid = f"slider travel with slider_upper above slider_lower (not at slider {i})"
        pair = (float(lower[i]), float(upper[i]))
        raise InvalidInputError(f"(slider_lower, slider_upper)[{i}]", pair, valid)
    speed = vector("slider_speed", p.slider_speed, 6)
    if np.any(speed <= 0.0):
        valid = "a positive slider speed for each of the six sliders"
        raise InvalidInputError("slider_speed", p.slider_speed, valid)
    out |= {"slider_lower": tuple(lower.tolist()), "slider_upper": tuple(upper.tolist()),
            "slider_speed": tuple(speed.tolist())}  # fmt: skip
    out["slider_resolution"] = scalar("slider_resolution", p.slider_resolution, 0.0, 1e-3,
                                      low_open=True)  # fmt: skip
    out["singular_threshold"] = scalar("singular_threshold", p.singular_threshold, 0.0, 1.0,
                                       high_open=True)  # fmt: skip
    return out
