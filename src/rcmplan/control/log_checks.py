"""The fields of a `RunLog`, checked when it is made: arrays of their dtype and shape."""

from __future__ import annotations

from typing import Any

import numpy as np

from rcmplan.exceptions import InvalidInputError

ARRAY_FIELDS = (
    "time", "sliders", "joints", "lam", "tip", "rcm", "trocar", "base", "target_tip", "error",
    "roll_error", "step", "iteration", "solver", "phase",
)  # fmt: skip


SHAPES = {"sliders": 6, "joints": 6, "tip": 3, "rcm": 3, "trocar": 3, "base": 3,
          "target_tip": 3, "error": 6}  # fmt: skip
INT_FIELDS = ("step", "iteration", "solver", "phase")
WIDE = ("sliders", "joints")  # one column per actuator or joint of the robot (iRAM!S: 6)


def checked_fields(log: Any) -> dict[str, Any]:
    """The log's fields as arrays of their dtype and shape (n records; `roll_error` may be
    empty), its names as tuples of strings; InvalidInputError naming the first that is not."""
    n = _records(log.time)
    out: dict[str, Any] = {}
    for k in ARRAY_FIELDS:
        value = getattr(log, k)
        try:
            arr = np.asarray(value)
            kinds = "iu" if k in INT_FIELDS else "iuf"
            ok = arr.dtype.kind in kinds and arr.ndim == (2 if k in SHAPES else 1)
            ok = ok and (arr.shape[0] == n or (k == "roll_error" and arr.size == 0))
            ok = ok and (k not in SHAPES or k in WIDE or arr.shape[1] == SHAPES[k])
        except (TypeError, ValueError):
            ok = False
        if not ok:
            width = "" if k not in SHAPES else (", k" if k in WIDE else f", {SHAPES[k]}")
            valid = f"an array of shape ({n}{width}): one row per record, as many as time has"
            raise InvalidInputError(f"{k} (or time)", value, valid)
        out[k] = arr.astype(np.int64 if k in INT_FIELDS else np.float64, copy=False)
    for k in ("phase_names", "solver_names", "actuator_labels"):
        names = getattr(log, k)
        if not isinstance(names, tuple | list) or not all(isinstance(v, str) for v in names):
            raise InvalidInputError(k, names, "a tuple of strings")
        out[k] = tuple(names)
    return out


def _records(time: Any) -> int:
    """The number of records: the length of the 1-D time column."""
    arr = np.asarray(time) if isinstance(time, np.ndarray | list | tuple) else None
    if arr is None or arr.ndim != 1 or arr.dtype.kind not in "iuf":
        raise InvalidInputError("time", time, "an array of times in s, one per record")
    return int(arr.shape[0])
