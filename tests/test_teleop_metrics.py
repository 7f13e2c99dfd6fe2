"""Session figures: the lag estimate finds a known delay, the band RMS measures a tremor of
known size, the reference follows the clutch mapping, and violations are counted per kind."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from rcmplan.teleop import Fixtures, SyntheticSurgeon, TeleopSettings, run_replay
from rcmplan.teleop import metrics as m
from rcmplan.teleop.motion_plan import MotionPlan, Move
from rcmplan.teleop.violations import KINDS, count, violation_masks

RATE = 1000.0


def test_the_added_lag_is_the_delay_between_two_copies_of_a_motion() -> None:
    t = np.arange(6000) / RATE
    motion = np.column_stack([1e-3 * np.sin(2 * np.pi * 0.4 * t), 5e-4 * np.cos(1.3 * t),
                              0 * t])  # fmt: skip
    delayed = np.column_stack([np.interp(t - 0.0153, t, motion[:, i]) for i in range(3)])
    mask = t > 1.0
    assert m.added_lag(delayed, motion, mask, RATE) == pytest.approx(0.0153, abs=2e-5)
    assert m.added_lag(motion, motion, mask, RATE) == pytest.approx(0.0, abs=2e-5)


def test_the_band_rms_of_a_10_hz_sinusoid_is_its_amplitude_over_root_two() -> None:
    t = np.arange(8000) / RATE
    x = np.column_stack([3e-6 * np.sin(2 * np.pi * 10 * t), 0 * t, 0 * t])
    x += np.column_stack([0 * t, 2e-3 * t, 0 * t])  # a slow drift outside the band
    mask = (t > 1.0) & (t < 7.0)
    assert m.band_rms(x, mask, RATE) == pytest.approx(3e-6 / math.sqrt(2), rel=0.01)


def test_the_reference_restarts_at_the_tip_on_each_engagement() -> None:
    tip = np.array([[0.0, 0, 0], [0.1, 0, 0], [0.2, 0, 0], [0.3, 0, 0], [0.4, 0, 0]])
    segment = np.array([-1, 0, 0, -1, 1])
    intended = np.array([[5.0, 0, 0], [5.0, 0, 0], [7.0, 0, 0], [9.0, 0, 0], [1.0, 0, 0]])
    ref = m.reference(tip, segment, intended, np.eye(3) / 10.0)
    assert np.isnan(ref[0]).all() and np.isnan(ref[3]).all()
    assert ref[[1, 2, 4], 0] == pytest.approx([0.1, 0.1 + 0.2, 0.4])


@pytest.fixture(scope="module")
def short_session():
    plan = MotionPlan(1.0, (Move(0.3, 0.5, (4e-3, 0.0, 0.0)),), released=((0.0, 0.2),))
    return run_replay(TeleopSettings(), SyntheticSurgeon(plan=plan).track())


def test_a_clean_session_counts_no_violation(short_session) -> None:
    assert short_session.violations == dict.fromkeys(KINDS, 0)


@pytest.mark.parametrize("kind", KINDS)
def test_each_kind_of_violation_is_counted_where_it_happens(short_session, kind) -> None:
    r = short_session
    s = r.session
    log = r.log
    k = 500
    tip, rcm, sliders = log.tip.copy(), log.rcm.copy(), log.sliders.copy()
    fx: Fixtures = r.settings.fixtures
    if kind == "rcm":
        rcm[k] += [0.0, 0.0, 2 * fx.rcm_limit]
    elif kind == "retina":
        tip[k] = s.eye.center + (s.eye.retina_radius - 0.5 * fx.retina_margin) * s.eye.axis
    elif kind == "workspace":
        tip[k] = s.eye.center + s.pipeline.scaling.rotation @ np.array([7e-3, 0.0, 0.0])
    elif kind == "speed":
        sliders[k:, 0] += 2 * s.robot.speed[0] * r.settings.dt
    else:  # the whole log past the travel margin (a single period would be a speed jump)
        sliders[:, 1] = s.robot.upper[1] - 0.5 * fx.travel_margin
    broken = replace(log, tip=tip, rcm=rcm, sliders=sliders)
    counts = count(violation_masks(broken, s.eye, s.box, fx, s.robot, r.settings.dt))
    periods = len(log) if kind == "travel" else 1
    assert counts == {x: periods if x == kind else 0 for x in KINDS}
