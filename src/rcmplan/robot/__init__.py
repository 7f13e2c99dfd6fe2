"""Robot models: the model protocol, serial chains (DH, URDF, MJCF), needles, iRAM!S.

Names load on first use, so a module that needs only the robots' names
(`rcmplan.robot.names`, read by the command line as it starts) does not import the models'
numerical kernels (numba).
"""

from __future__ import annotations

from rcmplan._lazy import lazy_names

TYPE_CHECKING = False  # typing.TYPE_CHECKING, not imported: see rcmplan/__init__.py

EXPORTS: dict[str, str] = {  # name -> the module that defines it (`rcmplan` lists them too)
    "ChainJoint": "rcmplan.robot.chain",
    "DHChain": "rcmplan.robot.dh",
    "DHLink": "rcmplan.robot.dh",
    "Iramis": "rcmplan.robot.iramis",
    "IramisParameters": "rcmplan.robot.iramis",
    "JointChain": "rcmplan.robot.chain",
    "Pcjm": "rcmplan.robot.pcjm",
    "RobotModel": "rcmplan.robot.model",
    "SerialArm": "rcmplan.robot.model",
    "StraightNeedle": "rcmplan.robot.needle",
}

__all__ = [
    "ChainJoint",
    "DHChain",
    "DHLink",
    "Iramis",
    "IramisParameters",
    "JointChain",
    "Pcjm",
    "RobotModel",
    "SerialArm",
    "StraightNeedle",
]


__getattr__ = lazy_names("rcmplan.robot", EXPORTS, globals())


if TYPE_CHECKING:  # the same names, for type checkers and editors
    from rcmplan.robot.chain import ChainJoint, JointChain
    from rcmplan.robot.dh import DHChain, DHLink
    from rcmplan.robot.iramis import Iramis, IramisParameters
    from rcmplan.robot.model import RobotModel, SerialArm
    from rcmplan.robot.needle import StraightNeedle
    from rcmplan.robot.pcjm import Pcjm
