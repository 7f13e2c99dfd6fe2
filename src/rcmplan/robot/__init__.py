"""Robot models: the model protocol, serial chains (DH, URDF, MJCF), needles, iRAM!S."""

from rcmplan.robot.chain import ChainJoint, JointChain
from rcmplan.robot.dh import DHChain, DHLink
from rcmplan.robot.iramis import Iramis, IramisParameters
from rcmplan.robot.model import RobotModel, SerialArm
from rcmplan.robot.needle import StraightNeedle
from rcmplan.robot.pcjm import Pcjm

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
