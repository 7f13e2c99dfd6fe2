"""The B-scans of one episode's iOCT volumes, for replaying the episode beside its 3D scene.

An episode's controller receives, every 1 / rate, the ILM displacement estimated from the
volume acquired `latency_s` earlier (`Episode.deliver`, `episode_ioct`). For each volume that
delivered an estimate during the logged periods (and the one it held at the first period),
`episode_bscans` renders the B-scan of that acquisition's scene (`EpisodeResult.received`: the
truth at the acquisition, the tip and needle where the robot held them, the ILM's tent) with
the same speckle and segments it (`episode_ioct.segment_acquisition`): with "image" estimates
the very image the controller's estimate came from, with the "noise" stand-in the image of
that acquisition beside the stand-in's estimate.

`bscans.npz` keeps the images as uint8 over [db_low, db_high] (the rendered dB, quantised for
size) with their acquisition and arrival times, the estimate the controller received, the
truth, and the segmentation of the image as rendered (before quantisation).
"""

from __future__ import annotations

import zipfile
import zlib
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rcmplan._atomic import atomic_path
from rcmplan._validate import FloatArray
from rcmplan.exceptions import RunFolderError
from rcmplan.subretinal.episode_ioct import segment_acquisition
from rcmplan.subretinal.ioct import IoctModel

if TYPE_CHECKING:
    from rcmplan.subretinal.episode import EpisodeResult

PER_FRAME = ("t_acq_s", "arrival_s", "estimate_m", "truth_m", "segmented_m", "tip_m", "tent_m",
             "ilm_at_tip_m", "rpe_at_tip_m", "seg_ilm_m", "seg_rpe_m", "seg_tip_m")  # fmt: skip
GEOMETRY = ("axial_pixel_m", "lateral_pixel_m", "top_m", "db_low", "db_high")


@dataclass(frozen=True)
class EpisodeBScans:
    """The B-scans of the volumes an episode's controller received (module docstring).

    Attributes:
        images: (K, depth_px, lateral_px) uint8, dB quantised over [db_low, db_high].
        t_acq_s, arrival_s: Acquisition and delivery times (K,) [s], episode time.
        estimate_m: The ILM displacement the controller received (K,) [m].
        truth_m: The true ILM displacement at the acquisition (K,) [m].
        segmented_m: The ILM displacement segmented from this image (K,) [m]; NaN if none.
        tip_m: The needle tip (x, z) in the B-scan frame (K, 2) [m], rendered.
        tent_m: The ILM's tent under the tip (K,) [m].
        ilm_at_tip_m, rpe_at_tip_m: True ILM and RPE depth z at the tip's x (K,) [m].
        seg_ilm_m, seg_rpe_m: Segmented ILM and RPE depth per A-line (K, lateral_px) [m], NaN
            where not found. seg_tip_m: Segmented tip (x, z) (K, 2) [m], NaN if not found.
        axial_pixel_m, lateral_pixel_m, top_m: The scan geometry (`IoctModel`) [m].
        db_low, db_high: The dB that uint8 0 and 255 stand for.
    """

    images: np.ndarray
    t_acq_s: FloatArray
    arrival_s: FloatArray
    estimate_m: FloatArray
    truth_m: FloatArray
    segmented_m: FloatArray
    tip_m: FloatArray
    tent_m: FloatArray
    ilm_at_tip_m: FloatArray
    rpe_at_tip_m: FloatArray
    seg_ilm_m: FloatArray
    seg_rpe_m: FloatArray
    seg_tip_m: FloatArray
    axial_pixel_m: float
    lateral_pixel_m: float
    top_m: float
    db_low: float
    db_high: float

    def __len__(self) -> int:
        return int(self.t_acq_s.size)

    def frame_at(self, t_s: float) -> int:
        """The frame the controller last received by episode time t_s [s] (arrival <= t_s, as
        `Episode.deliver` feeds them); -1 before the first."""
        return int(np.searchsorted(self.arrival_s, t_s, side="right")) - 1

    def image_db(self, k: int) -> FloatArray:
        """Frame k in dB (the quantised image, dequantised)."""
        scale = (self.db_high - self.db_low) / 255.0
        return np.asarray(self.db_low + scale * self.images[k].astype(np.float64))

    def row_of(self, z_m: FloatArray) -> FloatArray:
        """Image row (fractional, row centres at integers) of depths z [m]."""
        return np.asarray((np.asarray(z_m) + self.top_m) / self.axial_pixel_m - 0.5)

    def save(self, path: Path) -> Path:
        """Write the frames to `path` (.npz, compressed)."""
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            fields: dict[str, Any] = {k: np.asarray(v) for k, v in asdict(self).items()}
            np.savez_compressed(fh, **fields)
        return path


def episode_bscans(result: EpisodeResult) -> EpisodeBScans:
    """Render and segment the B-scan of every volume the controller received (module doc)."""
    cfg, log = result.settings, result.log
    ioct = IoctModel(volume_rate_hz=cfg.ioct_rate_hz, latency_s=cfg.latency_s)
    got = [r for r in result.received if r.estimate_m is not None]
    arrival = np.array([r.t_acq_s for r in got]) + cfg.latency_s
    first = max(int(np.searchsorted(arrival, log.time[0], side="right")) - 1, 0)
    last = int(np.searchsorted(arrival, log.time[-1], side="right"))
    rows: dict[str, list[object]] = {k: [] for k in PER_FRAME}
    images = []
    for k in range(first, last):
        r = got[k]
        scene, tip = r.scene, r.scene.tip_m or (np.nan, np.nan)
        image, seg = segment_acquisition(ioct, scene, cfg.seed, r.number)
        images.append(image)
        values = (r.t_acq_s, arrival[k], r.estimate_m, scene.ilm_offset_m,
                  np.nan if seg.ilm_offset_m is None else seg.ilm_offset_m, tip, scene.tent_m,
                  scene.ilm_depth_m(tip[0]), scene.rpe_depth_m(tip[0]),
                  np.where(seg.valid, seg.ilm_m, np.nan),
                  np.where(seg.rpe_valid, seg.rpe_m, np.nan),
                  (np.nan, np.nan) if seg.tip_m is None else seg.tip_m)  # fmt: skip
        for key, value in zip(PER_FRAME, values, strict=True):
            rows[key].append(value)
    return _frames(images, rows, ioct)


def _frames(
    images: list[FloatArray], rows: dict[str, list[object]], ioct: IoctModel
) -> EpisodeBScans:
    stack = np.asarray(images, dtype=np.float64).reshape(-1, ioct.depth_px, ioct.lateral_px)
    low = float(np.percentile(stack, 1.0)) if stack.size else 0.0
    high = float(stack.max()) if stack.size else 1.0
    quantised = np.round(255.0 * np.clip((stack - low) / max(high - low, 1e-9), 0.0, 1.0))
    columns: dict[str, Any] = {k: np.asarray(v, dtype=np.float64) for k, v in rows.items()}
    for key in ("tip_m", "seg_tip_m"):
        columns[key] = columns[key].reshape(-1, 2)
    for key in ("seg_ilm_m", "seg_rpe_m"):
        columns[key] = columns[key].reshape(-1, ioct.lateral_px)
    return EpisodeBScans(
        images=quantised.astype(np.uint8), **columns, axial_pixel_m=ioct.axial_pixel_m,
        lateral_pixel_m=ioct.lateral_pixel_m, top_m=ioct.top_m, db_low=low, db_high=high,
    )  # fmt: skip


def read_bscans(path: Path) -> EpisodeBScans:
    """An episode's bscans.npz, every field present and of one length; RunFolderError
    otherwise."""
    try:
        with np.load(path, allow_pickle=False) as z:
            missing = [k for k in ("images", *PER_FRAME, *GEOMETRY) if k not in z]
            if missing:
                why = "written by another version of rcmplan, or not an episode's B-scans"
                raise RunFolderError(path, f"lacks the fields {', '.join(missing)}: {why}")
            arrays: dict[str, Any] = {k: np.asarray(z[k]) for k in ("images", *PER_FRAME)}
            geometry: dict[str, Any] = {k: float(z[k]) for k in GEOMETRY}
    except (zipfile.BadZipFile, zlib.error, EOFError, ValueError, OSError) as exc:
        raise RunFolderError(path, f"truncated or damaged ({type(exc).__name__}: {exc})") from exc
    n = arrays["images"].shape[0]
    if arrays["images"].ndim != 3 or any(arrays[k].shape[0] != n for k in PER_FRAME):
        raise RunFolderError(path, "its fields differ in length: a damaged file")
    if np.any(np.diff(arrays["arrival_s"]) < 0):
        raise RunFolderError(path, "its arrival times are not sorted: a damaged file")
    return EpisodeBScans(**arrays, **geometry)
