"""Simulated iOCT: acquisition times, the needle's geometry, box-filtered edges, speckle."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rcmplan.exceptions import InvalidInputError
from rcmplan.subretinal.ioct import (
    NEEDLE_LENGTH_M,
    BScanScene,
    IoctModel,
    clean_bscan,
    reflectivity,
    render_bscan,
)


def test_volumes_come_one_period_apart_and_the_axes_are_pixel_centres() -> None:
    model = IoctModel(volume_rate_hz=9.0)
    t = model.acquisition_times(2.0)
    assert t.size == 19 and t[0] == 0.0 and t[-1] == pytest.approx(2.0)
    np.testing.assert_allclose(np.diff(t), 1 / 9.0)
    z, x = model.depth_axis_m(), model.lateral_axis_m()
    assert z[0] == pytest.approx(-model.top_m + 0.5 * 3.3e-6)
    np.testing.assert_allclose(np.diff(z), 3.3e-6)
    assert x.mean() == pytest.approx(0.0, abs=1e-15)
    np.testing.assert_allclose(np.diff(x), 12e-6)


@pytest.mark.parametrize("tilt", [0.3, -0.6, 1.1])
def test_the_needle_surface_is_the_first_point_of_the_shaft_along_each_a_line(tilt: float) -> None:
    scene = BScanScene(tip_m=(20e-6, 50e-6), needle_tilt_rad=tilt, needle_diameter_m=100e-6)
    x = np.linspace(-600e-6, 600e-6, 121)
    z = np.arange(-3e-3, 1e-3, 0.05e-6)
    s, c = math.sin(tilt), math.cos(tilt)
    dx, dz = x[None, :] - 20e-6, z[:, None] - 50e-6
    back, across = -(dx * s + dz * c), dx * c - dz * s  # written out again, not imported
    inside = (back >= 0) & (back <= NEEDLE_LENGTH_M) & (np.abs(across) <= 50e-6)
    first = np.where(inside.any(axis=0), z[np.argmax(inside, axis=0)], np.inf)
    top = scene.needle_top_m(x)
    hit = np.isfinite(first)
    assert hit.any() and np.array_equal(hit, np.isfinite(top))
    np.testing.assert_allclose(top[hit], first[hit], atol=0.06e-6)


def test_a_clean_row_is_the_mean_of_the_reflectivity_over_the_row() -> None:
    model = IoctModel()
    scene = BScanScene(ilm_offset_m=7.7e-6, tent_m=40e-6, tent_x_m=200e-6,
                       tip_m=(100e-6, -60e-6), needle_tilt_rad=0.6)  # fmt: skip
    image = clean_bscan(model, scene)
    x, z = model.lateral_axis_m(), model.depth_axis_m()
    sub = (np.arange(64) + 0.5) / 64 - 0.5
    fine = (z[:, None] + sub[None, :] * model.axial_pixel_m).ravel()
    mean = reflectivity(scene, x[None, :], fine[:, None]).reshape(z.size, 64, x.size).mean(axis=1)
    # exact where the profile is flat within a row; an edge's sides are taken at the edge,
    # which differs from their row means by the profile's slope over a fraction of a row
    assert np.abs(image - mean).max() < 0.15
    assert np.median(np.abs(image - mean)) < 1e-3


def test_a_seed_renders_the_same_image_and_the_speckle_has_unit_mean() -> None:
    model = IoctModel()
    scene = BScanScene(tip_m=(-200e-6, -150e-6))
    a = render_bscan(model, scene, np.random.default_rng(5))
    b = render_bscan(model, scene, np.random.default_rng(5))
    np.testing.assert_array_equal(a, b)
    assert a.shape == (256, 96)
    rng = np.random.default_rng(6)
    linear = np.mean([10 ** (render_bscan(model, scene, rng) / 10) for _ in range(40)], axis=0)
    clean = clean_bscan(model, scene)
    tissue = clean > 0.1
    ratio = (linear[tissue] - model.noise_floor) / clean[tissue]
    assert ratio.mean() == pytest.approx(1.0, abs=0.02)
    assert linear[clean == 0].mean() == pytest.approx(model.noise_floor, rel=0.05)


def test_bad_acquisition_and_scene_parameters_raise() -> None:
    with pytest.raises(InvalidInputError) as err:
        IoctModel(volume_rate_hz=0.0)
    assert err.value.name == "volume_rate_hz"
    with pytest.raises(InvalidInputError):
        IoctModel(depth_px=10)
    with pytest.raises(InvalidInputError):
        BScanScene(needle_tilt_rad=0.0)
    with pytest.raises(InvalidInputError):
        BScanScene(tent_m=-1e-6)
