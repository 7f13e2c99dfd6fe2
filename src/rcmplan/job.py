"""A run of a scenario: plant, method and phases put together, the log measured.

`run_scenario` never loses work: when a run stops early it returns the partial log with
`status` set to the error's status code, `message` to its text (and keeps the exception in
`error`). A run that finishes with a measured motion beyond a bound it states (the QP's limits,
the loop's RCM tolerance: `analysis.limits.broken_bounds`) has status "limit_violated" and a
message naming them, not "ok". An interrupted run (KeyboardInterrupt, or the CLI's SIGTERM)
re-raises the interrupt with the partial result attached as `result`, status "interrupted",
once its controller exists; interrupted before (placing the eye, building the plant and the
solver), it has no record to measure, and the interrupt goes on without a result, at once
(measuring would place the eye again, and loading the compiled kernels that needs can take a
second).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from rcmplan._signals import raise_interrupt
from rcmplan._validate import instance
from rcmplan.analysis.limits import broken_bounds, limit_figures
from rcmplan.analysis.metrics import overall, phase_metrics
from rcmplan.analysis.result import RunResult
from rcmplan.control.log import LogBuilder, RunLog
from rcmplan.control.methods import make_free_solver, make_solver
from rcmplan.control.phase import Phase
from rcmplan.controller import Controller
from rcmplan.exceptions import InvalidInputError, RcmplanError, UnreachableTargetError
from rcmplan.robot.checks import robot_model
from rcmplan.robot.curved import CurvedTipRobot
from rcmplan.robot.model import RobotModel
from rcmplan.robot.names import is_robot_file
from rcmplan.robot.registry import make_robot, summary_fields
from rcmplan.scene.curved_figures import curved_figures
from rcmplan.scene.eye import Eye
from rcmplan.scene.eye_text import in_eye_frame
from rcmplan.scene.scenario import Scenario
from rcmplan.sim.registry import make_plant

__all__ = ["RunResult", "run_scenario"]


def plant_model(robot: RobotModel) -> RobotModel:
    """The model a plant is built for: a curved needle's shaft (the plant moves the robot's
    actuators; the MuJoCo models draw the straight shaft, iRAM!S's the arc too), else the
    robot itself."""
    return robot.base if isinstance(robot, CurvedTipRobot) else robot


def run_scenario(
    scenario: Scenario,
    robot: RobotModel | None = None,
    on_phase: Callable[[Phase], None] | None = None,
) -> RunResult:
    """Run a scenario end to end on its plant with its method and measure it.

    Args:
        on_phase: Called after each finished phase (for progress bars).
    """
    instance("scenario", scenario, Scenario, "a Scenario (load_scenario(NAME or FILE.toml))")
    if robot is not None:
        robot_model("robot", robot)
    if on_phase is not None and not callable(on_phase):
        raise InvalidInputError("on_phase", on_phase, "a function of the finished Phase, or None")
    start = time.perf_counter()
    error: RcmplanError | None = None
    controller: Controller | None = None
    extra: dict[str, Any] = {}
    if robot is None and is_robot_file(scenario.robot):  # where the run's robot was read from
        extra["robot_file"] = summary_fields(scenario.robot)["robot_file"]
    robot = scenario.needle.fit(robot or make_robot(scenario.robot))
    eye: Eye | None = None
    try:
        shaft = plant_model(robot)
        eye = scenario.eye(robot)
        scene = {"eye": eye, "points": scenario.points(eye), "needle_arc": scenario.needle.arc()}
        plant = make_plant(scenario.plant, shaft, scene=scene, dt=scenario.dt)
        plant.reset(robot.home_actuators)
        solver = make_solver(
            scenario.method, scenario.method_settings, robot, plant, eye=eye, dt=scenario.dt
        )
        free = make_free_solver(robot, scenario.method_settings, solver)
        controller = Controller(plant, solver, free, settings=scenario.loop, robot=robot)
        controller.on_phase = on_phase
        log = controller.run(scenario.phases(robot))
        if scenario.needle.kind == "curved":
            extra.update(curved_figures(robot, scenario, eye, log))
    except RcmplanError as exc:
        error = exc
        if isinstance(exc, UnreachableTargetError) and eye is not None:
            error = in_eye_frame(exc, eye)
        log = exc.log if exc.log is not None else LogBuilder.for_robot(robot).finish()
    except BaseException as exc:  # an interrupt carries the records so far, as `result`
        ctl = controller

        def partial(interrupt: KeyboardInterrupt) -> RunResult:
            assert ctl is not None
            why = "interrupted by " + getattr(interrupt, "signal_name", "SIGINT")
            return _result(scenario, robot, ctl, ctl.log.finish(), start, "interrupted", why)

        raise_interrupt(exc, None if ctl is None else partial)
    if error is None:
        return _result(scenario, robot, controller, log, start, "ok", "", extra=extra)
    message = " ".join(f"{type(error).__name__}: {error}".split())
    return _result(scenario, robot, controller, log, start, error.status, message, error, extra)


def _result(
    scenario: Scenario, robot: RobotModel, controller: Controller | None, log: RunLog,
    start: float, status: str, message: str, error: RcmplanError | None = None,
    extra: dict[str, Any] | None = None,
) -> RunResult:  # fmt: skip
    times = controller.phase_times if controller is not None else {}
    paths = controller.phase_paths if controller is not None else {}
    tracking = limit_figures(scenario, robot, log)
    phases = phase_metrics(log, times)
    if status == "ok":  # finished: within the bounds it states, or "limit_violated"
        broken = broken_bounds(scenario, tracking, overall(phases)["max_rcm_deviation_m"])
        if broken:
            status, message = "limit_violated", broken
    return RunResult(
        scenario=scenario,
        log=log,
        phases=phases,
        status=status,
        wall_time_s=time.perf_counter() - start,
        robot=robot,
        error=error,
        message=message,
        extra={**tracking, **execution_paths(paths), **(extra or {})},
    )


def execution_paths(paths: dict[str, str]) -> dict[str, Any]:
    """summary.json's account of the code that moved the robot, from what ran, per phase
    (`Controller.phase_paths`): `execution_path` "compiled" (every phase), "reference" (none,
    or no phase ran) or "mixed", and the names of the compiled phases."""
    kinds = set(paths.values())
    overall = kinds.pop() if len(kinds) == 1 and kinds <= {"compiled", "reference"} else "mixed"
    return {
        "execution_path": overall if paths else "reference",
        "compiled_phases": [name for name, path in paths.items() if path == "compiled"],
    }
