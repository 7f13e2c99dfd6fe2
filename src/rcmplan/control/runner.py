"""The seam between the control loop and a faster runner of it.

`Controller` asks its runner, before the reference Python code, whether it will check a phase's
targets or run a whole phase itself; a runner that says yes leaves the controller, its log and
the plant exactly as the reference loop would.
The compiled runner (`rcmplan.compiled`) decides by itself, from the robot, solver and plant,
whether it applies, and says no otherwise (a solver or robot subclass, a plant it does not
know). It is every Controller's default; `Controller(runner=ReferenceRunner())` runs the
Python loop explicitly, and `register_default` changes the default of every Controller given
none.
"""

from __future__ import annotations

from typing import Protocol

from rcmplan._validate import FloatArray
from rcmplan.control.log import LogBuilder
from rcmplan.control.phase import LoopSettings
from rcmplan.control.plant import Plant
from rcmplan.control.solvers import Solver
from rcmplan.robot.model import RobotModel


class ControlState(Protocol):
    """What a runner may read and change of the controller that hands it a phase: its robot,
    plant and loop settings, the RCM's lambda, and the log it appends records to."""

    robot: RobotModel
    plant: Plant
    settings: LoopSettings
    lam: float
    log: LogBuilder


class Runner(Protocol):
    """Runs parts of Algorithms 1 and 2 instead of the reference loop, where it applies."""

    def check_targets(self, robot: RobotModel, targets: FloatArray) -> bool:
        """Check RCM targets as `solve_pose` would (raising its errors); False: not done."""
        ...

    def check_curved_targets(
        self, robot: RobotModel, targets: FloatArray, seed: FloatArray | None
    ) -> FloatArray | None:
        """Check a curved needle's targets (N, 7) as `solve_curved_pose` would along the path
        from `seed` (raising its errors); the last target's joints, or None: not done."""
        ...

    def run_phase(
        self, controller: ControlState, solver: Solver, targets: FloatArray, pid: int, sid: int
    ) -> bool:
        """Algorithm 1 on every target of a phase; False: nothing done."""
        ...


class ReferenceRunner:
    """Runs nothing: the controller's own Python code does everything."""

    def check_targets(self, robot: RobotModel, targets: FloatArray) -> bool:
        """Not done here."""
        return False

    def check_curved_targets(
        self, robot: RobotModel, targets: FloatArray, seed: FloatArray | None
    ) -> FloatArray | None:
        """Not done here."""
        return None

    def run_phase(
        self, controller: ControlState, solver: Solver, targets: FloatArray, pid: int, sid: int
    ) -> bool:
        """Not done here."""
        return False


_default: list[Runner | None] = [None]


def register_default(runner: Runner | None) -> None:
    """Make `runner` the one a Controller uses when given none (None: the compiled runner)."""
    _default[0] = runner


def registered_default() -> Runner | None:
    """The runner registered as the default, or None (a Controller then uses the compiled
    runner, `rcmplan.controller`)."""
    return _default[0]
