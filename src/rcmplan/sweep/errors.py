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


class WorkerLostError(RcmplanError):
    """Local worker processes kept dying while the run's chunks ran (killed by a signal, the
    system's out-of-memory killer, a crash): each time the pool broke, its unfinished chunks
    ran again on a new one, until it broke `breaks` times.

    Attributes:
        exit_codes: The dead workers' exit codes (negative: the signal that ended them).
        pending: Chunks not run.
        breaks: How many times the pool broke.
    """

    status = "worker_lost"

    def __init__(self, exit_codes: list[int], pending: int, breaks: int = 1) -> None:
        self.exit_codes = list(exit_codes)
        self.pending = pending
        self.breaks = breaks
        ends = endings(self.exit_codes)
        super().__init__(
            f"local worker processes died and the pool broke {breaks} time{'s' * (breaks > 1)} "
            f"(workers ended: {ends}); {pending} chunks not run (finished ones are in the "
            "checkpoint: rerun with --resume)"
        )


def ending(code: int) -> str:
    """How a process ended, from its exit code (negative: the signal)."""
    if code < 0:
        import signal

        try:
            return f"signal {signal.Signals(-code).name}"
        except ValueError:
            return f"signal {-code}"
    return f"exit code {code}"


def endings(codes: list[int]) -> str:
    """How processes ended, from their exit codes (`ending`, comma-separated), or "cause
    unknown" for none."""
    return ", ".join(ending(code) for code in codes) or "cause unknown"
