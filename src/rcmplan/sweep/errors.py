"""Errors of the sweep package, each a subclass of the package's one base error."""

from __future__ import annotations

from pathlib import Path

from rcmplan.exceptions import RcmplanError, UnreachableTargetError


class EmptyRegionError(UnreachableTargetError):
    """A sampling region holds no target the robot can reach.

    Attributes:
        counts: Number of samples per status ("reachable", "misses_retina", "unreachable").
    """

    def __init__(self, reason: str, counts: dict[str, int] | None = None) -> None:
        self.counts = dict(counts or {})
        super().__init__(reason)


class CheckpointError(RcmplanError):
    """A checkpoint is corrupt, was written for other settings, or cannot be written.

    Attributes:
        path: The offending file or folder.
        problem: What is wrong with it.
    """

    status = "checkpoint_error"

    def __init__(self, path: str | Path, problem: str) -> None:
        self.path = Path(path)
        self.problem = problem
        super().__init__(f"checkpoint {self.path}: {problem}")


class SchedulerError(RcmplanError):
    """A Dask scheduler did not answer, or the cluster failed the sweep.

    Attributes:
        address: The scheduler address.
        timeout_s: The connection timeout in [s].
    """

    status = "scheduler_error"

    def __init__(self, address: str, timeout_s: float, problem: str) -> None:
        self.address = address
        self.timeout_s = timeout_s
        super().__init__(f"Dask scheduler {address!r}: {problem}")
