"""One teleoperated session: robot, eye, plant, QP with the fixtures, pipeline, and the period.

Each control period reads the plant, runs the pipeline on the latest master sample, and takes
ONE step of the QP solver towards the desired pose (unlike Algorithm 1, which converges on
each target): the target moves every period, and the QP's limits hold the fixtures at every
step. The needle starts inserted through the trocar with its tip at `TeleopSettings.start_tip`
(a pose solved and checked before any motion).
"""

from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np

from rcmplan import servo
from rcmplan._validate import FloatArray
from rcmplan.control.log import LogBuilder
from rcmplan.control.qp import QpSolver
from rcmplan.control.targets import rcm_target, solve_pose
from rcmplan.exceptions import RcmBoundError
from rcmplan.robot.registry import make_robot
from rcmplan.scene.eye import default_eye, default_points, eye_frame
from rcmplan.sim.registry import make_plant
from rcmplan.teleop.pipeline import Pipeline, TargetMaker
from rcmplan.teleop.samples import MasterSample
from rcmplan.teleop.scaling import MotionScaling
from rcmplan.teleop.settings import TeleopSettings
from rcmplan.teleop.trace import TraceBuilder

PHASES = ("released", "engaged")


class TeleopState(NamedTuple):
    """The state after one period, for a viewer (SI units, base frame).

    Attributes:
        t: Plant time [s] at the start of the period.
        tip: Needle tip (3,) [m].
        desired: Desired tip (3,) [m] (what the hand asks for, before any fixture).
        rcm_deviation: Distance from the trocar to the needle line [m].
        retina_distance: Distance from the tip to the retina [m] (positive inside).
        engaged: The clutch.
        actuators: Actuator positions (n,) (iRAM!S: sliders [m], roll [rad]).
        joints: Joint positions (n,).
    """

    t: float
    tip: FloatArray
    desired: FloatArray
    rcm_deviation: float
    retina_distance: float
    engaged: bool
    actuators: FloatArray
    joints: FloatArray


class Session:
    """Everything one session needs, built and checked before any motion.

    Args:
        settings: The session's settings. The QP step runs compiled where it applies
            (`rcmplan.compiled.qp_period`), in replayed and live sessions alike.
    """

    def __init__(self, settings: TeleopSettings) -> None:
        self.settings = cfg = settings
        self.robot = robot = make_robot(cfg.robot)
        self.eye = eye = default_eye(robot)
        R = eye_frame(eye)
        self.start_tip = eye.center + R @ np.asarray(cfg.start_tip)
        cfg.fixtures.check_start(eye, self.start_tip)
        pose = solve_pose(robot, rcm_target(self.start_tip, eye.port))
        scene = {"eye": eye, "points": default_points(eye)}
        self.plant = make_plant(cfg.plant, robot, scene=scene, dt=cfg.dt)
        self.plant.reset(robot.actuators_from_joints(pose.q))
        self.box = cfg.fixtures.workspace(eye)  # the fixture as stated (violations, metrics)
        guard = 0.0 if getattr(self.plant, "exact_commands", False) else cfg.fixtures.plant_guard
        held = cfg.fixtures.workspace(eye, guard)  # the fixture the QP holds
        self.solver = QpSolver(robot, eye, cfg.dt, limits=cfg.fixtures.qp_limits(guard),
                               extra_limits=(held,))  # fmt: skip
        self.fast_step = servo.fast_period_step(self.solver)
        self.pipeline = Pipeline(cfg.make_filter(), MotionScaling(cfg.scale, R))
        allowed = eye.retina_radius - cfg.fixtures.retina_margin - guard
        self.targets = TargetMaker(eye.port, held, eye.center, allowed)
        self.log = LogBuilder.for_robot(robot)
        self._pid = [self.log.phase_id(p) for p in PHASES]
        self._sid = self.log.solver_id(self.solver.name)
        self.trace = TraceBuilder()
        self._segment = -1
        self._k = 0
        self.started = False

    def start(self, master: FloatArray) -> None:
        """Reset the pipeline at the first master position [m], the needle holding."""
        tip = self.robot.tip(self.robot.joints_from_actuators(self.plant.read_actuators()))
        p = (float(master[0]), float(master[1]), float(master[2]))
        self.pipeline.reset(p, (float(tip[0]), float(tip[1]), float(tip[2])))
        self.started = True

    def period(self, sample: MasterSample) -> TeleopState:
        """One control period on this sample (see the module docstring)."""
        if not self.started:
            self.start(sample.position)
        robot, plant, trocar = self.robot, self.plant, self.eye.port
        t = plant.time
        now = servo.read(robot, plant, trocar)
        s, q, tip, rcm = now.s, now.q, now.tip, now.rcm
        start = time.perf_counter()
        desired = self.pipeline.step(t, sample, (float(tip[0]), float(tip[1]), float(tip[2])))
        target = self.targets.target(desired)
        mid = time.perf_counter()
        e = servo.step(robot, plant, self.solver, self.fast_step, now, target)
        stop = time.perf_counter()
        self._record(t, sample, s, q, now.lam, tip, rcm, now.base, np.array(desired), e)
        self.trace.append(t, sample.t, sample.position, self.pipeline.filtered,
                          sample.clutch, desired, self._segment_of(sample.clutch),
                          mid - start, stop - mid)  # fmt: skip
        deviation = float(np.linalg.norm(rcm - trocar))
        if deviation > self.settings.rcm_bound:
            raise RcmBoundError("teleop", deviation, self.settings.rcm_bound)
        return TeleopState(t, tip, np.array(desired), deviation,
                           self.eye.distance_to_retina(tip), sample.clutch, s, q)  # fmt: skip

    def _segment_of(self, engaged: bool) -> int:
        events = self.pipeline.clutch.events
        if not engaged:
            return -1
        return sum(1 for ev in events if ev.kind == "engaged") - 1

    def _record(
        self, t: float, sample: MasterSample, s: FloatArray, q: FloatArray, lam: float,
        tip: FloatArray, rcm: FloatArray, base: FloatArray, desired: FloatArray, e: FloatArray,
    ) -> None:  # fmt: skip
        self.log.append(
            time=t, sliders=s, joints=q, lam=lam, tip=tip, rcm=rcm, trocar=self.eye.port,
            base=base, target_tip=desired, error=e, step=self._k, iteration=0,
            solver=self._sid, phase=self._pid[int(sample.clutch)],
        )  # fmt: skip
        self._k += 1

    def events(self) -> list[dict[str, object]]:
        """The clutch events as plain dictionaries (times [s], tips [m])."""
        return [{"t_s": ev.t, "kind": ev.kind, "tip_m": list(ev.tip)}
                for ev in self.pipeline.clutch.events]  # fmt: skip
