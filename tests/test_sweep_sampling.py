"""Sampling of retina targets: the cone, the retina, reachability, empty regions."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rcmplan import Iramis
from rcmplan.control.targets import rcm_target, solve_pose
from rcmplan.exceptions import InvalidInputError, UnreachableTargetError
from rcmplan.sweep.errors import EmptyRegionError
from rcmplan.sweep.sampling import REACHABLE, UNREACHABLE, sample_region
from rcmplan.sweep.settings import MotionSettings, Region

MOTION = MotionSettings()


def angles_from_axis(sample, eye_axis) -> np.ndarray:
    return np.arccos(np.clip(sample.directions @ eye_axis, -1.0, 1.0))


@pytest.mark.parametrize("sampling", ["grid", "random"])
def test_every_ray_lies_within_the_cone(sampling: str) -> None:
    region = Region(max_angle=math.radians(20), n_targets=200, sampling=sampling, seed=3)
    sample = sample_region(region, MOTION)
    axis = MOTION.eye(Iramis()).axis
    assert np.all(angles_from_axis(sample, axis) <= region.max_angle + 1e-12)
    assert np.allclose(np.linalg.norm(sample.tilt, axis=1), angles_from_axis(sample, axis))


def test_grid_is_deterministic_and_random_depends_on_the_seed() -> None:
    a = sample_region(Region(n_targets=50), MOTION)
    b = sample_region(Region(n_targets=50), MOTION)
    assert np.array_equal(a.points, b.points)
    r1 = sample_region(Region(n_targets=50, sampling="random", seed=1), MOTION)
    r1b = sample_region(Region(n_targets=50, sampling="random", seed=1), MOTION)
    r2 = sample_region(Region(n_targets=50, sampling="random", seed=2), MOTION)
    assert np.array_equal(r1.points, r1b.points)
    assert not np.allclose(r1.points, r2.points)


def test_targets_lie_on_the_retina_short_by_the_standoff() -> None:
    eye = MOTION.eye(Iramis())
    on = sample_region(Region(n_targets=30), MOTION)
    off = sample_region(Region(n_targets=30, standoff=0.5e-3), MOTION)
    assert np.allclose([eye.distance_to_retina(p) for p in on.points], 0.0, atol=1e-12)
    assert np.allclose([eye.distance_to_retina(p) for p in off.points], 0.5e-3, atol=1e-4)


def test_reachability_agrees_with_the_closed_form_pose(robot: Iramis) -> None:
    sample = sample_region(Region(n_targets=400), MOTION)  # most cleared by the screen
    assert set(np.unique(sample.status)) == {REACHABLE, UNREACHABLE}
    for i in range(len(sample)):
        target = rcm_target(sample.points[i], sample.trocar)
        if sample.status[i] == REACHABLE:
            solve_pose(robot, target)
        else:
            assert sample.reasons[i]
            with pytest.raises(UnreachableTargetError):
                solve_pose(robot, target)


def test_a_narrow_cone_is_reachable_everywhere() -> None:
    sample = sample_region(Region(max_angle=math.radians(5), n_targets=40), MOTION)
    assert sample.counts() == {"reachable": 40, "misses_retina": 0, "unreachable": 0}


def test_raises_when_no_target_in_the_region_is_reachable() -> None:
    with pytest.raises(EmptyRegionError, match="none of the 3 retina targets") as info:
        sample_region(Region(max_angle=math.radians(80), n_targets=3), MOTION)
    assert info.value.counts["reachable"] == 0


@pytest.mark.parametrize(
    "kwargs", [{"n_targets": 0}, {"max_angle": 0.0}, {"max_angle": 2.0}, {"sampling": "sobol"}]
)
def test_raises_on_an_empty_or_invalid_region(kwargs: dict) -> None:
    with pytest.raises(InvalidInputError):
        Region(**kwargs)
