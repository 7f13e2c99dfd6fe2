"""RCM control: tasks, limits, step solvers, targets, phases and the run log. The controller
that runs Algorithms 1 and 2 on them (`rcmplan.controller`) sits above the compiled runner it
calls, which itself uses what is here. Names load on first use."""

from __future__ import annotations

from typing import TYPE_CHECKING

from rcmplan._lazy import lazy_names

_EXPORTS: dict[str, str] = {
    "DlsSolver": "rcmplan.control.solvers",
    "LoopSettings": "rcmplan.control.phase",
    "Phase": "rcmplan.control.phase",
    "PinvSolver": "rcmplan.control.solvers",
    "RunLog": "rcmplan.control.log",
    "TipSolver": "rcmplan.control.solvers",
    "Tolerance": "rcmplan.control.solvers",
    "augmented_jacobian": "rcmplan.control.augmented",
    "extended_task": "rcmplan.control.augmented",
    "interpolate": "rcmplan.control.phase",
    "rcm_target": "rcmplan.control.targets",
    "solve_pose": "rcmplan.control.targets",
    "split_steps": "rcmplan.control.phase",
}

__all__ = [
    "DlsSolver",
    "LoopSettings",
    "Phase",
    "PinvSolver",
    "RunLog",
    "TipSolver",
    "Tolerance",
    "augmented_jacobian",
    "extended_task",
    "interpolate",
    "rcm_target",
    "solve_pose",
    "split_steps",
]


__getattr__ = lazy_names("rcmplan.control", _EXPORTS, globals())


if TYPE_CHECKING:
    from rcmplan.control.augmented import augmented_jacobian, extended_task
    from rcmplan.control.log import RunLog
    from rcmplan.control.phase import LoopSettings, Phase, interpolate, split_steps
    from rcmplan.control.solvers import DlsSolver, PinvSolver, TipSolver, Tolerance
    from rcmplan.control.targets import rcm_target, solve_pose
