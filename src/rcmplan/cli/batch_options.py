"""Where a command's batch of jobs runs and where it keeps its checkpoint: the options
--workers, --scheduler, --timeout, --checkpoint and --resume, their checks, and the checkpoint
they open. `rcmplan sweep` and `rcmplan subretinal --episodes` share them."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from rcmplan._validate import integer
from rcmplan.sweep.executors import DEFAULT_TIMEOUT_S

if TYPE_CHECKING:
    from rcmplan.sweep.checkpoint import RecordCheckpoint

MAX_WORKERS = 1024  # local processes one batch starts at most
CP = TypeVar("CP", bound="RecordCheckpoint[Any, Any]")


def add_batch_options(p: argparse.ArgumentParser, what: str, prefix: str = "") -> None:
    """--workers, --scheduler, --timeout, --checkpoint, --resume; `what` names the run in the
    help of --resume ("sweep"), `prefix` starts every help ("--episodes: ")."""
    p.add_argument("--workers", type=int, help=f"{prefix}local processes (default: every core)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help=f"{prefix}Dask scheduler address (tcp://...)")  # fmt: skip
    p.add_argument("--timeout", type=float, default=DEFAULT_TIMEOUT_S, metavar="S",
                   help=f"{prefix}Dask: time to connect, and to wait for a worker when none is "
                   f"left, positive, in s ({DEFAULT_TIMEOUT_S:g})")  # fmt: skip
    p.add_argument("--checkpoint", metavar="PATH",
                   help=f"{prefix}checkpoint folder (OUT/checkpoint)")  # fmt: skip
    p.add_argument("--resume", action="store_true",
                   help=f"{prefix}continue the checkpoint of an interrupted {what} of the same "
                   "settings (without it, a rerun discards the checkpoint and starts "
                   "afresh)")  # fmt: skip


def check_batch_options(args: argparse.Namespace) -> None:
    """--timeout (positive, in s) and --workers (1 to MAX_WORKERS), each under its own name."""
    from rcmplan.sweep.executors import check_timeout

    check_timeout(args.timeout, "--timeout")
    if args.workers is not None:
        integer("--workers", args.workers, 1, MAX_WORKERS)


def checkpoint_path(args: argparse.Namespace, out: Path) -> Path:
    """The checkpoint folder: --checkpoint, else OUT/checkpoint."""
    return Path(args.checkpoint or out / "checkpoint")


def open_checkpoint(path: Path, settings: Any, resume: bool, kind: type[CP]) -> CP:
    """The run's checkpoint of type `kind` (the sweep's `Checkpoint`, or another run's): with
    --resume the one at `path` continued (it must hold these settings), else a new one in place
    of the checkpoint an earlier run left there, as every command writes over its earlier
    outputs (a folder that is no checkpoint is never removed)."""
    from rcmplan.sweep.checkpoint import discard
    from rcmplan.sweep.errors import CheckpointError

    if not resume:
        discard(path)
    try:
        return kind.open(path, settings, resume)
    except CheckpointError as exc:
        hint = "; rerun without --resume to start afresh" if resume else ""
        raise CheckpointError(exc.path, exc.problem + hint) from exc


def resume_record(
    path: Path, resume: bool, header_found: bool, results: int, run: str = "sweep"
) -> dict[str, Any]:
    """summary.json's `resumed`: whether --resume was given, how many results the checkpoint at
    `path` gave, and, when --resume found nothing to continue, why and that the run (`run`:
    "sweep", "batch") started afresh (the same sentence the command prints on stderr)."""
    message = ""
    if resume and results == 0:
        why = "holds no finished results" if header_found else "is no checkpoint (none there)"
        message = f"nothing to resume: {path} {why}; the {run} starts afresh"
    return {"requested": resume, "resumed_from_checkpoint": results, "started_afresh": results == 0,
            "message": message}  # fmt: skip
