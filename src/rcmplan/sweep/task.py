"""One target's job: from p3 on the trocar axis to a retina target and back, measured.

The plant starts at the closed-form pose that puts the tip at p3 with the RCM at the trocar
(solve_pose), instead of re-running approach, align and insert; then the Controller runs two
RCM phases of straight-line targets (line_targets): p3 -> target and target -> p3. The result is
a pure function of (motion settings, target): the same on any executor, wall time aside.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, fields
from typing import Any

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.analysis.metrics import phase_metrics
from rcmplan.control.methods import make_solver
from rcmplan.control.phase import Phase
from rcmplan.control.plant import Plant
from rcmplan.control.targets import rcm_target, solve_pose
from rcmplan.controller import Controller
from rcmplan.exceptions import (
    ConvergenceError,
    RcmBoundError,
    RcmplanError,
    SingularPoseError,
    SliderLimitError,
    UnreachableTargetError,
)
from rcmplan.robot.model import RobotModel
from rcmplan.scene.eye import Eye, default_points
from rcmplan.scene.procedures import line_targets
from rcmplan.sim.registry import make_plant
from rcmplan.sweep.sampling import start_point
from rcmplan.sweep.settings import MotionSettings

# A stopped motion's status is its error's, as a run's summary names it (`RcmplanError.status`):
# those a sweep's motions meet, then the base class's ("error"). `report.summary` counts each,
# and any other error's status a motion reports.
STATUSES = ("ok", *(e.status for e in (ConvergenceError, UnreachableTargetError,
            SingularPoseError, SliderLimitError, RcmBoundError, RcmplanError)))  # fmt: skip
TargetItem = tuple[int, Sequence[float]]


@dataclass(frozen=True)
class TargetResult:
    """Figures of one target's motion; lengths in [m], time in [s].

    Attributes:
        id: Target id (its index in the sample).
        status: One of STATUSES ("ok" when both phases converged).
        iterations: Control iterations spent, both phases (the partial count on failure).
        max_rcm_deviation_m: Largest distance of the RCM point from the trocar over the motion.
        tip_error_m: Tip distance from the retina target at the end of the inward phase (from
            the current step's target when the motion stopped early); None without records.
        wall_time_s: Wall time of the motion; excluded from identity comparisons.
        message: The error message when status is not "ok".
    """

    id: int
    status: str
    iterations: int
    max_rcm_deviation_m: float | None
    tip_error_m: float | None
    wall_time_s: float
    message: str = ""

    @property
    def converged(self) -> bool:
        """True when both phases converged."""
        return self.status == "ok"

    def identity(self) -> tuple[Any, ...]:
        """Every field except wall time: equal on any executor for the same settings."""
        return tuple(getattr(self, f.name) for f in fields(self) if f.name != "wall_time_s")

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON-ready dictionary."""
        return asdict(self)

    @staticmethod
    def from_dict(data: dict[str, Any]) -> TargetResult:
        """Inverse of as_dict; raises KeyError or TypeError on a malformed record."""
        names = [f.name for f in fields(TargetResult)]
        missing = [n for n in names if n not in data]
        if missing or set(data) - set(names):
            raise KeyError(f"fields {sorted(data)} differ from {names}")
        return TargetResult(**data)


@functools.lru_cache(maxsize=16)
def scene(motion: MotionSettings) -> tuple[RobotModel, Eye, FloatArray, FloatArray]:
    """(robot, eye, start point p3, start actuators), built once per worker process."""
    robot = motion.model()
    eye = motion.eye(robot)
    start = start_point(eye, motion)
    pose = solve_pose(robot, rcm_target(start, eye.port))
    return robot, eye, start, robot.actuators_from_joints(pose.q)


@functools.lru_cache(maxsize=4)
def _plant(motion: MotionSettings) -> Plant:
    """The motion's plant, built once per worker process and reset for each target."""
    robot, eye, _, _ = scene(motion)
    points = default_points(eye, depth=motion.start_depth)
    return make_plant(motion.plant, robot, scene={"eye": eye, "points": points}, dt=motion.dt)


def motion_phases(motion: MotionSettings, start: FloatArray, target: FloatArray, trocar: FloatArray
                  ) -> list[Phase]:  # fmt: skip
    """The two RCM phases: p3 -> target and target -> p3, straight lines of targets."""
    steps = motion.steps()
    return [
        Phase("to-target", line_targets(start, target, trocar, steps)),
        Phase("to-start", line_targets(target, start, trocar, steps)),
    ]


def run_target(motion: MotionSettings, target_id: int, point: Sequence[float]) -> TargetResult:
    """Run one target's motion through the Controller and measure it."""
    robot, eye, start, sliders = scene(motion)
    target = np.asarray(point, dtype=float)
    t0 = time.perf_counter()
    plant = _plant(motion)
    plant.reset(sliders)
    solver = make_solver(motion.method, motion.method_settings(), robot, plant, eye=eye,
                         dt=motion.dt)  # fmt: skip
    controller = Controller(plant, solver, settings=motion.loop())
    status, message = "ok", ""
    try:
        log = controller.run(motion_phases(motion, start, target, eye.port))
    except RcmplanError as exc:
        status = exc.status
        message = f"{type(exc).__name__}: {exc}"
        log = exc.log if exc.log is not None else controller.log.finish()
    wall = time.perf_counter() - t0
    metrics = phase_metrics(log)
    devs = [m.max_rcm_deviation_m for m in metrics if m.max_rcm_deviation_m is not None]
    return TargetResult(
        id=int(target_id),
        status=status,
        iterations=len(log),
        max_rcm_deviation_m=_finite(max(devs)) if devs else None,
        tip_error_m=_finite(metrics[0].final_tip_error_m) if metrics else None,
        wall_time_s=wall,
        message=message,
    )


def run_chunk(motion: MotionSettings, items: Sequence[TargetItem]) -> list[TargetResult]:
    """run_target on each (id, point) of a chunk, in order (the unit of work of an executor).

    Every chunk runs on the same control path (compiled), so results are identical to the
    last bit whichever process or executor ran them.
    """
    return [run_target(motion, i, p) for i, p in items]


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None
