"""Checkpoints: finished results on disk as they arrive, so an interrupted sweep resumes.

`RecordCheckpoint` holds records of any run whose settings hash and whose records have an id
and a plain-dictionary form; `Checkpoint` is a sweep's (settings `SweepSettings`, records
`TargetResult`). A checkpoint is a folder:

    header.json            {"format": "rcmplan-sweep-checkpoint", "version": 2,
                            "settings_hash": <sha256>, "settings": {...}, "n_targets": N}
    chunk-<first id>.json  {"settings_hash": <sha256>, "results": [TargetResult, ...],
                            "sha256": <sha256 of the canonical JSON of "results">}

Each chunk file is written whole to a temporary name, flushed to disk and renamed into place, so
a killed process leaves either a complete chunk or none (stray temporary files are removed on
open). On resume every chunk is read and checked: valid JSON, the sweep's settings hash, the
checksum, known fields, ids in range and never repeated. Any failure raises CheckpointError
naming the file and the problem; a checkpoint is never silently reused or overwritten. A
checkpoint of an older format version is refused the same way, saying what changed (a sweep's
version 1 spelled its statuses with hyphens, "no-convergence", where version 2 records the
statuses the run summaries name, "no_convergence"): rerun without --resume.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from collections.abc import Iterable
from pathlib import Path
from typing import Any, ClassVar, Generic, Protocol, Self, TypeVar

from rcmplan._atomic import atomic_path
from rcmplan.sweep.errors import CheckpointError
from rcmplan.sweep.settings import FORMAT_VERSION, SweepSettings
from rcmplan.sweep.task import TargetResult

FORMAT_NAME = "rcmplan-sweep-checkpoint"
HEADER = "header.json"


class Plan(Protocol):
    """What a checkpointed run runs: hashed into every file, written into the header."""

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON-ready dictionary."""
        ...

    def digest(self) -> str:
        """A hash of the settings (hex)."""
        ...


class Record(Protocol):
    """One finished item of a checkpointed run."""

    @property
    def id(self) -> int:
        """The item's id, in [0, the run's item count)."""
        ...

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON-ready dictionary."""
        ...


S = TypeVar("S", bound=Plan)
R = TypeVar("R", bound=Record)


def _canonical(obj: Any) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)


def _digest(results: list[dict[str, Any]]) -> str:
    return hashlib.sha256(_canonical(results).encode()).hexdigest()


def write_atomic(path: Path, text: str) -> None:
    """Write text to path through a temporary file, fsync and rename (all or nothing; the
    temporary file is removed when the write fails or is interrupted: `rcmplan._atomic`)."""
    try:
        with atomic_path(path) as tmp, open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
    except OSError as exc:
        raise CheckpointError(path, f"cannot be written ({exc})") from exc


def _read_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise CheckpointError(path, f"is not readable JSON ({exc}); it is corrupt") from exc


def discard(path: str | Path) -> None:
    """Remove the checkpoint folder at `path` (nothing there, or an empty folder: nothing to
    do); CheckpointError, nothing removed, when `path` is not a checkpoint folder."""
    folder = Path(path)
    if not folder.exists() or (folder.is_dir() and not any(folder.iterdir())):
        return
    if not (folder / HEADER).is_file():
        raise CheckpointError(folder, "is not a checkpoint folder (no header.json); not removed")
    shutil.rmtree(folder)


class RecordCheckpoint(Generic[S, R]):
    """A checkpoint folder bound to one run's settings; use `open`. Subclasses say how many
    items the settings hold (`count`) and read a record back (`parse`).

    Attributes:
        path: The folder.
        digest: The settings hash every file must carry.
        n_targets: Ids must lie in [0, n_targets).
        kind: What runs, in messages ("sweep").
        format_name: The header's "format".
        format_version: The header's "version": the form of the records.
        older_versions: Why a checkpoint of each older version cannot be resumed, by version.
    """

    kind = "run"
    format_name = FORMAT_NAME
    format_version = FORMAT_VERSION
    older_versions: ClassVar[dict[int, str]] = {}

    def __init__(self, path: Path, settings: S) -> None:
        self.path = path
        self.settings = settings
        self.digest = settings.digest()
        self.n_targets = self.count(settings)

    @staticmethod
    def count(settings: S) -> int:
        """The number of items the settings hold."""
        raise NotImplementedError

    @staticmethod
    def parse(row: dict[str, Any]) -> R:
        """A record from its dictionary; KeyError or TypeError when malformed."""
        raise NotImplementedError

    @classmethod
    def open(cls, path: str | Path, settings: S, resume: bool) -> Self:
        """Create the checkpoint, or reopen an existing one for the same settings.

        Raises CheckpointError if the path is not a folder, the header is corrupt or for other
        settings, or the checkpoint already holds results and resume is False.
        """
        cp = cls(Path(path), settings)
        if cp.path.exists() and not cp.path.is_dir():
            raise CheckpointError(cp.path, "exists and is not a checkpoint folder")
        cp.path.mkdir(parents=True, exist_ok=True)
        for stray in [*cp.path.glob(".*.tmp*"), *cp.path.glob("*.tmp")]:  # a killed writer's
            stray.unlink(missing_ok=True)
        chunks = cp.chunk_files()
        if not (cp.path / HEADER).exists():
            if chunks:
                raise CheckpointError(cp.path / HEADER, "is missing while chunk files exist")
            write_atomic(cp.path / HEADER, _canonical(cp.header()))
            return cp
        cp.check_header()
        if chunks and not resume:
            raise CheckpointError(
                cp.path,
                f"already holds {len(chunks)} finished chunk(s); resume it (--resume) or "
                "choose another path",
            )
        return cp

    def header(self) -> dict[str, Any]:
        """The header record of this checkpoint."""
        return {
            "format": self.format_name,
            "version": self.format_version,
            "settings_hash": self.digest,
            "settings": self.settings.as_dict(),
            "n_targets": self.n_targets,
        }

    def check_header(self) -> None:
        """Raise CheckpointError unless header.json is this format and these settings."""
        path = self.path / HEADER
        data = _read_json(path)
        if not isinstance(data, dict) or data.get("format") != self.format_name:
            raise CheckpointError(path, f"is not a {self.format_name} header")
        version = data.get("version")
        if version != self.format_version:
            why = self.older_versions.get(version) if isinstance(version, int) else None
            problem = f"has format version {version!r}, expected {self.format_version}"
            raise CheckpointError(path, problem + (f": {why}" if why else ""))
        if data.get("settings_hash") != self.digest:
            theirs = str(data.get("settings_hash"))[:12]
            raise CheckpointError(
                path,
                f"was written for other {self.kind} settings (hash {theirs}, this {self.kind} "
                f"{self.digest[:12]}); choose another path or remove it",
            )

    def chunk_files(self) -> list[Path]:
        """Finished chunk files, sorted by name."""
        return sorted(self.path.glob("chunk-*.json"))

    def write(self, results: Iterable[R]) -> Path | None:
        """Write one finished chunk atomically; returns its path (None for an empty chunk)."""
        rows = [r.as_dict() for r in sorted(results, key=lambda r: r.id)]
        if not rows:
            return None
        path = self.path / f"chunk-{rows[0]['id']:07d}.json"
        record = {"settings_hash": self.digest, "results": rows, "sha256": _digest(rows)}
        write_atomic(path, _canonical(record))
        return path

    def load(self) -> dict[int, R]:
        """Every finished result by id, each chunk checked (CheckpointError names a bad file)."""
        out: dict[int, R] = {}
        for path in self.chunk_files():
            for result in self._load_chunk(path):
                if result.id in out:
                    raise CheckpointError(path, f"repeats target id {result.id}")
                out[result.id] = result
        return out

    def _load_chunk(self, path: Path) -> list[R]:
        data = _read_json(path)
        if not isinstance(data, dict) or not isinstance(data.get("results"), list):
            raise CheckpointError(path, "is not a chunk record (no 'results' list); corrupt")
        if data.get("settings_hash") != self.digest:
            raise CheckpointError(path, f"was written for other {self.kind} settings")
        rows = data["results"]
        if data.get("sha256") != _digest(rows):
            raise CheckpointError(path, "fails its checksum; it is corrupt")
        try:
            results = [self.parse(row) for row in rows]
        except (KeyError, TypeError) as exc:
            raise CheckpointError(path, f"holds a malformed result ({exc})") from exc
        for r in results:
            if not (isinstance(r.id, int) and 0 <= r.id < self.n_targets):
                bad = f"holds target id {r.id!r} outside [0, {self.n_targets})"
                raise CheckpointError(path, bad)
        return results


class Checkpoint(RecordCheckpoint[SweepSettings, TargetResult]):
    """A sweep's checkpoint: one record per reachable target of the region."""

    kind = "sweep"
    format_version = 2
    older_versions: ClassVar[dict[int, str]] = {
        1: "its results spell their statuses with hyphens (no-convergence, unreachable-path, "
        "singular, slider-limit), as rcmplan did before the sweep took the run summaries' "
        "names (no_convergence, unreachable_target, singular_pose, actuator_limit)",
    }

    @staticmethod
    def count(settings: SweepSettings) -> int:
        """The region's number of targets."""
        return settings.region.n_targets

    @staticmethod
    def parse(row: dict[str, Any]) -> TargetResult:
        """A target's result."""
        return TargetResult.from_dict(row)
