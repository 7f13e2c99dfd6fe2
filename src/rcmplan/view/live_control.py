"""The view's side of the live control: the teleoperation session (`rcmplan.teleop.run_live`:
clutch, scaling, tremor filter, one QP step per 1 kHz period with the virtual fixtures) driven
by the gizmo, and the state the view shows after every period.

The gizmo's position (base frame, scene units) is the master input: it is turned into the
master frame (the eye frame's axes, `to_master`) and, at scale 1 with no filter (the view's
defaults), the desired tip is the gizmo's position. What this module adds to the session is
view-specific: wall-clock period counting (`slots`, `missed`), the real-time scheduling
request, and a status saying why the needle holds short of the gizmo.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.robot.model import RobotModel
from rcmplan.scene.eye import Eye, eye_frame
from rcmplan.teleop.samples import MasterSample
from rcmplan.teleop.session import TeleopState
from rcmplan.teleop.settings import TeleopSettings
from rcmplan.view.realtime import request_realtime

HELD_GAP = 1e-6  # [m] the tip this far from the desired tip, and not moving: held
STILL = 1e-9  # [m] tip motion in a period below which the tip counts as not moving
STILL_PERIODS = 3  # (the tip read in a period is the previous period's command)
AT_FIXTURE = 5e-6  # [m] this close to a fixture, the tip (or an actuator) is at it (MuJoCo's
# piezo servo stops short of its command: the QP keeps a 1 um guard there, `Fixtures.plant_guard`)


@dataclass(frozen=True)
class LiveSettings:
    """A live session as the view runs it (SI units, robot base frame).

    Attributes:
        teleop: The teleoperation session (robot, plant, scale, filter, fixtures, dt).
        robot: Its robot (for drawing). eye: Its eye (`default_eye(robot)`).
        points: Named points to label in the view (the scenario's p1..p7).
        realtime: Ask for real-time scheduling of the control thread (`view.realtime`).
    """

    teleop: TeleopSettings
    robot: RobotModel
    eye: Eye
    points: dict[str, FloatArray] = field(default_factory=dict)
    realtime: bool = True

    @property
    def start_tip(self) -> FloatArray:
        """Where the tip starts (3,) [m], base frame."""
        return np.asarray(self.eye.center + eye_frame(self.eye) @ np.asarray(self.teleop.start_tip))

    @property
    def dt(self) -> float:
        """The control period [s]."""
        return self.teleop.dt

    @property
    def retina_margin(self) -> float:
        """Closest approach of the tip to the retina [m]."""
        return self.teleop.fixtures.retina_margin

    def to_master(self, position: FloatArray) -> FloatArray:
        """A base-frame position (3,) [m] (the gizmo's) in the master frame (the eye frame's
        axes, origin at the base frame's)."""
        return np.asarray(eye_frame(self.eye).T @ np.asarray(position, dtype=float))


class InputSource(Protocol):
    """Where the control reads its input: `rcmplan.teleop.LiveInput`, or its shared-memory
    twin (`live_process.SharedInput`)."""

    def latest(self) -> MasterSample:
        """The latest sample."""
        ...


class StopFlag(Protocol):
    """A threading.Event or a multiprocessing Event."""

    def is_set(self) -> bool:
        """True once the control should stop."""
        ...


@dataclass
class LiveState:
    """The control's state after a period, as the view reads it.

    Attributes:
        period: Periods run. slots: Periods of wall time so far. missed: Periods of wall time
            in which no period ended (see `Monitor`). t_s: Plant time [s].
        q, s: Joints and actuators.
        tip, goal: Tip and desired tip (what the gizmo asks for) (3,) [m].
        rcm_deviation: Distance from the trocar to the needle line [m].
        max_rcm_deviation: Its largest value so far [m]. retina_distance: Tip to retina [m]
            (positive inside). engaged: The clutch.
        status: "running", "released: ...", "held: <why>" or "stopped: <why>".
        scheduling: The control thread's scheduling (real-time or normal, and why).
    """

    period: int = 0
    slots: int = 0
    missed: int = 0
    t_s: float = 0.0
    q: FloatArray = field(default_factory=lambda: np.zeros(0))
    s: FloatArray = field(default_factory=lambda: np.zeros(0))
    tip: FloatArray = field(default_factory=lambda: np.zeros(3))
    goal: FloatArray = field(default_factory=lambda: np.zeros(3))
    rcm_deviation: float = 0.0
    max_rcm_deviation: float = 0.0
    retina_distance: float = 0.0
    engaged: bool = False
    status: str = "running"
    scheduling: str = ""


def why_held(settings: LiveSettings, tip: FloatArray, s: FloatArray) -> str:
    """Which fixture the tip (3,) [m] stands at, actuators `s` (n,): the retina margin, a face
    of the workspace box, an actuator at its travel (less the margin), else the QP's other
    limits (joint limits, the RCM box near a singular pose)."""
    cfg, eye, robot = settings.teleop.fixtures, settings.eye, settings.robot
    if eye.distance_to_retina(tip) - cfg.retina_margin < AT_FIXTURE:
        return f"the retina margin ({1e3 * cfg.retina_margin:g} mm)"
    box = cfg.workspace(eye)
    c = box.coordinates(tip).ravel()
    if np.any(c - np.array(box.lower) < AT_FIXTURE) or np.any(np.array(box.upper) - c < AT_FIXTURE):
        return "the workspace box"
    m = cfg.travel_margin + AT_FIXTURE
    at = (s - robot.lower < m) | (robot.upper - s < m)
    if np.any(at):
        names = ", ".join(n for n, a in zip(robot.actuator_names, at, strict=True) if a)
        return f"the travel of {names}"
    return "the QP's other limits (joint limits, a singular pose)"


class Monitor:
    """Turns each period's `TeleopState` into a `LiveState` (`update`, called from the loop).

    Wall time is cut in slots of dt from the start of the first period t0: slot j is
    [t0 + j dt, t0 + (j+1) dt). `rcmplan.teleop.run_live` starts period k no earlier than
    t0 + k dt (in slot k when on time); a period starting in slot j serves it, and a slot no
    period started in is missed (the loop was late: it then runs the periods it owes back to
    back, without waiting). `slots` is the last slot served plus one.
    """

    def __init__(self, settings: LiveSettings, scheduling: str = "") -> None:
        self.settings = settings
        self.state = LiveState(scheduling=scheduling, goal=settings.start_tip.copy(),
                               tip=settings.start_tip.copy())  # fmt: skip
        self._t0 = 0.0
        self._last = -1
        self._still = 0  # periods in a row the tip has not moved

    def update(self, ts: TeleopState, started: float | None = None) -> LiveState:
        """The state after one period that started at `started` (`time.perf_counter()`, [s];
        default: now), the same object each time, updated."""
        st, dt = self.state, self.settings.dt
        now = time.perf_counter() if started is None else started
        if st.period == 0:
            self._t0 = now
        # The loop never runs ahead of its schedule, whose grid starts a few microseconds
        # before the first period's read: a period that reads in the slot of the one before it
        # serves the next slot.
        j = max(int((now - self._t0) / dt), self._last + 1)
        st.missed += j - self._last - 1
        self._last = j
        st.slots = self._last + 1
        moved = float(np.linalg.norm(ts.tip - st.tip)) if st.period else np.inf
        self._still = self._still + 1 if moved < STILL else 0
        st.period += 1
        st.t_s, st.q, st.s = ts.t, ts.joints, ts.actuators
        st.tip, st.goal, st.engaged = ts.tip, ts.desired, ts.engaged
        st.rcm_deviation = ts.rcm_deviation
        st.max_rcm_deviation = max(st.max_rcm_deviation, ts.rcm_deviation)
        st.retina_distance = ts.retina_distance
        if not ts.engaged:
            st.status = "released: the needle holds"
        elif float(np.linalg.norm(ts.tip - ts.desired)) > HELD_GAP and self._still >= STILL_PERIODS:
            st.status = "held: at " + why_held(self.settings, ts.tip, ts.actuators)
        else:
            st.status = "running"
        return st


class _Stamped:
    """An input that notes when the loop last read it (the start of a period)."""

    def __init__(self, source: InputSource) -> None:
        self.source = source
        self.read_at = 0.0

    def latest(self) -> MasterSample:
        self.read_at = time.perf_counter()
        return self.source.latest()


def run_live(
    settings: LiveSettings,
    live_input: InputSource,
    stop_event: StopFlag,
    on_period: Callable[[LiveState], None] | None = None,
) -> LiveState:
    """`rcmplan.teleop.run_live` at wall-clock pace in the calling thread (asking first for
    real-time scheduling if `settings.realtime`) until `stop_event` is set or the session stops;
    calls `on_period(state)` after every period (keep it short). Returns the last state, its
    status "stopped: <why>" if the session stopped on an error."""
    from rcmplan.teleop.run import run_live as teleop_live

    scheduling = request_realtime() if settings.realtime else "normal scheduling (asked for)"
    monitor = Monitor(settings, scheduling)

    stamped = _Stamped(live_input)

    def period(ts: TeleopState) -> None:
        st = monitor.update(ts, stamped.read_at)
        if on_period is not None:
            on_period(st)

    result = teleop_live(settings.teleop, stamped, stop_event, period)  # type: ignore[arg-type]
    if result.error is not None:
        monitor.state.status = f"stopped: {result.message}"
    return monitor.state
