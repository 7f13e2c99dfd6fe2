"""A QP solver that keeps what it solves, for benchmarks that time steps at a real run's states."""

from __future__ import annotations

from typing import Any

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.control.qp import QpSolver
from rcmplan.control.qp_backends import QpResult
from rcmplan.control.qp_problem import QPProblem, StepQP


class RecordingQp(QpSolver):
    """A QpSolver that keeps every state (q, lambda, target) it builds a QP at, and the QP (a
    subclass: it runs on the reference path)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.states: list[FloatArray] = []
        self.problems: list[QPProblem] = []

    def _solve(
        self,
        robot: Any,
        q: FloatArray,
        lam: float,
        target: FloatArray,
        rcm_tolerance: float | None = None,
    ) -> tuple[StepQP, QpResult]:
        """The solver's solve; a state's first solve with the limits' own RCM box is kept (a
        narrower box's solve, `QpSolver.step`'s hold of the box, is not a new state)."""
        before = self.last
        out = super()._solve(robot, q, lam, target, rcm_tolerance)
        if rcm_tolerance is None and out is not before:
            self.states.append(np.concatenate([q, [lam], target]))
            self.problems.append(out[0].problem)
        return out
