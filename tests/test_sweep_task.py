"""One target's motion: determinism, figures, records."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rcmplan.controller import Controller
from rcmplan.exceptions import (
    ConvergenceError,
    QPError,
    RcmBoundError,
    RcmplanError,
    SingularPoseError,
    SliderLimitError,
    UnreachableTargetError,
)
from rcmplan.sweep.report import status_counts
from rcmplan.sweep.sampling import STATUS_NAMES, sample_region
from rcmplan.sweep.settings import MotionSettings, Region, SweepSettings
from rcmplan.sweep.task import STATUSES, TargetResult, run_chunk, run_target

FAST = MotionSettings(step_position=1e-3, step_angle=1e-2)


@pytest.fixture(scope="module")
def sample():
    return sample_region(Region(max_angle=math.radians(15), n_targets=12), FAST)


def test_a_target_gives_the_same_result_every_time(sample) -> None:
    i = int(sample.reachable_ids[3])
    a = run_target(FAST, i, sample.points[i])
    b = run_target(FAST, i, sample.points[i].tolist())
    assert a.identity() == b.identity()


def test_a_reachable_target_converges_with_small_errors(sample) -> None:
    i = int(sample.reachable_ids[0])
    r = run_target(FAST, i, sample.points[i])
    assert r.converged and r.status == "ok" and r.message == ""
    assert r.iterations > 0 and r.wall_time_s > 0
    assert r.tip_error_m is not None and r.tip_error_m < 1e-7
    assert r.max_rcm_deviation_m is not None and r.max_rcm_deviation_m < 50e-6


def test_a_chunk_keeps_ids_and_order(sample) -> None:
    ids = [int(i) for i in sample.reachable_ids[:3]]
    out = run_chunk(FAST, [(i, sample.points[i].tolist()) for i in ids])
    assert [r.id for r in out] == ids


def test_an_iteration_cap_too_small_is_recorded_as_no_convergence(sample) -> None:
    tight = MotionSettings(step_position=1e-3, step_angle=1e-2, max_iterations=1)
    i = int(sample.reachable_ids[0])
    r = run_target(tight, i, sample.points[i])
    assert r.status == ConvergenceError.status == "no_convergence" and not r.converged
    assert "ConvergenceError" in r.message


def test_a_motion_stopped_by_the_rcm_bound_is_recorded_with_the_single_run_status(sample) -> None:
    # 0.05 um: below what the motion to a target 15 deg off-axis deviates (its deviation under
    # the default 45 um bound is checked to exceed it first)
    i = int(sample.reachable_ids[0])
    free = run_target(FAST, i, sample.points[i])
    assert free.status == "ok" and free.max_rcm_deviation_m > 0.05e-6
    tight = MotionSettings(step_position=1e-3, step_angle=1e-2, rcm_bound=0.05e-6)
    r = run_target(tight, i, sample.points[i])
    assert r.status == RcmBoundError.status == "rcm_bound_exceeded" and not r.converged
    assert r.message.startswith("RcmBoundError: RCM bound exceeded in phase 'to-target'")
    assert r.iterations > 0 and r.max_rcm_deviation_m > 0.05e-6


STOPS = [
    UnreachableTargetError("lambda outside [0, 1]"),
    SingularPoseError(np.zeros(6), 1e-9, 1e-6),
    SliderLimitError(0, "L1", 0.02, -0.01, 0.01),
    QPError("the QP is infeasible"),  # one no sweep status is listed for: counted all the same
]


@pytest.mark.parametrize("error", STOPS, ids=lambda e: type(e).__name__)
def test_a_stopped_motion_has_the_status_a_run_summary_gives_its_error(
    error: RcmplanError, sample, monkeypatch: pytest.MonkeyPatch
) -> None:
    def stop(self: Controller, phases: object) -> None:
        raise error

    monkeypatch.setattr(Controller, "run", stop)
    i = int(sample.reachable_ids[0])
    r = run_target(FAST, i, sample.points[i])
    assert r.status == error.status and not r.converged  # as `job.run_scenario` reports it
    assert r.message.startswith(f"{type(error).__name__}: ")


def test_the_summary_counts_each_status_a_motion_reports() -> None:
    def result(i: int, status: str) -> TargetResult:
        return TargetResult(i, status, 10, None, None, 0.0)

    counts = status_counts([result(0, "ok"), result(1, "qp_failed"), result(2, "ok")])
    assert list(counts) == [*STATUSES, "qp_failed"]
    assert counts["ok"] == 2 and counts["qp_failed"] == 1 and sum(counts.values()) == 3


def test_statuses_are_spelled_as_the_run_summaries_spell_them() -> None:
    errors = (ConvergenceError, UnreachableTargetError, SingularPoseError, SliderLimitError)
    assert {e.status for e in errors} <= set(STATUSES)
    assert all("-" not in s for s in (*STATUSES, *STATUS_NAMES))


def test_results_round_trip_through_a_dictionary(sample) -> None:
    i = int(sample.reachable_ids[1])
    r = run_target(FAST, i, sample.points[i])
    assert TargetResult.from_dict(r.as_dict()) == r
    with pytest.raises(KeyError):
        TargetResult.from_dict({**r.as_dict(), "extra": 1})


def test_settings_hash_changes_with_any_setting() -> None:
    a = SweepSettings(Region(n_targets=10), FAST)
    assert a.digest() == SweepSettings(Region(n_targets=10), FAST).digest()
    assert a.digest() != SweepSettings(Region(n_targets=11), FAST).digest()
    other = MotionSettings(step_position=1e-3, step_angle=1e-2, K=(0.9,) * 6)
    assert a.digest() != SweepSettings(Region(n_targets=10), other).digest()
