"""Live control for the view: a target the user drags is the input, the robot's needle tip
follows it in real time with the RCM held at the trocar.

One solver step per control period (1 kHz by default) at wall-clock pace, against any plant:
read the actuators, re-declare the RCM as the needle point closest to the trocar (drift
correction), take one step of the scenario's solver towards `rcm_target(setpoint, trocar)`,
command, advance. The setpoint walks towards the latest input at most `max_speed`, so every
step is small, and two fixtures shape it: the tip stays inside the retina by `retina_margin`
(the input is projected into that ball), and an RCM deviation beyond `rcm_bound` stops the
control (a safety stop, as `LoopSettings.rcm_bound`).

This module has the public shape of `rcmplan.teleop` (`LiveInput.push/latest`,
`run_live(settings, live_input, stop_event, on_period)`), so the view moves to the teleoperation
pipeline (scaling, tremor filters, clutch) by changing the loop `live_process` runs once that
package is available.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from rcmplan._validate import FloatArray, scalar, vector
from rcmplan.control.method_settings import MethodSettings
from rcmplan.control.plant import Plant
from rcmplan.control.solvers import Solver
from rcmplan.control.targets import rcm_target, solve_pose
from rcmplan.exceptions import RcmplanError
from rcmplan.robot.model import RobotModel
from rcmplan.robot.needle import closest_lambda
from rcmplan.scene.eye import Eye
from rcmplan.view.realtime import request_realtime


@dataclass(frozen=True)
class LiveSettings:
    """A live session (SI units, robot base frame).

    Attributes:
        robot: The robot (a straight needle). eye: The eye; its trocar holds the RCM.
        start_tip: Where the tip starts (3,) [m], inside the eye.
        plant: "kinematic", "mujoco" or "mujoco-kinematic". method: An RCM method (`METHODS`).
        dt: Control period [s]. max_speed: Fastest setpoint motion [m/s].
        retina_margin: Closest approach of the tip to the retina [m].
        rcm_bound: RCM deviation [m] that stops the control.
        realtime: Ask for real-time scheduling of the control thread (`view.realtime`).
        method_settings: The method's gains and options (default: its defaults).
        points: Named points to label in the view (the scenario's p1..p7).
    """

    robot: RobotModel
    eye: Eye
    start_tip: FloatArray
    plant: str = "kinematic"
    method: str = "pinv"
    dt: float = 1e-3
    max_speed: float = 0.02
    retina_margin: float = 0.5e-3
    rcm_bound: float = 45e-6
    realtime: bool = True
    method_settings: MethodSettings | None = None
    points: dict[str, FloatArray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "start_tip", vector("start_tip", self.start_tip, 3))
        scalar("dt", self.dt, 1e-4, 0.1)
        scalar("max_speed", self.max_speed, 0.0, 1.0, low_open=True)
        scalar("retina_margin", self.retina_margin, 0.0, self.eye.retina_radius, high_open=True)
        scalar("rcm_bound", self.rcm_bound, 0.0, 0.01, low_open=True)


@dataclass(frozen=True)
class LiveSample:
    """One input: time [s] (`time.monotonic`), position (3,) [m], clutch engaged."""

    t: float
    position: FloatArray
    clutch: bool


class InputSource(Protocol):
    """Where the control reads its input: `LiveInput`, or its shared-memory twin."""

    def latest(self) -> LiveSample:
        """The latest sample."""
        ...


class StopFlag(Protocol):
    """A threading.Event or a multiprocessing Event."""

    def is_set(self) -> bool:
        """True once the control should stop."""
        ...


class LiveInput:
    """The latest input position, shared between threads (a lock guards it).

    Args:
        initial_position: The position (3,) [m] reported before any push.
    """

    def __init__(self, initial_position: FloatArray) -> None:
        self._lock = threading.Lock()
        self._sample = LiveSample(time.monotonic(), vector("position", initial_position, 3), False)
        self.pushes = 0

    def push(self, position_m: FloatArray, clutch: bool = True, t: float | None = None) -> None:
        """Record the latest input position (3,) [m] (InvalidInputError if not 3 finite
        numbers) and the clutch (True: the robot follows)."""
        sample = LiveSample(time.monotonic() if t is None else scalar("t", t),
                            vector("position", position_m, 3).copy(), bool(clutch))  # fmt: skip
        with self._lock:
            self._sample = sample
            self.pushes += 1

    def latest(self) -> LiveSample:
        """The latest sample."""
        with self._lock:
            return self._sample


@dataclass
class LiveState:
    """The control's state after a period, as the view reads it.

    Attributes:
        period: Steps run. slots: Periods of wall time so far. missed: Periods whose step ended
            late or that were skipped (see `run_live`). t_s: Simulated time [s].
        q, s: Joints and actuators.
        tip, base, setpoint, goal: Tip, needle base, commanded and requested tip (3,) [m].
        rcm_deviation: Distance from the trocar to the needle point p(lambda) [m].
        max_rcm_deviation: Its largest value so far [m]. retina_distance: Tip to retina [m]
            (positive inside). status: "running", "held: <why>" or "stopped: <why>".
        scheduling: The control thread's scheduling (real-time or normal, and why).
    """

    period: int = 0
    slots: int = 0
    missed: int = 0
    t_s: float = 0.0
    q: FloatArray = field(default_factory=lambda: np.zeros(0))
    s: FloatArray = field(default_factory=lambda: np.zeros(0))
    tip: FloatArray = field(default_factory=lambda: np.zeros(3))
    base: FloatArray = field(default_factory=lambda: np.zeros(3))
    setpoint: FloatArray = field(default_factory=lambda: np.zeros(3))
    goal: FloatArray = field(default_factory=lambda: np.zeros(3))
    rcm_deviation: float = 0.0
    max_rcm_deviation: float = 0.0
    retina_distance: float = 0.0
    status: str = "running"
    scheduling: str = ""


def fixture(settings: LiveSettings, p: FloatArray) -> FloatArray:
    """The input point p (3,) [m] moved into the ball the tip may reach: inside the retina by
    `retina_margin` (the retina fixture)."""
    eye = settings.eye
    d = p - eye.center
    r = float(np.linalg.norm(d))
    limit = eye.retina_radius - settings.retina_margin
    return p if r <= limit else eye.center + d * (limit / r)


def start(settings: LiveSettings) -> tuple[Plant, Solver, float]:
    """The plant with the tip at the start point and the RCM at the trocar, the solver, and
    the starting lambda."""
    from rcmplan.control.methods import make_solver
    from rcmplan.sim.registry import make_plant

    robot, eye = settings.robot, settings.eye
    pose = solve_pose(robot, rcm_target(fixture(settings, settings.start_tip), eye.port))
    plant = make_plant(settings.plant, robot, scene={"eye": eye}, dt=settings.dt)
    plant.reset(robot.actuators_from_joints(pose.q))
    solver = make_solver(settings.method, settings.method_settings, robot, eye=eye,
                         dt=settings.dt)  # fmt: skip
    return plant, solver, pose.lam


class LiveLoop:
    """One control step per period (see the module docstring)."""

    def __init__(self, settings: LiveSettings) -> None:
        self.settings = settings
        self.plant, self.solver, self.lam = start(settings)
        self.state = LiveState(setpoint=fixture(settings, settings.start_tip).copy())
        self.state.goal = self.state.setpoint.copy()

    def step(self, sample: LiveSample) -> LiveState:
        """Measure, then step towards the input (held while the clutch is released)."""
        cfg, robot, plant, st = self.settings, self.settings.robot, self.plant, self.state
        trocar = cfg.eye.port
        s = plant.read_actuators()
        q = robot.joints_from_actuators(s)
        base, end = robot.needle_point(q, 0.0), robot.needle_point(q, 1.0)
        self.lam = closest_lambda(base, end, trocar)
        st.q, st.s, st.base, st.tip = q, s, base, robot.tip(q)
        st.rcm_deviation = float(np.linalg.norm(base + self.lam * (end - base) - trocar))
        st.max_rcm_deviation = max(st.max_rcm_deviation, st.rcm_deviation)
        st.retina_distance = cfg.eye.distance_to_retina(st.tip)
        st.t_s = plant.time
        if st.rcm_deviation > cfg.rcm_bound:
            st.status = (
                f"stopped: RCM deviation {st.rcm_deviation:.3g} m beyond {cfg.rcm_bound:g} m"
            )
            return st
        if sample.clutch:
            st.goal = fixture(cfg, sample.position)
        move = st.goal - st.setpoint
        dist, reach = float(np.linalg.norm(move)), cfg.max_speed * cfg.dt
        setpoint = st.goal.copy() if dist <= reach else st.setpoint + move * (reach / dist)
        try:
            target = rcm_target(setpoint, trocar)
            e = self.solver.error(robot, q, self.lam, target)
            # lambda is re-declared from the needle each period (drift correction): the
            # step's lambda increment is not needed
            dq, _dlam = self.solver.step(robot, q, self.lam, target, e)
            q_new = q.copy()
            q_new[list(robot.active)] += dq
            plant.command_actuators(robot.check_actuators(robot.actuators_from_joints(q_new)))
            st.setpoint, st.status = setpoint, "running"
        except RcmplanError as exc:  # a limit or a singular pose: hold, the setpoint too
            st.status = f"held: {type(exc).__name__}: {' '.join(str(exc).split())[:120]}"
        plant.advance()
        return st


def run_live(
    settings: LiveSettings,
    live_input: InputSource,
    stop_event: StopFlag,
    on_period: Callable[[LiveState], None] | None = None,
) -> LiveState:
    """Run the control at wall-clock pace until `stop_event` is set or a safety stop; calls
    `on_period(state)` after every period (from this thread: keep it short). Returns the last
    state.

    Wall time is cut in periods t0 + k dt; the step of period k should end before period k
    does. A step that ends late misses its period, and the periods that passed meanwhile are
    missed too (skipped: the loop does not hurry to catch up, it goes on with the next period
    to start). `state.slots` counts the periods of wall time, `state.missed` the missed ones.
    """
    return pace(LiveLoop(settings), live_input, stop_event, on_period)


def pace(
    loop: LiveLoop,
    live_input: InputSource,
    stop_event: StopFlag,
    on_period: Callable[[LiveState], None] | None = None,
) -> LiveState:
    """`run_live` on a loop built beforehand (so that a plant or solver that cannot be built
    fails in the caller's thread, before any motion)."""
    dt = loop.settings.dt
    if loop.settings.realtime:
        loop.state.scheduling = request_realtime()
    else:
        loop.state.scheduling = "normal scheduling (asked for)"
    t0 = time.perf_counter()
    k = 0  # the period the next step belongs to
    st = loop.state
    while not stop_event.is_set():
        st = loop.step(live_input.latest())
        st.period += 1
        if on_period is not None:
            on_period(st)
        if st.status.startswith("stopped"):
            break
        now = time.perf_counter()
        if now > t0 + (k + 1) * dt:
            nxt = int((now - t0) / dt) + 1
            st.missed += nxt - k
            k = nxt
        else:
            k += 1
        st.slots = k
        wait = t0 + k * dt - time.perf_counter()
        if wait > 0:
            time.sleep(wait)
    return st
