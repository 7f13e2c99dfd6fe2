"""The segmentation's kernels against scipy.ndimage and numpy written on the whole image: the
Gaussian filters and their edge modes, the gradient, the step detector, the shadow's start and
the outlier test."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from rcmplan.subretinal.segment import SegmentationSettings, segment_bscan
from rcmplan.subretinal.segment_filters import (
    gaussian_taps,
    gradients,
    smooth_across,
    step_detector,
)
from rcmplan.subretinal.segment_kernels import inliers, shadow_start

RNG = np.random.default_rng(11)
LINES = RNG.normal(size=(12, 40)).cumsum(axis=1)  # 12 A-lines of 40 rows, A-line by A-line


@pytest.mark.parametrize("sigma", [0.4, 1.5, 2.0, 12.0])
def test_smoothing_across_a_lines_is_scipys_gaussian_with_the_edge_a_line_repeated(
    sigma: float,
) -> None:
    out = smooth_across(LINES, sigma, np.empty_like(LINES))
    expected = ndimage.gaussian_filter1d(LINES, sigma, axis=0, mode="nearest")
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("sigma", [1.0, 1.5, 15.0])  # 15: the filter reaches past both ends
def test_the_gradient_is_numpys_of_scipys_gaussian_reflected_at_the_ends(sigma: float) -> None:
    line = LINES[3]
    expected = np.gradient(ndimage.gaussian_filter1d(line, sigma, mode="reflect"))
    out = np.empty(line.size)
    gradients(line, 0, line.size, gaussian_taps(sigma), out)
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-12)
    part = np.empty(5)
    gradients(line, 17, 22, gaussian_taps(sigma), part)  # a few rows alone read the same
    np.testing.assert_allclose(part, expected[17:22], rtol=0, atol=1e-12)


def test_a_zero_sigma_smooths_nothing() -> None:
    assert gaussian_taps(0.0).tolist() == [1.0]
    np.testing.assert_array_equal(smooth_across(LINES, 0.0, np.empty_like(LINES)), LINES)


def test_the_step_detector_is_the_difference_of_the_window_means() -> None:
    n, rows = 4, LINES.shape[1]
    out = np.empty_like(LINES)
    step_detector(LINES, n, out)
    expected = np.zeros_like(LINES)
    for k in range(n, rows - n + 1):
        expected[:, k] = LINES[:, k : k + n].mean(axis=1) - LINES[:, k - n : k].mean(axis=1)
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-12)


def test_the_shadow_starts_where_the_dark_run_to_the_bottom_starts() -> None:
    linear = RNG.exponential(1.0, size=(30, 60))
    linear[:10, 35:] *= 0.01  # dark from row 35 down
    linear[10:20, 55:] *= 0.01  # dark from row 55: 5 rows, shorter than the least run
    out = np.empty(30, dtype=np.int64)
    shadow_start(linear, 0.2, 10, out)
    dark = ndimage.uniform_filter1d(linear, 7, axis=1, mode="nearest") < 0.2
    run = np.flip(np.cumprod(np.flip(dark, axis=1), axis=1), axis=1).sum(axis=1)
    np.testing.assert_array_equal(out, np.where(run >= 10, 60 - run, 60))
    assert (out[:10] <= 38).all() and (out[10:20] == 60).all()


@pytest.mark.parametrize("count", [1, 2, 3, 4, 5, 17])
def test_the_outlier_test_is_scipys_median_filter_over_the_valid_a_lines(count: int) -> None:
    profile = RNG.normal(0.0, 1e-5, size=24)
    valid = np.zeros(24, dtype=bool)
    valid[RNG.choice(24, size=count, replace=False)] = True
    keep = inliers(profile, valid, 0.7e-5)
    values = profile[valid]
    ref = ndimage.median_filter(values, size=min(5, count), mode="mirror")
    expected = np.zeros(24, dtype=bool)
    expected[valid] = np.abs(values - ref) <= 0.7e-5
    np.testing.assert_array_equal(keep, expected)


def test_a_b_scan_stored_either_way_is_segmented_alike() -> None:
    from rcmplan.subretinal.ioct import BScanScene, IoctModel, render_bscan

    model = IoctModel()
    image = render_bscan(model, BScanScene(tip_m=(50e-6, -40e-6)), np.random.default_rng(3))
    a = segment_bscan(np.ascontiguousarray(image), model, 11e-3, 100e-6)
    b = segment_bscan(np.asfortranarray(image), model, 11e-3, 100e-6)
    c = segment_bscan(np.asfortranarray(image), model, 11e-3, 100e-6, SegmentationSettings())
    for x, y in ((a, b), (a, c)):
        np.testing.assert_array_equal(x.ilm_m, y.ilm_m)
        np.testing.assert_array_equal(x.needle_top_m, y.needle_top_m)
        assert x.tip_m == y.tip_m and x.ilm_offset_m == y.ilm_offset_m
    assert a.tip_m is not None
