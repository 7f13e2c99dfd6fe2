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
   its shadow are set to the noise level, the image is smoothed across A-lines, and in each
   A-line, above any needle surface, a step detector (the mean of `step_rows` rows below less
   the mean of those above) finds the ILM as its first local peak above `min_step_db` and the
   RPE as its largest peak at least `min_thickness_m` below; each edge is then placed to a
   fraction of a row by a parabola through the peak of the gradient of the image smoothed
   along the A-line as well (`sigma_px`). A-lines whose ILM departs more than `outlier_m` from
   the median of its neighbours are dropped.
5. Tip: a line through the needle's surface points gives the needle's tilt; the surface ends at
   the cannula's upper corner (between the last A-line that meets it and the next); the tip on
   the axis lies one radius from that corner, perpendicular to the axis.

The ILM offset (the motion estimate) is the median over valid A-lines of the ILM depth less the
retina's sag across the scan (its curvature); the RPE offset likewise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from rcmplan._validate import FloatArray, scalar
from rcmplan.exceptions import InvalidInputError
from rcmplan.subretinal import segment_kernels as kernels
from rcmplan.subretinal.ioct import IoctModel


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


def _tip(x: FloatArray, top: FloatArray, dx: float, radius: float) -> tuple[float, float] | None:
    """Needle tip on the axis from its surface points (x, top) [m] (module docstring, step 5)."""
    seen = np.isfinite(top)
    if seen.sum() < 3:
        return None
    slope, intercept = np.polyfit(x[seen], top[seen], 1)
    if abs(slope) < 1e-3:
        return None
    theta = math.atan(1.0 / slope)
    end = x[seen].max() if slope > 0 else x[seen].min()
    xc = end + math.copysign(0.5 * dx, slope)
    zc = slope * xc + intercept
    up = math.copysign(1.0, theta)
    return xc - radius * up * math.cos(theta), zc + radius * up * math.sin(theta)


def _needle_surface(
    img: FloatArray, linear: FloatArray, shadow: FloatArray, bright: float,
    cfg: SegmentationSettings,
) -> FloatArray:  # fmt: skip
    """Sub-row of the needle's surface per A-line (nan where none is seen): step 3."""
    rows = img.shape[0]
    lo = shadow - cfg.surface_rows
    seen = (shadow > 0) & (shadow < rows)
    if not seen.any():
        return np.full(img.shape[1], np.nan)
    seen &= kernels.window_max(kernels.smooth_rows(linear, 1.0), lo, shadow) >= bright
    if not seen.any():
        return np.full(img.shape[1], np.nan)
    grad_z = kernels.gradient_rows(kernels.smooth_rows(img, cfg.sigma_px[0]))
    k = kernels.peaks(grad_z, lo, shadow + 1, cfg.min_edge_db, False)
    return kernels.refine(grad_z, np.where(seen, k, np.nan), 0, 0)


def _layers(
    img: FloatArray, limit: FloatArray, sep: int, cfg: SegmentationSettings
) -> tuple[FloatArray, FloatArray]:
    """Sub-rows of the ILM and the RPE per A-line (nan where not found) above row `limit`:
    step 4, on the image with the needle and its shadow replaced by the median of their pixels
    so that smoothing spreads no needle edge into the neighbouring A-lines."""
    rows, cols = img.shape
    across = kernels.smooth_cols(kernels.mask_below(img, limit), cfg.sigma_px[1])
    grad = kernels.gradient_rows(kernels.smooth_rows(across, cfg.sigma_px[0]))
    step = kernels.step_detector(across, cfg.step_rows)
    end = limit - cfg.step_rows // 2
    first = np.full(cols, float(cfg.step_rows))
    k_ilm = kernels.peaks(step, first, end, cfg.min_step_db, True)
    k_rpe = kernels.peaks(step, np.nan_to_num(k_ilm, nan=rows) + sep, end, cfg.min_step_db, False)
    # the detector at row k spans the boundary k - 1/2, where the gradient peaks too
    return kernels.refine(grad, k_ilm, 3, 1), kernels.refine(grad, k_rpe, 3, 1)


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
    cfg = settings or SegmentationSettings()
    img = np.asarray(image_db, dtype=np.float64)
    if img.shape != (model.depth_px, model.lateral_px) or not np.isfinite(img).all():
        want = (model.depth_px, model.lateral_px)
        raise InvalidInputError("image_db", img.shape, f"a finite array of shape {want}")
    linear = np.exp(img * (math.log(10.0) / 10.0))  # 10^(dB / 10)
    noise = float(np.median(linear[: model.depth_px // 4])) / math.log(2.0)
    min_rows = math.ceil(cfg.min_shadow_m / model.axial_pixel_m)
    shadow = kernels.shadow_start(linear, cfg.shadow_factor * noise, min_rows)
    top_row = _needle_surface(img, linear, shadow, cfg.needle_factor * noise, cfg)
    limit = np.where(np.isnan(top_row), shadow, np.floor(np.nan_to_num(top_row)) - 2)
    sep = math.ceil(cfg.min_thickness_m / model.axial_pixel_m)
    # the log of speckle has a long dark tail: clip it so that a few dark pixels make no edge
    floor = 10.0 * math.log10(noise * math.log(2.0)) - cfg.clip_db
    ilm_row, rpe_row = _layers(np.maximum(img, floor), limit, sep, cfg)
    x, z0, dz = model.lateral_axis_m(), model.depth_axis_m()[0], model.axial_pixel_m
    ilm, rpe, top = (z0 + dz * np.nan_to_num(r, nan=0.0) for r in (ilm_row, rpe_row, top_row))
    top[np.isnan(top_row)] = np.inf
    valid = _inliers(ilm, ~np.isnan(ilm_row), cfg.outlier_m)
    rpe_valid = valid & _inliers(rpe, ~np.isnan(rpe_row), cfg.outlier_m)
    tip = _tip(x, top, model.lateral_pixel_m, 0.5 * needle_diameter_m)
    sag = sag_m(x, curvature_radius_m)
    ilm_off = float(np.median(ilm[valid] + sag[valid])) if valid.any() else None
    rpe_off = float(np.median(rpe[rpe_valid] + sag[rpe_valid])) if rpe_valid.any() else None
    return Segmentation(ilm, rpe, valid, rpe_valid, top, tip, ilm_off, rpe_off)


def _inliers(profile: FloatArray, valid: np.ndarray, tolerance: float) -> np.ndarray:
    """A-lines whose value lies within `tolerance` of the median over valid neighbours (5)."""
    keep = np.zeros_like(valid)
    idx = np.flatnonzero(valid)
    if idx.size == 0:
        return keep
    values = profile[idx]
    ref = ndimage.median_filter(values, size=min(5, idx.size), mode="mirror")
    keep[idx] = np.abs(values - ref) <= tolerance
    return keep
