"""Replay files: a recorded master input as CSV or NPZ, read and checked before any motion.

CSV: a header row naming the columns (any order, extra columns ignored), then one row per
sample; lines starting with `#` are comments.

| column | unit | meaning |
|---|---|---|
| `time_s` | s | time stamp, strictly increasing, intervals of at most 10 ms (>= 100 Hz) |
| `x_m`, `y_m`, `z_m` | m | handle position in the master frame (the eye frame's axes) |
| `clutch` | 0 or 1 | 1 while engaged (the handle drives the needle) |

NPZ: arrays `time_s` (N,), `position_m` (N, 3), `clutch` (N,) of 0/1 or booleans, and
optionally `intended_m` (N, 3), the intended part of the motion when known.

Rows are counted from 0, the header and comments excluded. Every error names the file, the
row, the column and the value (`rcmplan.exceptions.InputStreamError`).
"""

from __future__ import annotations

import csv
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.exceptions import InputStreamError
from rcmplan.teleop.samples import MAX_SPEED_M_S, MasterTrack, check_track

COLUMNS = ("time_s", "x_m", "y_m", "z_m", "clutch")
NPZ_KEYS = ("time_s", "position_m", "clutch")
MAX_ROWS = 4_000_000  # an hour at 1 kHz


def read_track(path: str | Path, max_speed: float = MAX_SPEED_M_S) -> MasterTrack:
    """The track in a CSV or NPZ file (by suffix), checked row by row (`check_track`)."""
    path = Path(path)
    if not path.is_file():
        raise InputStreamError(str(path), None, "file", str(path), "an existing CSV or NPZ file")
    reader = _read_npz if path.suffix.lower() == ".npz" else _read_csv
    return check_track(reader(path), max_speed)


def _read_csv(path: Path) -> MasterTrack:
    src = path.name
    try:
        with open(path, newline="") as fh:
            rows = (r for r in csv.reader(fh) if r and not r[0].lstrip().startswith("#"))
            header = [h.strip() for h in next(rows, [])]
            missing = [c for c in COLUMNS if c not in header]
            if missing:
                raise InputStreamError(src, None, "header", header,
                                       f"columns {', '.join(COLUMNS)} (missing: "
                                       f"{', '.join(missing)})")  # fmt: skip
            cols = [header.index(c) for c in COLUMNS]
            data = [_csv_row(src, k, r, cols) for k, r in enumerate(rows) if _count(src, k)]
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise InputStreamError(
            src, None, "file", str(path), f"a readable CSV file ({exc})"
        ) from exc
    arr = np.array(data, dtype=float).reshape(-1, 5)
    return MasterTrack(arr[:, 0], arr[:, 1:4], arr[:, 4] > 0.5, None, src)


def _count(src: str, k: int) -> bool:
    if k >= MAX_ROWS:
        raise InputStreamError(src, k, "rows", k + 1, f"at most {MAX_ROWS:,} rows")
    return True


def _csv_row(src: str, k: int, row: list[str], cols: list[int]) -> list[float]:
    if len(row) <= max(cols):
        raise InputStreamError(src, k, "row", row, f"a value in each of {', '.join(COLUMNS)}")
    out = []
    for name, c in zip(COLUMNS, cols, strict=True):
        text = row[c].strip()
        try:
            value = float(text)
        except ValueError:
            raise InputStreamError(src, k, name, text, "a number") from None
        if name == "clutch" and value not in (0.0, 1.0):
            raise InputStreamError(src, k, name, text, "0 (released) or 1 (engaged)")
        out.append(value)
    return out


def _read_npz(path: Path) -> MasterTrack:
    src = path.name
    try:
        with np.load(path, allow_pickle=False) as z:
            missing = [k for k in NPZ_KEYS if k not in z.files]
            if missing:
                raise InputStreamError(src, None, "arrays", sorted(z.files),
                                       f"arrays {', '.join(NPZ_KEYS)} (missing: "
                                       f"{', '.join(missing)})")  # fmt: skip
            t = _float(src, "time_s", z["time_s"], 1)
            n = t.shape[0]
            if n > MAX_ROWS:
                raise InputStreamError(src, None, "rows", n, f"at most {MAX_ROWS:,} rows")
            p = _float(src, "position_m", z["position_m"], 2)
            clutch = _clutch(src, np.asarray(z["clutch"]))
            has = "intended_m" in z
            intended = _float(src, "intended_m", z["intended_m"], 2) if has else None
    except (OSError, ValueError, zipfile.BadZipFile) as exc:
        raise InputStreamError(
            src, None, "file", str(path), f"a readable NPZ file ({exc})"
        ) from exc
    if intended is not None and intended.shape != p.shape:
        raise InputStreamError(src, None, "intended_m", intended.shape, f"shape {p.shape}")
    return MasterTrack(t, p, clutch, intended, src)


def _float(src: str, key: str, a: np.ndarray, ndim: int) -> FloatArray:
    if a.dtype.kind not in "biuf" or a.ndim != ndim or (ndim == 2 and a.shape[1] != 3):
        shape = "(N,)" if ndim == 1 else "(N, 3)"
        raise InputStreamError(src, None, key, f"{a.dtype} array of shape {a.shape}",
                               f"numbers of shape {shape}")  # fmt: skip
    return np.asarray(a, dtype=float)


def _clutch(src: str, a: np.ndarray) -> np.ndarray:
    if a.dtype.kind not in "biuf" or a.ndim != 1:
        raise InputStreamError(src, None, "clutch", f"{a.dtype} array of shape {a.shape}",
                               "0/1 or booleans of shape (N,)")  # fmt: skip
    bad = np.flatnonzero((a != 0) & (a != 1))
    if bad.size:
        k = int(bad[0])
        raise InputStreamError(src, k, "clutch", a[k].item(), "0 (released) or 1 (engaged)")
    return np.asarray(a == 1)


def write_track(track: MasterTrack, path: str | Path) -> Path:
    """Write a track as CSV or NPZ (by suffix), in the format `read_track` reads."""
    path = Path(path)
    if path.suffix.lower() == ".npz":
        arrays: dict[str, Any] = {"time_s": track.time, "position_m": track.position,
                  "clutch": track.clutch.astype(np.int8)}  # fmt: skip
        if track.intended is not None:
            arrays["intended_m"] = track.intended
        with open(path, "wb") as fh:
            np.savez_compressed(fh, **arrays)
        return path
    rows = np.column_stack([track.time, track.position, track.clutch.astype(float)])
    with open(path, "w") as fh:
        fh.write(",".join(COLUMNS) + "\n")
        for r in rows.tolist():
            fh.write(f"{r[0]!r},{r[1]!r},{r[2]!r},{r[3]!r},{int(r[4])}\n")
    return path
