"""An objective: a task with its target, gain and weight, one term of the QP's cost.

The QP (`qp_problem.build_step`) minimises over x = (ds[active], l dlambda) / SCALE

    1/2 |W (J T x SCALE - K e)|^2 / SCALE^2

for its X_ext (or X_c) task plus one such term per objective: e = target - value, J the task's
Jacobian over (q[active], lambda) (`control/tasks.py`), T the actuator map
(`Configuration.kinematics`). An objective pulls the step towards its target at rate K,
traded against the others by W; for example `Objective(Posture(), home[active], 0.2, 1e-3)`
keeps a redundant arm near a posture while the X_ext task and the limits hold the needle.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rcmplan._validate import FloatArray, array, has_methods
from rcmplan.control.configuration import Configuration
from rcmplan.control.cost import weighted_cost
from rcmplan.control.tasks import Task
from rcmplan.exceptions import InvalidInputError


@dataclass(frozen=True, eq=False)
class Objective:
    """A task (`value`, `jacobian` over (q[active], lambda)) with its target (k,), gain K in
    (0, 2) and weight W > 0 (each a number, or one per row)."""

    task: Task
    target: FloatArray
    gain: float | FloatArray = 1.0
    weight: float | FloatArray = 1.0

    def __post_init__(self) -> None:
        has_methods("task", self.task, ("value", "jacobian"), "a task (control/tasks.py)")
        target = array("target", self.target, 1)
        gain = array("gain", self.gain, (0, 1))
        weight = array("weight", self.weight, (0, 1))
        if np.any(gain <= 0.0) or np.any(gain >= 2.0):
            raise InvalidInputError("gain", self.gain, "gains in (0, 2)")
        if np.any(weight <= 0.0) or np.any(weight > 1e6):
            raise InvalidInputError("weight", self.weight, "weights in (0, 1e6]")
        for name, value in (("gain", gain), ("weight", weight)):
            if value.ndim == 1 and value.shape != target.shape:
                given = self.gain if name == "gain" else self.weight
                raise InvalidInputError(name, given, f"a number or {target.shape[0]} values")
        object.__setattr__(self, "target", target)
        object.__setattr__(self, "gain", np.broadcast_to(gain, target.shape).copy())
        object.__setattr__(self, "weight", np.broadcast_to(weight, target.shape).copy())

    def error(self, cfg: Configuration) -> FloatArray:
        """target - the task's value at the configuration (k,)."""
        value = self.task.value(cfg.robot, cfg.q, cfg.lam)
        if value.shape != self.target.shape:
            raise InvalidInputError("target", self.target, f"{value.shape[0]} values, as the task")
        return np.asarray(self.target - value, dtype=float)

    def cost(self, cfg: Configuration) -> tuple[FloatArray, FloatArray]:
        """This term's (H, f) over x (`qp_problem.weighted_cost`, no damping)."""
        J = self.task.jacobian(cfg.robot, cfg.q, cfg.lam) @ cfg.kinematics.T
        n = J.shape[1]
        H, f = np.empty((n, n)), np.empty(n)
        K, W = np.asarray(self.gain, dtype=float), np.asarray(self.weight, dtype=float)
        weighted_cost(np.ascontiguousarray(J), W, K, self.error(cfg), 0.0, H, f)
        return H, f
