"""Drive the needle live in the view: a draggable target (viser's transform controls) is the
input, the robot follows in real time with the RCM at the trocar and the tip kept off the
retina, and the panels show the RCM deviation and the distance to the retina as they happen.

The control is the teleoperation session (`rcmplan.teleop.run_live` through `live_control`:
the gizmo's position is the master input; scale 1 and no tremor filter by default; one QP step
per 1 kHz period with the fixtures) and runs at wall-clock pace in a process of its own
(`live_process`): the view's drawing and viser's messages never hold the interpreter it
needs, and it asks for real-time scheduling where the system grants it (`view.realtime`). A
redraw thread reads the control's latest state from shared memory at `rate_hz`; the control
never waits for the view.
"""

from __future__ import annotations

import threading
import time
from typing import Any

import numpy as np

from rcmplan.exceptions import InvalidInputError
from rcmplan.scene.eye import eye_frame
from rcmplan.scene.record import SceneRecord
from rcmplan.teleop.settings import TeleopSettings, session_scenario
from rcmplan.view.camera import CameraViews
from rcmplan.view.links import robot_links
from rcmplan.view.live_control import LiveSettings, LiveState
from rcmplan.view.live_process import LiveProcess
from rcmplan.view.needle import needle_polyline
from rcmplan.view.panels import ActuatorPanel, StatePanel, length
from rcmplan.view.scene import SceneDrawing
from rcmplan.view.server import viser_race

NAN3 = np.full(3, np.nan)
# The view re-sends the gizmo's position at every redraw (40 /s): a sample older than this
# [s] means the view stopped sending, and the needle holds (`TeleopSettings.stale_after`).
STALE_AFTER_S = 1.0


def live_settings(
    scenario: str, robot: str | None, plant: str, realtime: bool = True,
    scale: float = 1.0, filter: str = "none",
) -> LiveSettings:  # fmt: skip
    """Live settings from a scenario (its points; the tip starts at its p3), a robot (default:
    the scenario's), a plant, whether to ask for real-time scheduling, the motion scaling and
    the tremor filter (`rcmplan.teleop.TeleopSettings`). Refused before anything starts: a
    curved needle (the live target is a tip point with the RCM: a straight needle's task), an
    eye other than the robot's default one (the teleoperation session's), a start point
    outside the fixtures."""
    sc, model, eye = session_scenario(scenario, robot)
    points = sc.points(eye).as_dict()
    start = eye_frame(eye).T @ (points["p3"] - eye.center)
    teleop = TeleopSettings(robot=sc.robot, plant=plant, scale=scale, filter=filter,
                            start_tip=tuple(start), stale_after=STALE_AFTER_S)  # fmt: skip
    teleop.fixtures.check_start(eye, points["p3"])
    return LiveSettings(teleop, model, eye, points=points, realtime=realtime)


class LiveView:
    """The live scene, its control and its redraw threads.

    Args:
        server: A running viser server. settings: The live session. rate_hz: Redraw rate.
    """

    def __init__(self, server: Any, settings: LiveSettings, rate_hz: float = 40.0) -> None:
        self.server, self.settings, self.rate_hz = server, settings, rate_hz
        self.control = LiveProcess(settings)  # plant and solver built first: errors surface here
        robot, eye = settings.robot, settings.eye
        record = SceneRecord.of(eye, settings.points, ("p4", "p5", "p6", "p7"))
        self.links = robot_links(server, robot)
        self.drawing = SceneDrawing(server.scene, record)
        self.input = self.control.input
        self.gizmo_scale = 0.4 * eye.radius  # arrow length [m]
        self.gizmo = server.scene.add_transform_controls(
            "/live/target", scale=self.gizmo_scale, disable_rotations=True, depth_test=False,
            position=settings.start_tip,
        )  # fmt: skip
        self.moves = 0  # gizmo updates from a browser
        self.refused = ""  # why the gizmo's last position was not sent
        gui = server.gui
        self.clutch = gui.add_checkbox(
            "clutch engaged", initial_value=True,
            hint="Release to move the gizmo without moving the needle; engaged again, the "
            "needle moves on from where it is by the gizmo's motion from there.",
        )  # fmt: skip

        def moved(_event: Any) -> None:
            self.moves += 1
            self.send()

        self.gizmo.on_update(moved)
        self.clutch.on_update(lambda _event: self.send())
        self.panel = StatePanel(gui, "Live")
        with gui.add_folder("Actuators"):
            self.actuators = ActuatorPanel(gui, robot.actuator_names, robot.actuator_units,
                                           robot.lower, robot.upper)  # fmt: skip
        gui.add_markdown("Drag the gizmo's arrows: the needle tip follows with the RCM held at "
                         f"the trocar and the tip {length(settings.retina_margin, 'mm')} off "
                         "the retina. Release the clutch to move the gizmo alone.  \n_"
                         + self.links.note + "_")  # fmt: skip
        self.cameras = CameraViews(server, record, robot)
        self.lock = threading.Lock()
        self.updates = 0
        self.races = 0  # redraws cut short by viser's race (`server.viser_race`)
        self.update_times: list[float] = []
        self.stop_event = threading.Event()
        self.redraw = threading.Thread(target=self._redraw, name="rcmplan-live-view", daemon=True)
        self.redraw.start()

    def send(self) -> None:
        """Push the gizmo's position as the master position, with the clutch checkbox's state
        (released: the needle holds while the gizmo moves; engaged again, the session
        re-indexes, so the needle does not jump to the gizmo). A position the input refuses
        (beyond +-1 m of the base: `teleop.samples.check_position`) is not sent: the needle
        holds (the session releases the clutch when no position comes) and the panel says
        why."""
        try:
            master = self.settings.to_master(np.array(self.gizmo.position))
            self.input.push(master, clutch=bool(self.clutch.value))
            self.refused = ""
        except InvalidInputError as exc:
            self.refused = " ".join(str(exc).split())[:160]

    @property
    def latest(self) -> LiveState | None:
        """The control's latest state (a copy, from shared memory)."""
        return self.control.latest()

    def _redraw(self) -> None:
        period = 1.0 / self.rate_hz
        due = time.perf_counter() + period
        while not self.stop_event.wait(max(0.0, due - time.perf_counter())):
            due = max(due + period, time.perf_counter())  # a slow redraw is not caught up
            self.send()  # the gizmo holds its place: its position stays the live input
            st = self.latest
            if st is None:
                continue
            try:
                self.show(st, st.q, st.s, st.tip)
            except RuntimeError as exc:
                if not viser_race(exc):
                    raise
                self.races += 1  # the frame is queued; the next one wakes the sender

    def show(self, st: LiveState, q: Any, s: Any, tip: Any) -> None:
        """Redraw the robot, needle and panels from one control state."""
        with self.lock, self.server.atomic():
            self.links.show(q, s)
            base = self.settings.robot.needle_point(q, 0.0)
            needle = needle_polyline(self.settings.robot, q, base, tip)
            self.drawing.show(needle, self.settings.eye.port, NAN3)
            missed = st.missed / st.slots if st.slots else 0.0
            self.panel.show({
                "RCM deviation": length(st.rcm_deviation),
                "largest RCM deviation": length(st.max_rcm_deviation),
                "distance to the retina": length(st.retina_distance, "mm"),
                "tip to target": length(float(np.linalg.norm(tip - st.goal))),
                "control": f"{st.period:,} periods, {100 * missed:.1f}% missed",
                "scheduling": st.scheduling,
                "status": st.status + (f" (gizmo not sent: {self.refused})"
                                       if self.refused else ""),
            })  # fmt: skip
            self.actuators.show(s)
            self.updates += 1
            self.update_times.append(time.perf_counter())

    def state(self) -> dict[str, Any]:
        """The control's latest state and the redraw count, for tests and benchmarks (SI)."""
        st = self.latest
        if st is None:
            return {"period": 0}
        times = self.update_times[-31:]
        rate = (len(times) - 1) / (times[-1] - times[0]) if len(times) > 1 else 0.0
        return {
            "period": st.period, "slots": st.slots, "missed": st.missed,
            "tip_m": st.tip.tolist(), "goal_m": st.goal.tolist(),
            "rcm_deviation_m": st.rcm_deviation, "max_rcm_deviation_m": st.max_rcm_deviation,
            "retina_distance_m": st.retina_distance, "status": st.status,
            "view_updates": self.updates, "view_races": self.races, "view_rate_hz": rate,
            "pushes": self.moves,
        }  # fmt: skip

    def close(self) -> None:
        """Stop the redraw and the control."""
        self.stop_event.set()
        self.redraw.join(timeout=2.0)
        self.control.close()
