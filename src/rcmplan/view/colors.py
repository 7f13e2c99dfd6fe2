"""Colours of the view: the tip trace coloured by RCM deviation, and the fixed palette."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray

# green (no deviation) -> yellow -> red (the run's largest deviation)
STOPS = np.array([[40, 170, 80], [240, 200, 40], [220, 40, 40]], dtype=float)
FREE_SPACE = (150, 150, 150)  # a record without an RCM (outside the eye)
NEEDLE = (255, 0, 200)  # a colour no other object has, so the needle can be found on screen
EYE = (120, 160, 210)
RETINA = (200, 80, 70)
TROCAR = (30, 160, 60)
TARGET = (40, 90, 220)
RCM_POINT = (250, 140, 0)
# the segmentation drawn over an iOCT B-scan
SEG_ILM = (60, 220, 90)
SEG_RPE = (255, 170, 0)
SEG_TIP = (0, 200, 255)


def deviation_colors(deviation_m: FloatArray, scale_m: float) -> NDArray[np.uint8]:
    """RGB (n, 3) for RCM deviations (n,) in [m]: green at 0 to red at `scale_m` and above;
    grey where the deviation is NaN (no RCM held)."""
    d = np.asarray(deviation_m, dtype=float)
    x = np.clip(np.nan_to_num(d / max(scale_m, 1e-15), nan=0.0), 0.0, 1.0) * 2.0
    lo = np.minimum(x.astype(int), 1)
    f = (x - lo)[:, None]
    rgb = STOPS[lo] * (1.0 - f) + STOPS[lo + 1] * f
    rgb[~np.isfinite(d)] = FREE_SPACE
    return np.asarray(np.round(rgb), dtype=np.uint8)
