"""A run of a scenario: plant, method and phases put together, the log measured.

`run_scenario` never loses work: when a run stops early it returns the partial log with
`status` set to the error message (and keeps the exception in `error`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from rcmplan import __version__
from rcmplan.analysis.metrics import PhaseMetrics, overall, phase_metrics, slider_use
from rcmplan.control.log import LogBuilder, RunLog
from rcmplan.control.loop import Controller, Phase
from rcmplan.control.methods import make_free_solver, make_solver
from rcmplan.exceptions import InvalidInputError, RcmplanError
from rcmplan.robot.curved import CurvedTipRobot
from rcmplan.robot.model import RobotModel
from rcmplan.robot.registry import make_robot
from rcmplan.scene.curved_figures import curved_figures
from rcmplan.scene.scenario import Scenario
from rcmplan.sim.registry import make_plant


@dataclass
class RunResult:
    """What a run produced.

    Attributes:
        scenario: The scenario that ran.
        log: The run log (partial when the run stopped early).
        phases: Metrics per phase.
        status: "ok" or the error message.
        error: The exception that stopped the run, if any.
        wall_time_s: Wall time of the whole run (planning, control, measuring) in [s].
    """

    scenario: Scenario
    log: RunLog
    phases: list[PhaseMetrics]
    status: str
    wall_time_s: float
    robot: RobotModel
    error: RcmplanError | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """True when the run finished every phase."""
        return self.status == "ok"

    def summary(self) -> dict[str, Any]:
        """The summary.json contract: scenario, method, plant, status, phases, overall figures."""
        phases = [
            {
                "name": p.name,
                "inside_eye": p.inside_eye,
                "max_rcm_deviation_m": p.max_rcm_deviation_m,
                "rms_rcm_deviation_m": p.rms_rcm_deviation_m,
                "max_rcm_deviation_xyz_m": p.max_rcm_deviation_xyz_m,
                "final_tip_error_m": p.final_tip_error_m,
                "max_tracking_error_m": p.max_tracking_error_m,
                "iterations": p.iterations,
                "steps": p.steps,
                "wall_time_s": p.wall_time_s,
            }
            for p in self.phases
        ]
        return {
            "scenario": self.scenario.name,
            "robot": self.robot.name,
            "needle": self.robot.needle_kind,
            "procedure": self.scenario.procedure,
            "method": self.scenario.method,
            "plant": self.scenario.plant,
            "status": self.status,
            "phases": phases,
            **overall(self.phases),
            "iterations": len(self.log),
            "wall_time_s": self.wall_time_s,
            "sliders": slider_use(self.log, self.robot).as_dict(),
            "rcmplan_version": __version__,
            **self.extra,
        }


def check_curved_plant(robot: RobotModel, plant: str) -> RobotModel:
    """The model a plant is built for: a curved needle's shaft (its MuJoCo model has no arc;
    iRAM!S only), else the robot itself."""
    if not isinstance(robot, CurvedTipRobot):
        return robot
    if plant != "kinematic" and robot.name != "iramis":
        raise InvalidInputError("plant", plant, "'kinematic' for a curved needle on an arm")
    return robot.base


def run_scenario(
    scenario: Scenario,
    robot: RobotModel | None = None,
    on_phase: Callable[[Phase], None] | None = None,
) -> RunResult:
    """Run a scenario end to end on its plant with its method and measure it.

    Args:
        on_phase: Called after each finished phase (for progress bars).
    """
    start = time.perf_counter()
    error: RcmplanError | None = None
    controller: Controller | None = None
    robot = scenario.needle.fit(robot or make_robot(scenario.robot))
    extra: dict[str, Any] = {}
    try:
        shaft = check_curved_plant(robot, scenario.plant)
        eye = scenario.eye(robot)
        scene = {"eye": eye, "points": scenario.points(eye), "needle_arc": scenario.needle.arc()}
        plant = make_plant(scenario.plant, shaft, scene=scene, dt=scenario.dt)
        plant.reset(robot.home_actuators)
        solver = make_solver(
            scenario.method, scenario.method_settings, robot, eye=eye, dt=scenario.dt
        )
        free = make_free_solver(robot, scenario.method_settings)
        controller = Controller(plant, solver, free, settings=scenario.loop, robot=robot)
        controller.on_phase = on_phase
        phases = scenario.phases(robot)
        log = controller.run(phases)
        if scenario.needle.kind == "curved":
            extra = curved_figures(robot, scenario, eye, log)
    except RcmplanError as exc:
        error = exc
        log = exc.log if exc.log is not None else LogBuilder().finish()
    wall = time.perf_counter() - start
    times = controller.phase_times if controller is not None else {}
    return RunResult(
        scenario=scenario,
        log=log,
        phases=phase_metrics(log, times),
        status="ok" if error is None else f"{type(error).__name__}: {error}",
        wall_time_s=wall,
        robot=robot,
        error=error,
        extra=extra,
    )
