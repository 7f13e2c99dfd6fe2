"""rcmplan: RCM-constrained needle motion planning for surgical robots (iRAM!S and serial arms).

The main nouns are importable from here, loaded when first used (so `import rcmplan` stays
cheap and the command line starts fast):

- robots: `make_robot(name or FILE.toml)`, `load_robot_file`, `Iramis`, `SerialArm`,
  `JointChain`, `load_urdf`, `load_mjcf`, `needle_arm`, needles;
- control: `Controller`, `LoopSettings`, `Phase`, solvers (`PinvSolver`, `DlsSolver`,
  `QpSolver`, `TipSolver`), tasks, limits, `RunLog`, `rcm_target`, `solve_pose`;
- plants: `KinematicPlant`, `MujocoPlant` (extra `sim`), `make_plant`;
- scene: `default_eye`, `default_points`, `Steps`, `injection`, `spiral`, `load_scenario`,
  `run_scenario`.
"""

from __future__ import annotations

from rcmplan._lazy import lazy_names
from rcmplan._version import __version__
from rcmplan.robot import EXPORTS as ROBOT_EXPORTS

# typing.TYPE_CHECKING without importing typing: the `rcmplan` command imports this package
# before it installs its signal handler (rcmplan.cli.interrupts), and typing took 12 ms of that.
TYPE_CHECKING = False

_EXPORTS: dict[str, str] = {
    # robots and tools: the robot package's names, then loaders and the curved needle
    **ROBOT_EXPORTS,
    "CurvedNeedle": "rcmplan.robot.curved_needle",
    "load_mjcf": "rcmplan.robot.mjcf",
    "load_robot_file": "rcmplan.robot.robot_file",
    "load_urdf": "rcmplan.robot.urdf",
    "make_robot": "rcmplan.robot.registry",
    "needle_arm": "rcmplan.robot.arms",
    # control: the loop, solvers, tasks, limits, the log
    "Controller": "rcmplan.controller",
    "DlsSolver": "rcmplan.control.solvers",
    "LoopSettings": "rcmplan.control.phase",
    "Phase": "rcmplan.control.phase",
    "PinvSolver": "rcmplan.control.solvers",
    "QpSolver": "rcmplan.control.qp",
    "RunLog": "rcmplan.control.log",
    "TipSolver": "rcmplan.control.solvers",
    "Tolerance": "rcmplan.control.solvers",
    "rcm_target": "rcmplan.control.targets",
    "solve_pose": "rcmplan.control.targets",
    "split_steps": "rcmplan.control.phase",
    "NeedleAngles": "rcmplan.control.tasks",
    "NeedleBase": "rcmplan.control.tasks",
    "Posture": "rcmplan.control.tasks",
    "RcmPoint": "rcmplan.control.tasks",
    "TipPosition": "rcmplan.control.tasks",
    "Configuration": "rcmplan.control.configuration",
    "Objective": "rcmplan.control.objective",
    "QpLimits": "rcmplan.control.qp_limits",
    "TissueDepthLimit": "rcmplan.control.limits",
    "ActuatorLimit": "rcmplan.control.limits",
    "Constraint": "rcmplan.control.limits",
    "RcmLimit": "rcmplan.control.limits",
    "RetinaBarrier": "rcmplan.control.limits",
    "SingularMargin": "rcmplan.control.limits",
    "TipSpeed": "rcmplan.control.limits",
    "WorkspaceBound": "rcmplan.control.limits",
    # plants
    "KinematicPlant": "rcmplan.sim.kinematic",
    "MujocoPlant": "rcmplan.sim.mujoco.plant",
    "make_plant": "rcmplan.sim.registry",
    # eye, procedures, scenarios, runs
    "Eye": "rcmplan.scene.eye",
    "Spiral": "rcmplan.scene.procedures",
    "Steps": "rcmplan.scene.procedures",
    "default_eye": "rcmplan.scene.eye",
    "default_points": "rcmplan.scene.eye",
    "injection": "rcmplan.scene.procedures",
    "spiral": "rcmplan.scene.procedures",
    "load_scenario": "rcmplan.scene.scenario",
    "run_scenario": "rcmplan.job",
    # errors
    "InvalidInputError": "rcmplan.exceptions",
    "RcmplanError": "rcmplan.exceptions",
}

__all__ = [
    "ActuatorLimit",
    "ChainJoint",
    "Configuration",
    "Constraint",
    "Controller",
    "CurvedNeedle",
    "DHChain",
    "DHLink",
    "DlsSolver",
    "Eye",
    "InvalidInputError",
    "Iramis",
    "IramisParameters",
    "JointChain",
    "KinematicPlant",
    "LoopSettings",
    "MujocoPlant",
    "NeedleAngles",
    "NeedleBase",
    "Objective",
    "Pcjm",
    "Phase",
    "PinvSolver",
    "Posture",
    "QpLimits",
    "QpSolver",
    "RcmLimit",
    "RcmPoint",
    "RcmplanError",
    "RetinaBarrier",
    "RobotModel",
    "RunLog",
    "SerialArm",
    "SingularMargin",
    "Spiral",
    "Steps",
    "StraightNeedle",
    "TipPosition",
    "TipSolver",
    "TipSpeed",
    "TissueDepthLimit",
    "Tolerance",
    "WorkspaceBound",
    "__version__",
    "default_eye",
    "default_points",
    "injection",
    "load_mjcf",
    "load_robot_file",
    "load_scenario",
    "load_urdf",
    "make_plant",
    "make_robot",
    "needle_arm",
    "rcm_target",
    "run_scenario",
    "solve_pose",
    "spiral",
    "split_steps",
]


__getattr__ = lazy_names("rcmplan", _EXPORTS, globals())


def __dir__() -> list[str]:
    return __all__


if TYPE_CHECKING:  # the same names, for type checkers and editors
    from rcmplan.control.configuration import Configuration
    from rcmplan.control.limits import (
        ActuatorLimit,
        Constraint,
        RcmLimit,
        RetinaBarrier,
        SingularMargin,
        TipSpeed,
        TissueDepthLimit,
        WorkspaceBound,
    )
    from rcmplan.control.log import RunLog
    from rcmplan.control.objective import Objective
    from rcmplan.control.phase import LoopSettings, Phase, split_steps
    from rcmplan.control.qp import QpSolver
    from rcmplan.control.qp_limits import QpLimits
    from rcmplan.control.solvers import DlsSolver, PinvSolver, TipSolver, Tolerance
    from rcmplan.control.targets import rcm_target, solve_pose
    from rcmplan.control.tasks import NeedleAngles, NeedleBase, Posture, RcmPoint, TipPosition
    from rcmplan.controller import Controller
    from rcmplan.exceptions import InvalidInputError, RcmplanError
    from rcmplan.job import run_scenario
    from rcmplan.robot.arms import needle_arm
    from rcmplan.robot.chain import ChainJoint, JointChain
    from rcmplan.robot.curved_needle import CurvedNeedle
    from rcmplan.robot.dh import DHChain, DHLink
    from rcmplan.robot.iramis import Iramis, IramisParameters
    from rcmplan.robot.mjcf import load_mjcf
    from rcmplan.robot.model import RobotModel, SerialArm
    from rcmplan.robot.needle import StraightNeedle
    from rcmplan.robot.pcjm import Pcjm
    from rcmplan.robot.registry import make_robot
    from rcmplan.robot.robot_file import load_robot_file
    from rcmplan.robot.urdf import load_urdf
    from rcmplan.scene.eye import Eye, default_eye, default_points
    from rcmplan.scene.procedures import Spiral, Steps, injection, spiral
    from rcmplan.scene.scenario import load_scenario
    from rcmplan.sim.kinematic import KinematicPlant
    from rcmplan.sim.mujoco.plant import MujocoPlant
    from rcmplan.sim.registry import make_plant
