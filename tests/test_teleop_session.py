"""Teleoperated sessions: the fixtures hold while the input pushes through them, the clutch
holds the needle and re-engages without a jump, bad settings stop before motion, live input
is paced and stops on its event, and an interrupt keeps the partial result."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from rcmplan.exceptions import InvalidInputError
from rcmplan.teleop import LiveInput, SyntheticSurgeon, TeleopSettings, run_live, run_replay
from rcmplan.teleop.motion_plan import MotionPlan, Move
from rcmplan.teleop.summary import summary
from rcmplan.teleop.violations import KINDS, retina_distance

MM = 1e-3
# Released while the filter settles, then 2.5 mm towards the retina (0.75 mm past the margin),
# released while pushing, the hand pulls back, re-engaged, then 0.5 mm sideways.
PUSH = MotionPlan(
    duration=4.0,
    moves=(Move(0.8, 1.6, (0.0, 0.0, 50 * MM)), Move(2.7, 0.4, (0.0, 0.0, -50 * MM)),
           Move(3.3, 0.6, (10 * MM, 0.0, 0.0))),
    released=((0.0, 0.6), (2.5, 3.2)),
)  # fmt: skip
REQUIRED = ("status", "max_rcm_deviation_m", "tip_tremor_rms_m", "input_tremor_rms_m",
            "tracking_rms_m", "added_lag_s", "limit_violations", "retina_min_distance_m")  # fmt: skip


@pytest.fixture(scope="module")
def pushed():
    settings = TeleopSettings()
    return settings, run_replay(settings, SyntheticSurgeon(plan=PUSH, seed=2).track())


def test_a_push_through_the_retina_margin_is_held_at_the_margin(pushed) -> None:
    settings, result = pushed
    margin = settings.fixtures.retina_margin
    eye = result.session.eye
    assert result.status == "ok", result.message
    assert retina_distance(eye, result.trace.desired).min() < margin - 0.5 * MM  # pushed past
    assert retina_distance(eye, result.log.tip).min() >= margin - 1e-9  # never crossed
    assert result.violations == dict.fromkeys(KINDS, 0)


def test_the_rcm_stays_within_its_limit_on_the_kinematic_plant(pushed) -> None:
    settings, result = pushed
    deviation = np.linalg.norm(result.log.rcm - result.log.trocar, axis=1)
    assert deviation.max() <= settings.fixtures.rcm_limit


def test_released_past_the_fixture_the_needle_holds_and_the_summary_says_so(pushed) -> None:
    _, result = pushed
    doc = summary(result)
    released = [e for e in doc["clutch_events"] if e["kind"] == "released"]
    assert doc["released_past_fixture"][0]["t_s"] == released[-1]["t_s"]
    assert "retina" in doc["released_past_fixture"][0]["fixtures"]
    t = result.log.time
    held = (t > 2.5) & (t < 3.2)
    tips = result.log.tip[held]
    assert np.abs(tips - tips[0]).max() < 1e-9  # the needle holds while released


def test_re_engaging_starts_the_desired_tip_at_the_needle(pushed) -> None:
    _, result = pushed
    engaged = result.trace.engaged
    starts = np.flatnonzero(engaged[1:] & ~engaged[:-1]) + 1
    assert starts.size == 2
    for k in starts:
        assert result.trace.desired[k] == pytest.approx(result.log.tip[k], abs=1e-15)
    jumps = np.linalg.norm(np.diff(result.log.tip, axis=0), axis=1)
    assert jumps[starts[-1] - 1 : starts[-1] + 50].max() < 5e-6  # no jump after re-engaging


def test_the_summary_has_every_field_other_checks_rely_on(pushed) -> None:
    _, result = pushed
    doc = summary(result)
    for key in REQUIRED:
        assert key in doc
    assert set(doc["limit_violations"]) == set(KINDS)
    assert doc["tip_tremor_rms_m"] < doc["input_tremor_rms_m"]
    assert doc["fixture_active_s"]["retina"] > 0.0


def test_a_start_tip_past_the_margin_is_refused_before_motion() -> None:
    with pytest.raises(InvalidInputError, match="retina margin"):
        run_replay(TeleopSettings(start_tip=(0.0, 0.0, 10.9 * MM)), SyntheticSurgeon().track())


def test_a_start_tip_outside_the_workspace_is_refused_before_motion() -> None:
    with pytest.raises(InvalidInputError, match="workspace"):
        run_replay(TeleopSettings(start_tip=(7 * MM, 0.0, 5 * MM)), SyntheticSurgeon().track())


@pytest.mark.parametrize("bad", [{"scale": 60.0}, {"filter": "kalman"}, {"plant": "real"}])
def test_bad_settings_are_refused(bad) -> None:
    with pytest.raises(InvalidInputError):
        TeleopSettings(**bad)


def test_an_interrupt_keeps_the_partial_session() -> None:
    def stop(state) -> None:
        if state.t >= 0.2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt) as info:
        run_replay(TeleopSettings(), SyntheticSurgeon(plan=PUSH).track(), on_period=stop)
    result = info.value.result  # type: ignore[attr-defined]
    assert result.status == "interrupted"
    assert len(result.log) == len(result.trace) == 201


def test_live_input_drives_the_needle_until_the_stop_event() -> None:
    live = LiveInput()
    stop = threading.Event()
    states = []
    settings = TeleopSettings(scale=10.0, filter="none")

    def on_period(state) -> None:
        states.append(state)
        k = len(states)
        live.push([min(k, 200) * 1e-5, 0.0, 0.0], clutch=True)  # 2 mm of hand, then still
        if k == 400:
            stop.set()

    result = run_live(settings, live, stop, on_period)
    assert result.status == "ok"
    assert len(states) == len(result.log) == 400
    first, last = states[0], states[-1]
    assert not first.engaged  # nothing was pushed before the first period
    R = result.session.pipeline.scaling.rotation
    moved = R.T @ (last.tip - first.tip)  # in the master (eye) frame
    assert moved == pytest.approx([2e-3 / 10.0, 0.0, 0.0], abs=2e-6)
    assert last.rcm_deviation <= settings.fixtures.rcm_limit
    assert result.pacing["periods"] == 400


def test_a_live_input_that_stops_sending_counts_as_released() -> None:
    live = LiveInput()
    stop = threading.Event()
    sent: list[float] = []

    def on_period(state) -> None:
        if len(sent) < 20:  # the device sends for 20 periods, then goes silent
            live.push([0.0, 0.0, 0.0], clutch=True)
            sent.append(state.t)
        elif live.latest().t < time.monotonic() - 0.1:
            stop.set()  # 100 ms of silence: long past `stale_after`

    result = run_live(TeleopSettings(stale_after=0.05), live, stop, on_period)
    engaged = result.trace.engaged
    assert engaged[1:20].all()  # fresh while it sends
    assert not engaged[-5:].any()  # stale: released, the needle holds


def test_on_the_mujoco_plant_the_margin_holds_and_the_needle_holds_when_released() -> None:
    pytest.importorskip("mujoco", reason="the MuJoCo plant needs the sim extra")
    settings = TeleopSettings(plant="mujoco")
    result = run_replay(settings, SyntheticSurgeon(plan=PUSH, seed=2).track())
    assert result.status in ("ok", "limit_violated"), result.message
    eye, margin = result.session.eye, settings.fixtures.retina_margin
    assert retina_distance(eye, result.trace.desired).min() < margin - 0.5 * MM
    assert retina_distance(eye, result.log.tip).min() >= margin - 1e-9
    assert result.violations["retina"] == result.violations["workspace"] == 0
    deviation = np.linalg.norm(result.log.rcm - result.log.trocar, axis=1)
    assert deviation.max() < 10e-6  # the MuJoCo plant's floor for the injection (README)
    t = result.log.time
    tips = result.log.tip[(t > 2.6) & (t < 3.2)]  # released; the servo settles in 0.1 s
    assert np.abs(tips - tips[0]).max() < 1e-6


@pytest.mark.parametrize(
    ("tip", "inp", "expected"),
    [(20e-6, 100e-6, 0.8), (1.1e-7, 5.7e-8, None), (1e-6, None, None), (None, 1e-4, None)],
)
def test_tremor_reduction_is_given_only_for_an_input_with_tremor(
    tip: float | None, inp: float | None, expected: float | None
) -> None:
    from rcmplan.teleop.metrics import summary_band

    ratio = summary_band({"tip_tremor_rms_m": tip, "input_tremor_rms_m": inp})["tremor_reduction"]
    assert ratio == pytest.approx(expected) if expected is not None else ratio is None
