"""The segmentation's error against the truth a B-scan was rendered from, per acquisition and
aggregated (RMS) over many: what episode metrics report next to the controller's errors."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.subretinal.ioct import BScanScene, IoctModel
from rcmplan.subretinal.segment import Segmentation


class SegmentationError(NamedTuple):
    """Errors of one segmentation against the truth it was rendered from [m].

    Attributes:
        ilm_rms_m: RMS over valid A-lines of the ILM depth error (None if none is valid).
        rpe_rms_m: Same for the RPE surface.
        ilm_offset_m: ILM offset estimate less the true ILM offset (None if no estimate).
        tip_m: Distance from the estimated to the true needle tip (None if either is absent).
    """

    ilm_rms_m: float | None
    rpe_rms_m: float | None
    ilm_offset_m: float | None
    tip_m: float | None


def segmentation_error(seg: Segmentation, scene: BScanScene, model: IoctModel) -> SegmentationError:
    """Score a segmentation against the scene it was rendered from."""
    x = model.lateral_axis_m()

    def rms(est: FloatArray, truth: FloatArray, ok: np.ndarray) -> float | None:
        return float(np.sqrt(np.mean((est[ok] - truth[ok]) ** 2))) if ok.any() else None

    ilm = rms(seg.ilm_m, scene.ilm_depth_m(x), seg.valid)
    rpe = rms(seg.rpe_m, scene.rpe_depth_m(x), seg.rpe_valid)
    off = None if seg.ilm_offset_m is None else seg.ilm_offset_m - scene.ilm_offset_m
    tip = None
    if seg.tip_m is not None and scene.tip_m is not None:
        tip = math.dist(seg.tip_m, scene.tip_m)
    return SegmentationError(ilm, rpe, off, tip)


def rms_m(values: Sequence[float | None]) -> float | None:
    """RMS of the values that exist (None where none does): aggregates `SegmentationError`
    fields over many acquisitions."""
    v = np.array([x for x in values if x is not None], dtype=np.float64)
    return float(np.sqrt(np.mean(v**2))) if v.size else None
