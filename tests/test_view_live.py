"""Live control of the view without a browser: the gizmo's position drives the teleoperation
session (scale 1, no filter), the tip follows it with the RCM held, the actuators keep their
speed, the retina fixture keeps the tip off the retina, the clutch holds the needle, a limit
holds it and the status says why, the period is counted against wall time."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from rcmplan.exceptions import InvalidInputError
from rcmplan.teleop import LiveInput, MasterSample
from rcmplan.teleop.session import Session
from rcmplan.view.live import live_settings
from rcmplan.view.live_control import LiveSettings, Monitor, run_live


@pytest.fixture(scope="module")
def settings():
    return live_settings("default", None, "kinematic")


class Gizmo:
    """A session driven as the view drives it: base-frame positions of the gizmo, engaged."""

    def __init__(self, s: LiveSettings) -> None:
        self.s, self.session, self.monitor = s, Session(s.teleop), Monitor(s)
        self.worst = 0.0

    def at(self, p: np.ndarray, clutch: bool = True):
        ts = self.session.period(MasterSample(0.0, self.s.to_master(p), clutch))
        self.worst = max(self.worst, ts.rcm_deviation)
        return self.monitor.update(ts)

    def drag(self, goal: np.ndarray, periods: int, speed: float = 0.02):
        """Move the gizmo from the start to goal at `speed` [m/s] (a hand's drag), then hold
        it there; the last state."""
        start, dt = self.s.start_tip, self.s.dt
        d = goal - start
        n = max(1, int(np.ceil(np.linalg.norm(d) / (speed * dt))))
        for k in range(periods):
            st = self.at(start + d * min(1.0, (k + 1) / n))
        return st


@pytest.mark.parametrize("robot", ["iramis", "ur5"])
def test_the_tip_reaches_the_gizmo_with_the_rcm_held(robot) -> None:
    s = live_settings("default", robot, "kinematic")
    g = Gizmo(s)
    g.at(s.start_tip)
    goal = s.start_tip + np.array([1.5e-3, -1e-3, 0.5e-3])
    st = g.drag(goal, 5000)  # iRAM!S: its sliders' speed holds the tip near 1 mm/s
    np.testing.assert_allclose(st.goal, goal, atol=1e-12)  # scale 1: the gizmo is the goal
    np.testing.assert_allclose(st.tip, goal, atol=1e-9)
    assert g.worst <= 1e-6
    assert st.status == "running"


def test_scaling_moves_the_goal_by_the_gizmo_motion_over_the_scale() -> None:
    s = live_settings("default", "ur5", "kinematic", scale=4.0)
    g = Gizmo(s)
    g.at(s.start_tip)
    st = g.at(s.start_tip + np.array([2e-3, 0.0, -1e-3]))
    np.testing.assert_allclose(st.goal - s.start_tip, [0.5e-3, 0.0, -0.25e-3], atol=1e-12)


def test_every_actuator_keeps_its_speed_when_the_gizmo_jumps(settings) -> None:
    g = Gizmo(settings)
    robot = settings.robot
    s0 = g.at(settings.start_tip).s.copy()
    far = settings.start_tip + np.array([0.0, 3e-3, 0.0])
    steps = []
    for _ in range(100):
        s1 = g.at(far).s.copy()
        steps.append(np.abs(s1 - s0))
        s0 = s1
    steps = np.array(steps)
    assert np.all(steps <= robot.speed * settings.dt * (1 + 1e-9) + 1e-15)
    assert np.any(np.isclose(steps, robot.speed * settings.dt, rtol=1e-6))  # one was at it


def test_a_gizmo_beyond_the_retina_leaves_the_tip_at_the_margin() -> None:
    s = live_settings("default", "ur5", "kinematic")
    eye = s.eye
    g = Gizmo(s)
    g.at(s.start_tip)
    outside = eye.center + 2 * eye.radius * eye.axis
    closest = np.inf
    for _ in range(4000):
        st = g.at(outside)
        closest = min(closest, st.retina_distance)
    assert closest >= s.retina_margin - 1e-9
    assert st.retina_distance == pytest.approx(s.retina_margin, abs=1e-6)
    assert st.status == "held: at the retina margin (0.25 mm)"
    assert g.worst <= 1e-6


def test_a_released_clutch_holds_the_needle(settings) -> None:
    g = Gizmo(settings)
    start = g.at(settings.start_tip).tip.copy()
    for _ in range(50):
        st = g.at(settings.start_tip + 2e-3, clutch=False)
    np.testing.assert_allclose(st.tip, start, atol=1e-12)
    assert st.status.startswith("released")


@pytest.mark.parametrize(("pull", "why"), [
    ((0.0, 0.0, 20e-3), "held: at the travel of L1"),  # pulled up: a PCJM leaves its travel
    ((20e-3, 0.0, 0.0), "held: at the workspace box"),  # sideways
])  # fmt: skip
def test_a_limit_holds_the_needle_and_says_why(pull, why) -> None:
    s = live_settings("default", "iramis", "kinematic")
    g = Gizmo(s)
    g.at(s.start_tip)
    far = s.start_tip + np.array(pull)
    for _ in range(20000):
        st = g.at(far)
        if st.status.startswith("held"):
            break
    assert st.status == why
    tip = st.tip.copy()
    for _ in range(50):
        st = g.at(far)
    np.testing.assert_allclose(st.tip, tip, atol=1e-9)
    assert st.status == why
    assert g.worst <= 1e-6


def test_run_live_counts_its_periods_against_wall_time(settings) -> None:
    inp, stop = LiveInput(settings.to_master(settings.start_tip)), threading.Event()
    out, first = {}, threading.Event()  # 0.3 s of periods once the session runs (building it
    # may compile its QP step on a first run)
    th = threading.Thread(
        target=lambda: out.setdefault(
            "st", run_live(settings, inp, stop, on_period=lambda st: first.set())
        )
    )
    start = time.perf_counter()
    th.start()
    assert first.wait(300.0), "the session never ran a period"
    time.sleep(0.3)
    stop.set()
    th.join()
    elapsed = time.perf_counter() - start
    st = out["st"]
    assert st.period > 0 and 0 <= st.missed <= st.slots
    assert st.slots <= elapsed / settings.dt + 1  # periods are wall-clock periods
    assert st.slots - st.missed <= st.period <= st.slots  # a period per slot served, at most
    # one period per slot of wall time (a late loop catches up, never runs ahead)
    assert st.t_s == pytest.approx((st.period - 1) * settings.dt)  # one plant period each


def test_live_refuses_a_curved_needle() -> None:
    with pytest.raises(InvalidInputError, match="straight"):
        live_settings("curved", None, "kinematic")


def test_live_refuses_a_scale_out_of_range() -> None:
    with pytest.raises(InvalidInputError, match="scale"):
        live_settings("default", None, "kinematic", scale=0.5)


def test_live_input_refuses_a_position_that_is_not_three_numbers(settings) -> None:
    with pytest.raises(InvalidInputError):
        LiveInput(settings.start_tip).push(np.array([0.0, np.nan, 0.0]))


def test_the_scheduling_reported_is_the_one_the_thread_has() -> None:
    import os

    from rcmplan.view.realtime import request_realtime

    seen = {}

    def ask() -> None:  # in a thread of its own: the test runner's thread keeps its policy
        seen["text"] = request_realtime()
        seen["policy"] = os.sched_getscheduler(0)

    th = threading.Thread(target=ask)
    th.start()
    th.join()
    fifo = seen["policy"] == os.SCHED_FIFO
    assert seen["text"].startswith("real-time" if fifo else "normal")


def test_run_live_reports_its_scheduling(settings) -> None:
    from dataclasses import replace

    inp, stop = LiveInput(settings.to_master(settings.start_tip)), threading.Event()
    stop.set()  # no period, then stop
    st = run_live(replace(settings, realtime=False), inp, stop)
    assert st.scheduling == "normal scheduling (asked for)"


def test_the_view_does_not_send_a_gizmo_position_the_input_refuses(settings) -> None:
    from rcmplan.view.live import LiveView
    from rcmplan.view.server import start_server, stop_server

    server = start_server("127.0.0.1", 0)
    view = LiveView(server, settings)
    try:
        view.stop_event.set()  # no redraw (it sends too) while the pushes are counted
        view.redraw.join()
        before = view.input.pushes
        view.gizmo.position = np.array([5.0, 0.0, 0.0])  # 5 m from the base
        view.send()
        assert view.input.pushes == before
        assert "position_m" in view.refused
        view.gizmo.position = settings.start_tip
        view.send()
        assert view.input.pushes == before + 1 and view.refused == ""
    finally:
        view.close()
        stop_server(server)


def test_the_clutch_checkbox_lets_the_gizmo_move_alone_and_the_needle_moves_on_from_there(
    settings,
) -> None:
    from rcmplan.view.live import LiveView
    from rcmplan.view.server import start_server, stop_server

    server = start_server("127.0.0.1", 0)
    view = LiveView(server, settings)
    start = np.asarray(settings.start_tip)
    try:
        probe_wait(lambda: view.state()["period"] > 100)
        tip0 = np.array(view.state()["tip_m"])
        view.clutch.value = False
        view.gizmo.position = start + np.array([2e-3, 0.0, 0.0])  # the redraw thread sends it
        probe_wait(lambda: view.state()["status"].startswith("released"))
        time.sleep(0.3)
        np.testing.assert_allclose(view.state()["tip_m"], tip0, atol=1e-12)  # the needle held
        view.clutch.value = True
        view.send()  # engaged with the gizmo 2 mm from the needle: the session re-indexes
        probe_wait(lambda: not view.state()["status"].startswith("released"))
        np.testing.assert_allclose(view.state()["goal_m"], tip0, atol=1e-9)  # no jump
        view.gizmo.position = start + np.array([2e-3, 1e-3, 0.0])  # 1 mm on from there
        goal = tip0 + np.array([0.0, 1e-3, 0.0])
        probe_wait(lambda: np.linalg.norm(np.subtract(view.state()["tip_m"], goal)) < 1e-6)
        assert view.state()["max_rcm_deviation_m"] <= 1e-6
    finally:
        view.close()
        stop_server(server)


def probe_wait(check, timeout_s: float = 30.0) -> None:
    from browser_probe import wait_for

    wait_for(check, timeout_s, 0.01)


def test_a_redraw_cut_short_by_visers_race_does_not_stop_the_view(settings, monkeypatch) -> None:
    from rcmplan.view.live import LiveView
    from rcmplan.view.server import start_server, stop_server

    server = start_server("127.0.0.1", 0)
    view = LiveView(server, settings)
    show, calls = view.panel.show, []

    def racing(rows):  # type: ignore[no-untyped-def]
        calls.append(1)
        if len(calls) == 1:  # as viser's asyncio.Event.set raised once from the redraw thread
            raise RuntimeError("deque mutated during iteration")
        return show(rows)

    monkeypatch.setattr(view.panel, "show", racing)
    try:
        probe_wait(lambda: view.state()["view_updates"] > 5, timeout_s=10.0)
        assert view.redraw.is_alive() and view.state()["view_races"] == 1
    finally:
        view.close()
        stop_server(server)
