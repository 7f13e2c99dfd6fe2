"""Segment the ILM, the RPE and the needle tip from a B-scan image alone.

Input: a B-scan in dB (`ioct.render_bscan`) and the scan geometry (`IoctModel`); the known
instrument (cannula diameter), the retina's curvature radius and a least ILM-to-RPE distance
are the only prior knowledge. No truth enters. Steps:

1. Noise: the noise level is the mean intensity of the top quarter of the image (vitreous
   by the window's design; exponential noise has mean = median / ln 2).
2. Shadow: an A-line is shadowed where it ends in a dark run (at least `min_shadow_m` long) in
   which the intensity averaged over 7 rows stays below `shadow_factor` times the noise
   level; the shadow starts at the run's first row.
3. Needle: in a shadowed A-line whose rows just above the shadow reach `needle_factor` times
   the noise level, the needle's surface is the strongest rising edge there (of the image
   smoothed along the A-line only: the steep shaft moves rows from one A-line to the next);
   an A-line shadowed from its first row sees no surface (the shaft passes above the window).
4. Layers: the image is clipped from below `clip_db` under the noise's median, the needle and
   its shadow are set to the median of their pixels (about the noise level, so that smoothing
   spreads no needle edge into the neighbouring A-lines), the image is smoothed across
   A-lines, and in each A-line, above any needle surface, a step detector (the mean of
   `step_rows` rows below less the mean of those above) finds the ILM as its first local peak
   above `min_step_db` and the RPE as its largest peak at least `min_thickness_m` below; each
   edge is then placed to a fraction of a row by a parabola through the peak of the gradient
   of the image smoothed along the A-line as well (`sigma_px`). A-lines whose ILM departs more
   than `outlier_m` from the median of its neighbours are dropped.
5. Tip: a least-squares line through the needle's surface points gives the needle's tilt; the
   surface ends at the cannula's upper corner (between the last A-line that meets it and the
   next); the tip on the axis lies one radius from that corner, perpendicular to the axis.

The ILM offset (the motion estimate) is the median over valid A-lines of the ILM depth less the
retina's sag across the scan (its curvature); the RPE offset likewise.

Steps 2-5 are numba kernels (`segment_kernels`, on the filters of `segment_filters`) that read
the image A-line by A-line and smooth along an A-line only the rows a step reads; the medians
are numpy's partition.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rcmplan._validate import FloatArray, scalar
from rcmplan.exceptions import InvalidInputError
from rcmplan.subretinal.ioct import IoctModel
from rcmplan.subretinal.segment_filters import smooth_across
from rcmplan.subretinal.segment_kernels import (
    clip_below,
    fill_below,
    inliers,
    layer_limit,
    layer_rows,
    needle_rows,
    needle_tip,
    shadow_start,
)

DB_TO_LN = math.log(10.0) / 10.0  # ln of the linear intensity per dB


@dataclass(frozen=True)
class SegmentationSettings:
    """Tuning of the segmentation (module docstring).

    Attributes:
        sigma_px: Gaussian smoothing (rows, columns) in pixels.
        shadow_factor: Shadow threshold relative to the noise level.
        needle_factor: Least needle-surface intensity relative to the noise level.
        min_thickness_m: Least ILM-to-RPE distance searched [m].
        outlier_m: Largest departure of an ILM point from the median-filtered profile [m].
        surface_rows: Rows above a shadow searched for the needle's surface.
        min_shadow_m: Least depth [m] a shadow spans to the bottom of the image.
        min_edge_db: Least rise [dB per row] of the smoothed image at the needle's surface.
        step_rows: Rows averaged on each side by the layer step detector.
        min_step_db: Least step [dB] between those means at a layer edge.
        clip_db: The layers are found on the image clipped from below at this far [dB] under
            the noise's median (the log of speckle has a long dark tail).
    """

    sigma_px: tuple[float, float] = (1.5, 2.0)
    shadow_factor: float = 4.0
    needle_factor: float = 30.0
    min_thickness_m: float = 100e-6
    outlier_m: float = 20e-6
    surface_rows: int = 8
    min_shadow_m: float = 100e-6
    min_edge_db: float = 2.0
    step_rows: int = 6
    min_step_db: float = 7.0
    clip_db: float = 6.0

    def __post_init__(self) -> None:
        scalar("sigma_px[0]", self.sigma_px[0], 0.0, 20.0)
        scalar("sigma_px[1]", self.sigma_px[1], 0.0, 20.0)
        scalar("shadow_factor", self.shadow_factor, 1.0, 1e3, low_open=True)
        scalar("needle_factor", self.needle_factor, 1.0, 1e6, low_open=True)
        scalar("min_thickness_m", self.min_thickness_m, 0.0, 1e-3)
        scalar("outlier_m", self.outlier_m, 0.0, 1e-3, low_open=True)
        if not isinstance(self.surface_rows, int) or not 2 <= self.surface_rows <= 64:
            raise InvalidInputError("surface_rows", self.surface_rows, "an integer in [2, 64]")
        scalar("min_shadow_m", self.min_shadow_m, 0.0, 0.01)
        scalar("min_edge_db", self.min_edge_db, 0.0, 100.0)
        if not isinstance(self.step_rows, int) or not 2 <= self.step_rows <= 32:
            raise InvalidInputError("step_rows", self.step_rows, "an integer in [2, 32]")
        scalar("min_step_db", self.min_step_db, 0.0, 100.0)
        scalar("clip_db", self.clip_db, 0.0, 100.0)


DEFAULT_SETTINGS = SegmentationSettings()


@dataclass(frozen=True)
class Segmentation:
    """What the segmentation found in one B-scan (depths z and positions x in the B-scan frame).

    Attributes:
        ilm_m: ILM depth per A-line [m] (meaningful where `valid`).
        rpe_m: RPE-surface depth per A-line [m] (meaningful where `rpe_valid`).
        valid: A-lines where the ILM was found.
        rpe_valid: A-lines where the RPE was found.
        needle_top_m: Needle surface depth per A-line [m] (inf where none is seen).
        tip_m: Needle tip (x, z) on its axis [m], or None when no needle end is seen.
        ilm_offset_m: ILM displacement estimate [m], or None when no A-line shows the ILM.
        rpe_offset_m: RPE displacement estimate [m] (depth less the sag, not less the
            thickness), or None.
    """

    ilm_m: FloatArray
    rpe_m: FloatArray
    valid: np.ndarray
    rpe_valid: np.ndarray
    needle_top_m: FloatArray
    tip_m: tuple[float, float] | None
    ilm_offset_m: float | None
    rpe_offset_m: float | None


def sag_m(x: FloatArray, radius_m: float) -> FloatArray:
    """Height [m] of a sphere of `radius_m` above its deepest point at lateral offsets x [m]."""
    return radius_m - np.sqrt(radius_m * radius_m - np.minimum(x * x, 0.98 * radius_m**2))


def _middle(values: FloatArray) -> tuple[float, float]:
    """The two middle values of `values` (1-D, n > 0; reordered in place) in order, one value
    twice for an odd n: by one partition (`np.median` partitions about two, several times
    slower)."""
    k = values.size // 2
    values.partition(k)
    upper = float(values[k])
    return (upper if values.size % 2 else float(values[:k].max())), upper


def _median(values: FloatArray) -> float:
    """Median of `values` (1-D, n > 0; reordered in place), as `np.median`."""
    lower, upper = _middle(values)
    return 0.5 * (lower + upper)


def segment_bscan(
    image_db: FloatArray,
    model: IoctModel,
    curvature_radius_m: float,
    needle_diameter_m: float,
    settings: SegmentationSettings | None = None,
) -> Segmentation:
    """Segment one B-scan (module docstring).

    Args:
        image_db: B-scan (depth_px, lateral_px) in dB.
        model: The scan geometry.
        curvature_radius_m: ILM radius [m] (removes the sag from the offsets).
        needle_diameter_m: Outer diameter of the cannula [m].
    """
    cfg = settings or DEFAULT_SETTINGS
    img = np.asarray(image_db, dtype=np.float64)
    if img.shape != (model.depth_px, model.lateral_px) or not np.isfinite(img).all():
        want = (model.depth_px, model.lateral_px)
        raise InvalidInputError("image_db", img.shape, f"a finite array of shape {want}")
    lines = np.ascontiguousarray(img.T)  # A-line by A-line (`segment_filters`)
    lower, upper = _middle(lines[:, : model.depth_px // 4].flatten())  # dB sorts as linear
    noise = 0.5 * (10.0 ** (lower / 10.0) + 10.0 ** (upper / 10.0)) / math.log(2.0)
    rows = _rows(lines, noise, model, cfg)
    x, z0, dz = model.lateral_axis_m(), model.depth_axis_m()[0], model.axial_pixel_m
    ilm, rpe = (np.where(np.isnan(r), z0, z0 + dz * r) for r in rows[:2])
    top = np.where(np.isnan(rows[2]), np.inf, z0 + dz * rows[2])
    valid = inliers(ilm, ~np.isnan(rows[0]), cfg.outlier_m)
    rpe_valid = valid & inliers(rpe, ~np.isnan(rows[1]), cfg.outlier_m)
    found, tip_x, tip_z = needle_tip(x, top, model.lateral_pixel_m, 0.5 * needle_diameter_m)
    sag = sag_m(x, curvature_radius_m)
    ilm_off = _median(ilm[valid] + sag[valid]) if valid.any() else None
    rpe_off = _median(rpe[rpe_valid] + sag[rpe_valid]) if rpe_valid.any() else None
    tip = (tip_x, tip_z) if found else None
    return Segmentation(ilm, rpe, valid, rpe_valid, top, tip, ilm_off, rpe_off)


def _rows(
    lines: FloatArray, noise: float, model: IoctModel, cfg: SegmentationSettings
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Sub-rows per A-line of the ILM, the RPE and the needle's surface (nan where not found)
    in the image held A-line by A-line, whose noise has mean intensity `noise`: steps 2-4."""
    cols, depth = lines.shape
    work = np.empty((3, cols, depth))  # the intermediate images, in one block
    linear = np.multiply(lines, DB_TO_LN, out=work[0])
    np.exp(linear, out=linear)
    shadow = np.empty(cols, dtype=np.int64)
    shadow_start(linear, cfg.shadow_factor * noise,
                 math.ceil(cfg.min_shadow_m / model.axial_pixel_m), shadow)  # fmt: skip
    top_row = np.empty(cols)
    needle_rows(lines, linear, shadow, cfg.needle_factor * noise, cfg.surface_rows,
                cfg.min_edge_db, float(cfg.sigma_px[0]), top_row)  # fmt: skip
    limit = layer_limit(shadow, top_row)
    # the log of speckle has a long dark tail: clip it so that a few dark pixels make no edge
    floor = 10.0 * math.log10(noise * math.log(2.0)) - cfg.clip_db
    masked, below = work[1], work[2].reshape(-1)
    count = clip_below(lines, floor, limit, masked, below)
    if count:  # the needle and its shadow: no edge spreads from them across A-lines
        fill_below(masked, limit, _median(below[:count]))
    across = smooth_across(masked, float(cfg.sigma_px[1]), work[0])
    ilm_row, rpe_row = np.empty(cols), np.empty(cols)
    layer_rows(across, limit, math.ceil(cfg.min_thickness_m / model.axial_pixel_m),
               cfg.step_rows, cfg.min_step_db, float(cfg.sigma_px[0]), work[2], ilm_row,
               rpe_row)  # fmt: skip
    return ilm_row, rpe_row, top_row
