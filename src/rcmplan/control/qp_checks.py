"""The arguments of `QpSolver` that its own settings checks do not cover, checked first."""

from __future__ import annotations

from typing import Any

from rcmplan._validate import has_methods, instance
from rcmplan.control.eye_model import check_eye
from rcmplan.control.qp_limits import QpLimits
from rcmplan.control.solvers import Tolerance
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.checks import robot_model


def check_qp_args(
    robot: Any,
    eye: Any,
    K: Any,
    tol: Any,
    limits: Any,
    servo: Any,
    extra_limits: Any,
    objectives: Any = (),
) -> None:
    """Raise InvalidInputError naming the first of these arguments that is not valid."""
    robot_model("robot", robot)
    if eye is not None:
        check_eye("eye", eye)
    if not isinstance(K, tuple | list) and not hasattr(K, "shape"):
        raise InvalidInputError("K", K, "six gains in (0, 2) (seven on a curved needle)")
    if tol is not None:
        instance("tol", tol, Tolerance, "a Tolerance or None (the defaults)")
    if limits is not None:
        instance("limits", limits, QpLimits, "QpLimits or None (the defaults)")
    if servo is not None and not hasattr(servo, "exact_commands"):
        raise InvalidInputError("servo", servo, "a plant (stating exact_commands) or None")
    if not isinstance(extra_limits, tuple | list):
        raise InvalidInputError("extra_limits", extra_limits, "a tuple of limits")
    for lim in extra_limits:
        has_methods("extra_limits", lim, ("constraint",), "a tuple of limits")
    if not isinstance(objectives, tuple | list):
        raise InvalidInputError("objectives", objectives, "a tuple of objectives")
    for term in objectives:
        has_methods("objectives", term, ("cost",), "a tuple of objectives (Objective)")
