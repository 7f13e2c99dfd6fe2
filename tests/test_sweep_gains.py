"""Gain search: the best candidate meets the stated constraints on its subsample."""

from __future__ import annotations

import math

import pytest

from rcmplan.sweep.executors import LocalExecutor
from rcmplan.sweep.gains import (
    Candidate,
    Objective,
    Search,
    evaluate,
    grid_search,
    optimize_search,
    subsample,
)
from rcmplan.sweep.sampling import sample_region
from rcmplan.sweep.settings import MotionSettings, Region, SweepSettings
from rcmplan.sweep.task import run_target

BASE = SweepSettings(
    Region(max_angle=math.radians(15), n_targets=12),
    MotionSettings(step_position=0.5e-3, step_angle=5e-3),
)
OBJECTIVE = Objective(rcm_bound_m=10e-6)


@pytest.fixture(scope="module")
def sample():
    return sample_region(BASE.region, BASE.motion)


def meets_constraints(candidate: Candidate, sample, ids, bound: float) -> bool:
    motion = candidate.motion(BASE.motion)
    results = [run_target(motion, int(i), sample.points[i]) for i in ids]
    return (
        all(r.converged for r in results) and max(r.max_rcm_deviation_m for r in results) <= bound
    )


def test_grid_search_picks_the_fewest_iterations_within_the_rcm_bound(sample) -> None:
    ids = subsample(sample, 3)
    grid = {"k_task": (1.0,), "k_rcm": (0.8, 1.0), "step_position": (0.5e-3, 2e-3)}
    with LocalExecutor(1) as ex:
        result = grid_search(Search(BASE, sample, ids, ex, OBJECTIVE), grid)
    assert len(result.evaluations) == 4
    best = result.best
    assert best is not None and best.feasible
    feasible = [e for e in result.evaluations if e.feasible]
    assert best.mean_iterations == min(e.mean_iterations for e in feasible)
    assert meets_constraints(best.candidate, sample, ids, OBJECTIVE.rcm_bound_m)


def test_the_optimiser_returns_a_candidate_that_meets_the_constraints(sample) -> None:
    ids = subsample(sample, 2)
    with LocalExecutor(1) as ex:
        result = optimize_search(Search(BASE, sample, ids, ex, OBJECTIVE), max_evaluations=6)
    assert result.mode == "optimize" and 1 <= len(result.evaluations) <= 7
    assert result.best is not None
    assert meets_constraints(result.best.candidate, sample, ids, OBJECTIVE.rcm_bound_m)


def test_a_violated_bound_is_infeasible_and_penalised(sample) -> None:
    ids = subsample(sample, 2)
    c = Candidate(1.0, 1.0, 0.5e-3)
    results = [run_target(c.motion(BASE.motion), int(i), sample.points[i]) for i in ids]
    strict = evaluate(c, results, Objective(rcm_bound_m=1e-12))
    loose = evaluate(c, results, Objective(rcm_bound_m=1e-3))
    assert not strict.feasible and loose.feasible
    assert strict.cost > loose.cost == loose.mean_iterations


def test_candidates_set_gains_and_keep_the_step_ratio() -> None:
    m = Candidate(0.9, 1.1, 1e-3).motion(BASE.motion)
    assert m.K == (0.9, 0.9, 0.9, 1.1, 1.1, 1.1)
    assert m.step_angle / m.step_position == pytest.approx(10.0)


def test_subsample_spreads_over_the_reachable_targets(sample) -> None:
    ids = subsample(sample, 4)
    assert len(ids) == 4 and set(ids) <= set(sample.reachable_ids)
    assert len(subsample(sample, 10_000)) == sample.reachable_ids.size
