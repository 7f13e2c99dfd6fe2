"""The teleoperation trace: per control period, what the pipeline saw and made (beside the run
log, which holds the robot's state). Written as `teleop.npz` next to `log.npz`.

Arrays, one row per period: time [s] (plant time), sample_time [s] (the master sample's own
stamp), master (3,) [m] raw master position, filtered (3,) [m], engaged (bool), desired (3,)
[m] the desired tip in the base frame (before any fixture), segment (int: the index of the
engagement the period belongs to, -1 while released), pipeline_s and control_s [s] (wall time
of the pipeline, and of the solver step and plant period).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rcmplan._atomic import atomic_path
from rcmplan._validate import FloatArray

FIELDS = ("time", "sample_time", "master", "filtered", "engaged", "desired", "segment",
          "pipeline_s", "control_s")  # fmt: skip
WIDE = ("master", "filtered", "desired")


@dataclass(frozen=True)
class Trace:
    """Per-period arrays (module docstring)."""

    time: FloatArray
    sample_time: FloatArray
    master: FloatArray
    filtered: FloatArray
    engaged: NDArray[np.bool_]
    desired: FloatArray
    segment: NDArray[np.int64]
    pipeline_s: FloatArray
    control_s: FloatArray

    def __len__(self) -> int:
        return int(self.time.shape[0])

    def save_npz(self, path: str | Path, **extra: Any) -> None:
        """Write the arrays (and `extra` arrays) to an NPZ file, atomically."""
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            np.savez_compressed(fh, **{k: getattr(self, k) for k in FIELDS}, **extra)

    @staticmethod
    def load_npz(path: str | Path) -> Trace:
        """Read a trace written by save_npz."""
        with np.load(path) as z:
            return Trace(**{k: z[k] for k in FIELDS})


@dataclass
class TraceBuilder:
    """Collects one row per period; `finish` returns the Trace (also after a failure)."""

    _rows: list[tuple[Any, ...]] = field(default_factory=list)

    def append(self, *row: Any) -> None:
        """One row in FIELDS order."""
        self._rows.append(row)

    def __len__(self) -> int:
        return len(self._rows)

    def finish(self) -> Trace:
        """The rows so far as arrays."""
        rows = list(self._rows)  # an interrupt may land in `append`: rows are whole tuples
        cols = list(zip(*rows, strict=True)) if rows else [() for _ in FIELDS]
        out: dict[str, Any] = {}
        for k, col in zip(FIELDS, cols, strict=True):
            if k in WIDE:
                out[k] = np.array(col, dtype=float).reshape(-1, 3)
            elif k == "engaged":
                out[k] = np.array(col, dtype=bool)
            elif k == "segment":
                out[k] = np.array(col, dtype=np.int64)
            else:
                out[k] = np.array(col, dtype=float)
        return Trace(**out)
