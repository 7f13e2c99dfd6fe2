"""Helpers shared by the benchmark modules: timing, rows, the fast-path controller."""

from __future__ import annotations

import os
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from rcmplan.compiled.runner import fast_check_targets, fast_converge_phase
from rcmplan.control import Phase
from rcmplan.control.runner import ReferenceRunner, register_default
from rcmplan.controller import Controller

THESIS_ITERATION_S = 180.0 / 1350  # V-REP loop: about 3 min for 1350 iterations (sec. 4.1.2)


def quick() -> bool:
    """True when run.py was given --quick (fewer repetitions)."""
    return os.environ.get("RCMPLAN_BENCH_QUICK") == "1"


def per_call(fn: Callable[[], Any], number: int, repeat: int = 7) -> float:
    """Median over `repeat` batches of the time per call in [s], `number` calls per batch."""
    fn()
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        for _ in range(number):
            fn()
        times.append((time.perf_counter() - t) / number)
    return statistics.median(times)


def row(
    figure: str, value: float | str, unit: str, peer: str = "", peer_value: float | None = None,
    target: str = "",
) -> dict[str, Any]:  # fmt: skip
    """One table row; ratio = value / peer_value (for times below 1 means rcmplan is faster)."""
    ok = isinstance(value, float | int) and peer_value not in (None, 0)
    ratio = float(value) / float(peer_value) if ok else None  # type: ignore[arg-type]
    return {"figure": figure, "value": value, "unit": unit, "peer": peer,
            "peer_value": peer_value, "ratio": ratio, "target": target}  # fmt: skip


def use_path(mode: str | None) -> None:
    """ "off": the Python loop runs every phase (the reference runner registered as the
    default); "on" or None: the compiled runner, where it applies (the default)."""
    register_default(ReferenceRunner() if mode == "off" else None)


class FastController(Controller):
    """A Controller that always takes the compiled path, or raises."""

    def check_targets(self, targets: np.ndarray) -> None:
        if not fast_check_targets(self.robot, targets):
            super().check_targets(targets)

    def run_phase(self, phase: Phase) -> None:
        solver = self.solver if phase.kind == "rcm" else self.free_solver
        pid, sid = self.log.phase_id(phase.name), self.log.solver_id(solver.name)
        q = self.robot.joints_from_actuators(self.plant.read_actuators())
        targets = phase.plan(q)
        if phase.kind == "rcm":
            if callable(phase.targets):
                self.check_targets(targets)
            self.lam = self._closest_lambda(q, targets[0][3:])
        if not fast_converge_phase(self, solver, targets, pid, sid):
            raise RuntimeError("the compiled path declined this phase")
