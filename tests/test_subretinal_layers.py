"""Retina layers on the posterior wall: depths, the RPE, the target, against closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rcmplan.exceptions import InvalidInputError
from rcmplan.scene.eye import Eye
from rcmplan.subretinal.layers import (
    THICKNESS_RANGE_M,
    RetinaLayers,
    depth_below_ilm,
    in_target_band,
    incidence_rad,
    past_rpe,
    target_point,
)


def test_the_default_layers_sit_on_the_default_eye() -> None:
    eye = Eye(center=np.zeros(3), trocar=np.array([0.0, 0.0, -12e-3]))
    layers = RetinaLayers.from_eye(eye)
    assert layers.ilm_radius_m == pytest.approx(eye.retina_radius) == pytest.approx(11e-3)
    assert layers.rpe_radius_m == pytest.approx(11e-3 + 250e-6)
    assert layers.sclera_radius_m == pytest.approx(11.45e-3)
    assert layers.sclera_m == pytest.approx(12e-3 - 11.45e-3)
    assert layers.band_m == pytest.approx((0.4 * 250e-6, 0.6 * 250e-6))


def test_depth_below_the_ilm_is_the_radial_distance_from_the_ilm_sphere(
    rng: np.random.Generator,
) -> None:
    layers = RetinaLayers()
    dirs = rng.normal(size=(50, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    radii = rng.uniform(10.5e-3, 11.5e-3, size=50)
    points = dirs * radii[:, None]
    depth = depth_below_ilm(layers, points)
    assert np.shape(depth) == (50,)
    np.testing.assert_allclose(depth, radii - 11e-3, atol=1e-15)
    moved = depth_below_ilm(layers, points, displacement_m=30e-6)
    np.testing.assert_allclose(moved, radii - 11e-3 - 30e-6, atol=1e-15)
    assert depth_below_ilm(layers, points[0]) == pytest.approx(radii[0] - 11e-3, abs=1e-15)


def test_a_point_past_the_rpe_is_reported_with_its_excess_depth() -> None:
    layers = RetinaLayers(thickness_m=300e-6)
    n = np.array([0.6, 0.0, 0.8])
    beyond = past_rpe(layers, (11e-3 + 310e-6) * n)
    assert beyond.past is True and beyond.by_m == pytest.approx(10e-6)
    short = past_rpe(layers, (11e-3 + 290e-6) * n)
    assert short.past is False and short.by_m == pytest.approx(-10e-6)
    # the wall moved 20 um outwards: the same point is now short of the RPE
    assert past_rpe(layers, (11e-3 + 310e-6) * n, displacement_m=20e-6).past is False


def test_the_target_lies_on_the_ray_at_the_target_fraction_of_the_thickness() -> None:
    layers = RetinaLayers(thickness_m=260e-6, target_fraction=0.4, band_fraction=0.1)
    p = target_point(layers, [1.0, 2.0, 2.0], displacement_m=-15e-6)
    assert np.linalg.norm(p) == pytest.approx(11e-3 - 15e-6 + 0.4 * 260e-6)
    np.testing.assert_allclose(p / np.linalg.norm(p), np.array([1.0, 2.0, 2.0]) / 3.0)
    depth = depth_below_ilm(layers, p, displacement_m=-15e-6)
    assert depth == pytest.approx(0.4 * 260e-6)
    assert in_target_band(layers, depth) is True
    assert list(in_target_band(layers, [0.29 * 260e-6, 0.31 * 260e-6, 0.51 * 260e-6])) == [
        False, True, False,
    ]  # fmt: skip


def test_incidence_is_zero_at_the_pole_and_matches_the_law_of_cosines_elsewhere() -> None:
    layers = RetinaLayers()
    trocar = np.array([0.0, 0.0, -12e-3])
    assert incidence_rad(layers, [0.0, 0.0, 1.0], trocar) == pytest.approx(0.0, abs=1e-12)
    alpha = math.radians(60.0)
    n = np.array([math.sin(alpha), 0.0, math.cos(alpha)])
    # triangle centre-trocar-ILM point: sides 12 mm and 11 mm with angle pi - alpha between
    side = math.sqrt(12e-3**2 + 11e-3**2 + 2 * 12e-3 * 11e-3 * math.cos(alpha))
    # the angle at the ILM point between the normal (away from the centre) and the ray from
    # the trocar, by the law of sines: sin(angle) = 12 mm sin(pi - alpha) / side
    expected = math.asin(12e-3 * math.sin(alpha) / side)
    assert incidence_rad(layers, n, trocar) == pytest.approx(expected)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("thickness_m", 200e-6),
        ("thickness_m", 400e-6),
        ("target_fraction", 1.0),
        ("band_fraction", 0.3),
        ("choroid_m", -1e-6),
        ("eye_radius_m", 11.2e-3),
    ],
)
def test_a_layer_parameter_out_of_range_raises_naming_it(field: str, value: float) -> None:
    kwargs = {field: value}
    if field == "band_fraction":
        kwargs["target_fraction"] = 0.8
    with pytest.raises(InvalidInputError) as err:
        RetinaLayers(**kwargs)
    assert err.value.name == field


def test_the_thickness_range_is_the_published_one_and_named_in_the_error() -> None:
    assert THICKNESS_RANGE_M == (238e-6, 340e-6)
    with pytest.raises(InvalidInputError, match=r"thickness_m = 0\.0005.*\[0\.000238, 0\.00034\]"):
        RetinaLayers(thickness_m=500e-6)


def test_bad_points_and_directions_raise() -> None:
    layers = RetinaLayers()
    with pytest.raises(InvalidInputError):
        depth_below_ilm(layers, [1.0, 2.0])
    with pytest.raises(InvalidInputError):
        depth_below_ilm(layers, [np.nan, 0.0, 0.0])
    with pytest.raises(InvalidInputError):
        target_point(layers, [0.0, 0.0, 0.0])
    with pytest.raises(InvalidInputError):
        in_target_band(layers, [np.inf])
