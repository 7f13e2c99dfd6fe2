"""The arguments of `Controller`, checked before it is built."""

from __future__ import annotations

from typing import Any

from rcmplan._validate import has_methods, instance
from rcmplan.control.phase import LoopSettings
from rcmplan.control.plant import check_plant
from rcmplan.control.solvers import Solver
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.checks import robot_model


def check_controller_args(
    plant: Any, solver: Any, free_solver: Any, settings: Any, runner: Any, robot: Any
) -> None:
    """Raise InvalidInputError naming the first argument of `Controller` that is not valid."""
    check_plant("plant", plant)
    check_solver("solver", solver)
    if free_solver is not None:
        check_solver("free_solver", free_solver)
    if settings is not None:
        instance("settings", settings, LoopSettings, "LoopSettings or None (the defaults)")
    if runner is not None:
        has_methods("runner", runner, ("run_phase", "check_targets"), "a runner or None")
    if robot is not None:
        robot_model("robot", robot)
        if len(robot.lower) != len(plant.robot.lower):
            valid = f"a model of the plant's {len(plant.robot.lower)} actuators"
            raise InvalidInputError("robot", getattr(robot, "name", robot), valid)


def check_solver(name: str, solver: Any) -> Solver:
    """solver if it is a step solver, else InvalidInputError naming `name`."""
    methods = ("error", "step", "tolerance")
    ok = all(callable(getattr(solver, m, None)) for m in methods)
    if (
        not ok
        or not isinstance(getattr(solver, "name", None), str)
        or getattr(solver, "kind", None) not in ("rcm", "free")
    ):
        valid = "a step solver (rcmplan.PinvSolver, DlsSolver, QpSolver, TipSolver)"
        raise InvalidInputError(name, solver, valid)
    checked: Solver = solver
    return checked
