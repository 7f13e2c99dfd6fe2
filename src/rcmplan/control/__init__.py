"""RCM control: tasks, the augmented Jacobian, step solvers and the thesis's control loops."""

from rcmplan.control.augmented import augmented_jacobian, extended_task
from rcmplan.control.log import RunLog
from rcmplan.control.loop import Controller, LoopSettings, Phase, interpolate, split_steps
from rcmplan.control.solvers import DlsSolver, PinvSolver, TipSolver, Tolerance
from rcmplan.control.targets import rcm_target, solve_pose

__all__ = [
    "Controller",
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
