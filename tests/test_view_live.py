"""Live control of the view without a browser: the tip follows the input with the RCM held,
the retina fixture keeps it off the retina, a limit holds the needle, the period is counted."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from rcmplan.exceptions import InvalidInputError
from rcmplan.view.live import live_settings
from rcmplan.view.live_control import LiveInput, LiveLoop, LiveSample, fixture, run_live


@pytest.fixture(scope="module")
def settings():
    return live_settings("default", None, "kinematic")


def follow(loop: LiveLoop, goal: np.ndarray, periods: int) -> float:
    """Step towards goal; the largest RCM deviation seen [m]."""
    worst = 0.0
    for _ in range(periods):
        worst = max(worst, loop.step(LiveSample(0.0, goal, True)).rcm_deviation)
    return worst


@pytest.mark.parametrize("robot", ["iramis", "ur5"])
def test_the_tip_reaches_the_input_with_the_rcm_held(robot) -> None:
    s = live_settings("default", robot, "kinematic")
    loop = LiveLoop(s)
    goal = s.start_tip + np.array([1.5e-3, -1e-3, 0.5e-3])
    worst = follow(loop, goal, 400)  # 1.9 mm at 20 mm/s: 95 periods, then settled
    st = loop.step(LiveSample(0.0, goal, True))
    np.testing.assert_allclose(st.tip, goal, atol=1e-9)
    assert worst <= 1e-6
    assert st.status == "running"


def test_the_setpoint_moves_at_most_max_speed_per_period(settings) -> None:
    loop = LiveLoop(settings)
    goal = settings.start_tip + np.array([0.0, 3e-3, 0.0])
    st = loop.step(LiveSample(0.0, goal, True))
    step = np.linalg.norm(st.setpoint - settings.start_tip)
    assert step == pytest.approx(settings.max_speed * settings.dt)


def test_an_input_beyond_the_retina_is_held_off_it_by_the_margin(settings) -> None:
    eye = settings.eye
    outside = eye.center + 2 * eye.radius * np.array([0.0, 0.0, 1.0])
    held = fixture(settings, outside)
    assert eye.distance_to_retina(held) == pytest.approx(settings.retina_margin)
    inside = settings.start_tip
    np.testing.assert_array_equal(fixture(settings, inside), inside)


def test_a_released_clutch_holds_the_needle(settings) -> None:
    loop = LiveLoop(settings)
    start = loop.step(LiveSample(0.0, settings.start_tip, True)).tip.copy()
    for _ in range(50):
        st = loop.step(LiveSample(0.0, settings.start_tip + 2e-3, False))
    np.testing.assert_allclose(st.tip, start, atol=1e-12)


def test_a_limit_holds_the_needle_and_its_setpoint_and_says_why() -> None:
    s = live_settings("default", "iramis", "kinematic")
    loop = LiveLoop(s)
    far = s.start_tip + np.array([0.0, 0.0, 20e-3])  # pulled up: a PCJM leaves its travel
    for _ in range(2000):
        st = loop.step(LiveSample(0.0, far, True))
        if st.status.startswith("held"):
            break
    assert st.status.startswith("held: ActuatorLimitError")
    tip = st.tip.copy()
    worst = follow(loop, far, 50)
    np.testing.assert_allclose(loop.state.tip, tip, atol=1e-12)
    assert worst <= 1e-6


def test_run_live_counts_its_periods_against_wall_time(settings) -> None:
    inp, stop = LiveInput(settings.start_tip), threading.Event()
    out = {}
    th = threading.Thread(target=lambda: out.setdefault("st", run_live(settings, inp, stop)))
    start = time.perf_counter()
    th.start()
    time.sleep(0.3)
    stop.set()
    th.join()
    elapsed = time.perf_counter() - start
    st = out["st"]
    assert st.period > 0 and 0 <= st.missed <= st.slots
    assert st.slots <= elapsed / settings.dt + 1  # periods are wall-clock periods
    assert st.slots - st.missed <= st.period <= st.slots + 1  # on-time steps <= steps run
    assert st.t_s == pytest.approx((st.period - 1) * settings.dt)  # one plant period per step


def test_live_refuses_a_curved_needle() -> None:
    with pytest.raises(InvalidInputError, match="straight"):
        live_settings("curved", None, "kinematic")


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

    inp, stop = LiveInput(settings.start_tip), threading.Event()
    stop.set()  # one period, then stop
    st = run_live(replace(settings, realtime=False), inp, stop)
    assert st.scheduling == "normal scheduling (asked for)"
