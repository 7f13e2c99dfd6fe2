"""Control methods by name, so commands and scenario files can say `--method dls`.

A method is an RCM step solver built from settings; the free-space solver is always the tip
pseudoinverse. Optional methods (the QP controller) are imported on first use.
"""

from __future__ import annotations

import importlib
from dataclasses import replace
from typing import Any

from rcmplan.choices import CURVED_METHODS, DEFAULT_METHOD, METHODS
from rcmplan.control.method_settings import MethodSettings
from rcmplan.control.resolution import met_tolerance
from rcmplan.control.solvers import DlsSolver, PinvSolver, Solver
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.curved import CurvedTipRobot
from rcmplan.robot.iramis import Iramis
from rcmplan.robot.model import RobotModel

__all__ = ["DEFAULT_METHOD", "METHODS", "MethodSettings", "make_solver"]


def make_solver(
    name: str,
    settings: MethodSettings | None = None,
    robot: RobotModel | None = None,
    plant: Any | None = None,
    **context: Any,
) -> Solver:
    """The RCM step solver called `name`.

    Args:
        name: One of METHODS.
        settings: Gains, damping, tolerance and method-specific options.
        robot: The robot (methods that hold limits need it).
        plant: The plant the solver will drive, or None: its actuator resolution raises the
            tolerance to what it supports (`control.resolution`), and the QP centres its
            speed window on the command its servos follow (`QpSolver`'s `servo`).
        context: Scene context for constrained methods (eye, control period dt, ...).
    """
    cfg = settings or MethodSettings()
    if plant is not None:
        tol = met_tolerance(cfg.tolerance, robot or Iramis(), plant)
        cfg = cfg if tol is cfg.tolerance else replace(cfg, tolerance=tol)
        context["servo"] = plant
    if isinstance(robot, CurvedTipRobot) and robot.needle.curved:
        return _curved_solver(name, cfg, robot, **context)
    if name == "pinv":
        return PinvSolver(K=cfg.K, tol=cfg.tolerance)
    if name == "pinv-thesis":
        return PinvSolver(K=cfg.K, variant="thesis", tol=cfg.tolerance)
    if name == "dls":
        return DlsSolver(damping=cfg.damping, tol=cfg.tolerance)
    if name == "qp":
        qp = importlib.import_module("rcmplan.control.qp")
        solver: Solver = qp.QpSolver.from_settings(cfg, robot or Iramis(), **context)
        return solver
    raise InvalidInputError("method", name, f"one of {METHODS}")


def _curved_solver(name: str, cfg: MethodSettings, robot: RobotModel, **context: Any) -> Solver:
    """The curved needle's solvers (`rcmplan.control.curved`): pinv, DLS and the QP."""
    from rcmplan.control.curved import CurvedDlsSolver, CurvedPinvSolver, gains_from_x_ext

    if name == "pinv":
        return CurvedPinvSolver(K=gains_from_x_ext(cfg.K), tol=cfg.tolerance)
    if name == "dls":
        return CurvedDlsSolver(damping=cfg.damping, tol=cfg.tolerance)
    if name == "qp":
        qp = importlib.import_module("rcmplan.control.qp")
        solver: Solver = qp.QpSolver.from_settings(cfg, robot, **context)
        return solver
    raise InvalidInputError("method", name, f"one of {CURVED_METHODS} for a curved needle")


def make_free_solver(
    robot: RobotModel,
    settings: MethodSettings | None = None,
    solver: Solver | None = None,
) -> Solver | None:
    """The free-space solver for `robot` and its RCM `solver`: the RCM solver's own
    `free_solver()` if it has one (the QP: it holds its limits in every phase), else whole
    poses for a curved needle (its arc must pass the trocar), else None (the controller's
    default, the tip pseudoinverse)."""
    cfg = settings or MethodSettings()
    own = getattr(solver, "free_solver", None)
    if callable(own):
        free: Solver = own()
        return free
    if isinstance(robot, CurvedTipRobot) and robot.needle.curved:
        from rcmplan.control.curved import CurvedPoseSolver

        return CurvedPoseSolver(tol=cfg.tolerance)
    return None
