"""The iOCT B-scan beside a replayed subretinal episode: at the replayed time, the B-scan of the
volume whose estimate the controller last received (`subretinal.episode_bscans`; the episode's
bscans.npz, read by `run_folder.load_run`), with that image's segmented ILM (green) and RPE
(orange) and the segmented needle tip (cyan cross), and under it the times, the ILM
displacement (received, segmented from the image, true) and the tip's depth against the layers.

The image is widened 4 times across (12 um A-lines, 3.3 um rows) so that it reads at about its
true aspect. It is sent only when the frame changes.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray
from rcmplan.view import colors
from rcmplan.view.panels import StatePanel, length
from rcmplan.view.run_folder import RunData

if TYPE_CHECKING:  # the B-scans' module imports the iOCT models: only an episode's replay does
    from rcmplan.subretinal.episode_bscans import EpisodeBScans

WIDEN = 4  # image columns per A-line
JPEG_QUALITY = 90


def frame_rgb(frames: EpisodeBScans, k: int) -> NDArray[np.uint8]:
    """Frame k as RGB (depth_px, WIDEN * lateral_px, 3) with its segmentation drawn over it."""
    grey = np.repeat(frames.images[k], WIDEN, axis=1)
    rgb = np.repeat(grey[:, :, None], 3, axis=2)
    rows, cols = grey.shape
    lines = ((frames.seg_ilm_m[k], colors.SEG_ILM), (frames.seg_rpe_m[k], colors.SEG_RPE))
    for line, colour in lines:
        r = frames.row_of(line)
        for j in np.flatnonzero(np.isfinite(r)):
            top = int(np.clip(np.round(r[j]), 0, rows - 2))
            rgb[top : top + 2, j * WIDEN : (j + 1) * WIDEN] = colour
    x, z = frames.seg_tip_m[k]
    if np.isfinite(x):
        c = int(np.clip(np.round(x / frames.lateral_pixel_m * WIDEN + 0.5 * cols), 0, cols - 1))
        r0 = int(np.clip(np.round(frames.row_of(z)), 0, rows - 1))
        rgb[max(r0 - 6, 0) : r0 + 7, max(c - 1, 0) : c + 2] = colors.SEG_TIP
        rgb[max(r0 - 1, 0) : r0 + 2, max(c - 6, 0) : c + 7] = colors.SEG_TIP
    return np.asarray(rgb, dtype=np.uint8)


class BScanPanel:
    """The B-scan image and its figures in the view's panel.

    Args:
        gui: A viser GuiApi. frames: The episode's B-scans.
        depth_m: The true tip depth in tissue per record [m] (episode.npz `depth_m`), or None.
        thickness_m: The retina's thickness, ILM to RPE [m].
    """

    def __init__(
        self, gui: Any, frames: EpisodeBScans, depth_m: FloatArray | None, thickness_m: float
    ) -> None:
        self.frames, self.depth_m, self.thickness_m = frames, depth_m, thickness_m
        self.frame = -2  # none sent yet
        self.sends = 0
        with gui.add_folder("iOCT B-scan"):
            shape = (frames.images.shape[1], WIDEN * frames.images.shape[2], 3)
            self.blank = np.zeros(shape, dtype=np.uint8)
            self.image = gui.add_image(self.blank, label="B-scan", format="jpeg",
                                       jpeg_quality=JPEG_QUALITY)  # fmt: skip
            self.text = StatePanel(gui, "Volume received")

    def show(self, t_s: float, record: int) -> None:
        """Show the frame the controller last received by episode time t_s [s], and the tip's
        true depth at record `record`."""
        f, k = self.frames, self.frames.frame_at(t_s)
        if k != self.frame:
            self.image.image = frame_rgb(f, k) if k >= 0 else self.blank
            self.frame = k
            self.sends += 1
        values = {"now": self._now(record)}
        if k < 0:
            values["volume"] = "none received yet"
        else:
            z = f.tip_m[k, 1]
            values.update({
                "volume": f"{k + 1} of {len(f)}: acquired {f.t_acq_s[k]:.3f} s, received "
                          f"{f.arrival_s[k]:.3f} s",
                "ILM displacement": f"received {length(f.estimate_m[k])}, this image "
                                    f"{length(f.segmented_m[k])}, true {length(f.truth_m[k])}",
                "tip at acquisition": f"depth below the ILM {length(z - f.ilm_at_tip_m[k])}, "
                                      f"height above the RPE {length(f.rpe_at_tip_m[k] - z)}",
            })  # fmt: skip
        self.text.show(values)

    def _now(self, i: int) -> str:
        if self.depth_m is None or not 0 <= i < self.depth_m.size:
            return "-"
        depth, rpe = length(float(self.depth_m[i])), length(self.thickness_m)
        return f"tip depth in tissue {depth} (the RPE at {rpe})"


def bscan_panel(gui: Any, run: RunData) -> BScanPanel | None:
    """The B-scan panel of a subretinal episode's run (one with B-scans), else None."""
    if run.bscans is None:
        return None
    thickness = float(run.summary.get("thickness_m", float("nan")))
    return BScanPanel(gui, run.bscans, run.tissue_depth_m, thickness)
