"""Segmentation of B-scans from the image alone, scored against the truth they were rendered
from, at the default noise."""

from __future__ import annotations

import numpy as np
import pytest

from rcmplan.exceptions import InvalidInputError
from rcmplan.subretinal.ioct import BScanScene, IoctModel, render_bscan
from rcmplan.subretinal.segment import Segmentation, segment_bscan
from rcmplan.subretinal.segment_error import rms_m, segmentation_error

MODEL = IoctModel()
PX = MODEL.axial_pixel_m


def random_scene(rng: np.random.Generator, tent: bool) -> BScanScene:
    """A moved retina and a needle above it (or tenting it) at a random tilt and place."""
    offset = rng.uniform(-60e-6, 60e-6)
    tip_x = rng.uniform(-300e-6, 300e-6)
    dent = rng.uniform(10e-6, 80e-6) if tent else 0.0
    tip_z = offset + dent if tent else offset - rng.uniform(20e-6, 150e-6)
    return BScanScene(
        ilm_offset_m=offset, tent_m=dent, tent_x_m=tip_x, tip_m=(tip_x, tip_z),
        needle_tilt_rad=rng.choice([-1.0, 1.0]) * rng.uniform(0.3, 0.9),
    )  # fmt: skip


@pytest.fixture(scope="module")
def scored() -> list:
    rng = np.random.default_rng(2024)
    out = []
    for k in range(60):
        scene = random_scene(rng, tent=k % 2 == 1)
        seg = segment_bscan(render_bscan(MODEL, scene, rng), MODEL, 11e-3, 100e-6)
        out.append((scene, seg, segmentation_error(seg, scene, MODEL)))
    return out


def test_layers_are_found_within_a_pixel_and_a_half_of_the_truth(scored: list) -> None:
    ilm = rms_m([e.ilm_rms_m for _, _, e in scored])
    rpe = rms_m([e.rpe_rms_m for _, _, e in scored])
    assert ilm is not None and ilm < 1.5 * PX
    assert rpe is not None and rpe < 1.5 * PX
    x = MODEL.lateral_axis_m()
    for scene, seg, _ in scored:  # where the needle does not hide the ILM, it is found
        visible = scene.needle_top_m(x) > scene.ilm_depth_m(x)
        assert seg.valid[visible].mean() > 0.9
        assert not seg.valid[~visible].any()


def test_the_ilm_offset_of_an_untented_retina_is_within_a_pixel(scored: list) -> None:
    errors = [e.ilm_offset_m for scene, _, e in scored if scene.tent_m == 0.0]
    assert len(errors) == 30 and all(e is not None for e in errors)
    assert max(abs(e) for e in errors) < PX  # type: ignore[arg-type]


def test_the_needle_tip_is_found_within_three_pixels(scored: list) -> None:
    tips = [e.tip_m for _, _, e in scored]
    assert all(t is not None for t in tips)
    tip = rms_m(tips)
    assert tip is not None and tip < 3 * PX


def test_a_retina_without_a_needle_is_found_everywhere_and_no_tip_is_made_up() -> None:
    rng = np.random.default_rng(3)
    scene = BScanScene(ilm_offset_m=-23e-6, lateral_shift_m=150e-6)
    seg = segment_bscan(render_bscan(MODEL, scene, rng), MODEL, 11e-3, 100e-6)
    assert seg.tip_m is None and not np.isfinite(seg.needle_top_m).any()
    assert seg.valid.mean() > 0.95
    error = segmentation_error(seg, scene, MODEL)
    assert error.tip_m is None
    assert error.ilm_offset_m is not None and abs(error.ilm_offset_m) < PX


def test_a_needle_inside_the_retina_leaves_the_ilm_above_it_visible() -> None:
    rng = np.random.default_rng(4)
    scene = BScanScene(tip_m=(0.0, 120e-6), needle_tilt_rad=0.7)  # punctured, 120 um deep
    seg = segment_bscan(render_bscan(MODEL, scene, rng), MODEL, 11e-3, 100e-6)
    error = segmentation_error(seg, scene, MODEL)
    assert error.tip_m is not None and error.tip_m < 3 * PX
    x = MODEL.lateral_axis_m()
    over = np.isfinite(seg.needle_top_m) & (seg.needle_top_m > scene.ilm_depth_m(x) + 20e-6)
    assert over.any() and seg.valid[over].all()  # ILM found above the needle in the retina
    assert error.ilm_rms_m is not None and error.ilm_rms_m < 1.5 * PX


def test_the_error_scoring_matches_a_hand_made_segmentation() -> None:
    scene = BScanScene(ilm_offset_m=10e-6, tip_m=(0.0, -50e-6))
    x = MODEL.lateral_axis_m()
    valid = np.zeros(x.size, bool)
    valid[:10] = True
    seg = Segmentation(
        ilm_m=scene.ilm_depth_m(x) + 2e-6, rpe_m=scene.rpe_depth_m(x) - 1e-6, valid=valid,
        rpe_valid=valid, needle_top_m=np.full(x.size, np.inf), tip_m=(3e-6, -46e-6),
        ilm_offset_m=13e-6, rpe_offset_m=None,
    )  # fmt: skip
    error = segmentation_error(seg, scene, MODEL)
    assert error.ilm_rms_m == pytest.approx(2e-6)
    assert error.rpe_rms_m == pytest.approx(1e-6)
    assert error.ilm_offset_m == pytest.approx(3e-6)
    assert error.tip_m == pytest.approx(5e-6)
    assert rms_m([3e-6, None, 4e-6]) == pytest.approx(np.sqrt(12.5) * 1e-6)
    assert rms_m([None]) is None


def test_an_image_of_the_wrong_shape_raises() -> None:
    with pytest.raises(InvalidInputError):
        segment_bscan(np.zeros((10, 10)), MODEL, 11e-3, 100e-6)
    with pytest.raises(InvalidInputError):
        segment_bscan(np.full((256, 96), np.nan), MODEL, 11e-3, 100e-6)
