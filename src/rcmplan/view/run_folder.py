"""Read a run folder for the view: the log, summary.json and its scene, every file checked.

A run folder is what `rcmplan inject`, `spiral` and `teleop` write (`summary.json`, `log.npz`,
`log.csv`, ...); `rcmplan compare` writes a summary.json listing its `methods` and one run
folder per method (an older version wrote `compare.json` instead of that summary). Any
other folder, a log written by another version of rcmplan (fields missing, another layout, no
`scene` block), or a truncated file raises RunFolderError naming the file and what is wrong,
before a server starts. A subretinal episode's folder (`rcmplan subretinal`) also holds
bscans.npz, the B-scans of the iOCT volumes its controller received, and episode.npz.
"""

from __future__ import annotations

import json
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan._version import __version__
from rcmplan.control.log import ARRAY_FIELDS, INT_FIELDS, SHAPES, WIDE, RunLog
from rcmplan.exceptions import InvalidInputError, RunFolderError
from rcmplan.scene.record import SceneRecord, read_scene_record

if TYPE_CHECKING:
    from rcmplan.subretinal.episode_bscans import EpisodeBScans

WHAT_A_RUN_IS = (
    "a run folder holds summary.json and log.npz (written by rcmplan inject, spiral, teleop "
    "or subretinal); a comparison folder holds summary.json with a `methods` list and one run "
    "folder per method"
)


@dataclass(frozen=True)
class RunData:
    """One run to show.

    Attributes:
        folder: The run folder. label: Its name in the view (the method of a comparison).
        summary: summary.json as read. log: The run log. scene: The eye, trocar and points.
        bscans: A subretinal episode's B-scans (bscans.npz), else None.
        tissue_depth_m: A subretinal episode's true tip depth in tissue per record [m]
            (episode.npz `depth_m`), else None.
    """

    folder: Path
    label: str
    summary: dict[str, Any]
    log: RunLog
    scene: SceneRecord
    bscans: EpisodeBScans | None = None
    tissue_depth_m: FloatArray | None = None

    @property
    def robot_name(self) -> str:
        """The robot the run drove (summary.json `robot`)."""
        return str(self.summary.get("robot", ""))

    @property
    def robot_source(self) -> str:
        """What `make_robot` builds the run's robot from: the robot file it was read from
        (summary.json `robot_file`), else its name."""
        return str(self.summary.get("robot_file") or self.robot_name)


def load_runs(path: str | Path) -> list[RunData]:
    """The runs in a folder: one for a run folder, one per method for a comparison folder.

    `path` may also name a run's summary.json or log.npz. Raises RunFolderError.
    """
    folder = Path(path)
    if folder.is_file() and folder.name in ("summary.json", "log.npz", "compare.json"):
        folder = folder.parent
    if not folder.exists():
        raise RunFolderError(folder, f"no such folder; {WHAT_A_RUN_IS}")
    if not folder.is_dir():
        raise RunFolderError(folder, f"not a folder; {WHAT_A_RUN_IS}")
    if (folder / "summary.json").is_file():
        if "methods" in read_json(folder / "summary.json"):
            return _comparison(folder / "summary.json")
        return [load_run(folder)]
    if (folder / "compare.json").is_file():
        return _comparison(folder / "compare.json")
    raise RunFolderError(folder, f"not a run folder (no summary.json); {WHAT_A_RUN_IS}")


def load_run(folder: Path, label: str | None = None) -> RunData:
    """One run folder, checked: summary.json, its scene block, log.npz and their agreement."""
    summary = read_json(folder / "summary.json")
    status = summary.get("status")
    kind = summary.get("command")
    if kind in ("reproduce", "sweep"):  # figures of many runs, no log of one
        raise RunFolderError(folder, f"a folder of `rcmplan {kind}`: figures of many runs, "
                             f"none to replay; {WHAT_A_RUN_IS}")  # fmt: skip
    if not (folder / "log.npz").is_file():
        why = f" (status {status!r}: {summary.get('message', '')})" if status != "ok" else ""
        raise RunFolderError(folder / "log.npz", f"missing: the run left no log{why}")
    scene = _scene(folder / "summary.json", summary)
    log = read_log(folder / "log.npz")
    n = summary.get("iterations", summary.get("periods"))  # a teleop session counts periods
    if n != len(log):
        raise RunFolderError(
            folder / "log.npz", f"holds {len(log)} records but summary.json says {n}: a "
            "truncated log, or a log and a summary of different runs",
        )  # fmt: skip
    if not (folder / "bscans.npz").is_file():
        return RunData(folder, label or folder.name, summary, log, scene)
    from rcmplan.subretinal.episode_bscans import read_bscans  # a subretinal episode's

    bscans = read_bscans(folder / "bscans.npz")
    depth = _tissue_depth(folder / "episode.npz", len(log))
    return RunData(folder, label or folder.name, summary, log, scene, bscans, depth)


def _tissue_depth(path: Path, n: int) -> FloatArray | None:
    """An episode.npz's true tip depth in tissue, one per record of the log (n), if it has
    it; RunFolderError if the file is unreadable."""
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            depth = np.asarray(z["depth_m"], dtype=float) if "depth_m" in z else None
    except (zipfile.BadZipFile, zlib.error, EOFError, ValueError, OSError) as exc:
        raise RunFolderError(path, f"truncated or damaged ({type(exc).__name__}: {exc})") from exc
    return depth if depth is not None and depth.shape == (n,) else None


def _comparison(path: Path) -> list[RunData]:
    """The runs of a comparison whose summary (summary.json, or an older compare.json) is
    `path`, one per method with a run folder beside it."""
    folder, doc = path.parent, read_json(path)
    rows = doc.get("methods")
    if not isinstance(rows, list):
        raise RunFolderError(path, "no `methods` list: not a comparison")
    runs = []
    for row in rows:
        method = row.get("method") if isinstance(row, dict) else None
        if isinstance(method, str) and (folder / method / "summary.json").is_file():
            runs.append(load_run(folder / method, method))
    if not runs:
        raise RunFolderError(
            path, "no method has a run folder beside it (written by a version "
            "of rcmplan that kept no logs of a comparison?): run rcmplan compare again",
        )  # fmt: skip
    return runs


def read_json(path: Path) -> dict[str, Any]:
    """A JSON object from a file; RunFolderError if unreadable, truncated or not an object."""
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise RunFolderError(path, f"cannot be read ({exc.strerror or exc})") from exc
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise RunFolderError(path, f"not valid JSON (truncated?): {exc}") from exc
    if not isinstance(doc, dict):
        raise RunFolderError(path, "not a JSON object")
    return doc


def _scene(path: Path, summary: dict[str, Any]) -> SceneRecord:
    if "scene" not in summary:
        version = summary.get("rcmplan_version", "an older version")
        raise RunFolderError(
            path, f"no `scene` block (the eye, trocar and points the view draws): written by a "
            f"version of rcmplan ({version}) that did not record it; run the command again "
            f"with this rcmplan ({__version__})",
        )  # fmt: skip
    if summary["scene"] is None:
        raise RunFolderError(
            path, f"the run has no scene: it stopped before its eye was placed (status "
            f"{summary.get('status')!r}: {summary.get('message', '')})",
        )  # fmt: skip
    try:
        return read_scene_record(summary["scene"])
    except InvalidInputError as exc:
        raise RunFolderError(path, f"its scene block is not one this version reads: {exc}") from exc


def read_log(path: Path) -> RunLog:
    """log.npz, every field present with its shape; RunFolderError otherwise."""
    try:
        with np.load(path, allow_pickle=False) as z:
            missing = [k for k in (*ARRAY_FIELDS, "phase_names", "solver_names") if k not in z]
            if missing:
                raise RunFolderError(
                    path, f"lacks the fields {', '.join(missing)}: a log written by another "
                    f"version of rcmplan (this one is {__version__}), or not a run log",
                )  # fmt: skip
            arrays: dict[str, Any] = {k: np.asarray(z[k]) for k in ARRAY_FIELDS}
            phases = tuple(str(s) for s in z["phase_names"])
            solvers = tuple(str(s) for s in z["solver_names"])
            labels = tuple(str(s) for s in z["actuator_labels"]) if "actuator_labels" in z else ()
    except (zipfile.BadZipFile, zlib.error, EOFError, ValueError, OSError, KeyError) as exc:
        raise RunFolderError(path, f"truncated or damaged ({type(exc).__name__}: {exc})") from exc
    _check_shapes(path, arrays, len(phases))
    return RunLog(**arrays, phase_names=phases, solver_names=solvers, actuator_labels=labels)


def _check_shapes(path: Path, arrays: dict[str, np.ndarray], n_phases: int) -> None:
    n = len(arrays["time"])
    if n == 0:
        raise RunFolderError(path, "holds no records: the run stopped before its first step")
    for k, a in arrays.items():
        want = (n, SHAPES[k]) if k in SHAPES else (n,)
        wide = k in WIDE and a.ndim == 2 and a.shape[0] == n and a.shape[1] >= 1
        if a.shape != want and not wide:
            raise RunFolderError(path, f"field {k!r} has shape {a.shape}, expected {want}: a log "
                                 "of another version, or a damaged file")  # fmt: skip
        kind = "iu" if k in INT_FIELDS else "f"
        if a.dtype.kind not in kind:
            raise RunFolderError(path, f"field {k!r} has dtype {a.dtype}, expected "
                                 f"{'integers' if k in INT_FIELDS else 'floats'}")  # fmt: skip
    if arrays["sliders"].shape[1] != arrays["joints"].shape[1]:
        raise RunFolderError(path, "sliders and joints have different widths")
    time = arrays["time"]
    if not np.all(np.isfinite(time)) or np.any(np.diff(time) < 0):
        raise RunFolderError(path, "field 'time' is not finite and non-decreasing")
    phase = arrays["phase"]
    if phase.min() < 0 or phase.max() >= max(n_phases, 1):
        raise RunFolderError(path, f"phase ids outside the {n_phases} phase names")
