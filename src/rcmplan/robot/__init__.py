"""Robot models: generic standard-DH chains, PCJMs, the needle and the iRAM!S robot."""

from rcmplan.robot.dh import DHChain, DHLink
from rcmplan.robot.iramis import Iramis, IramisParameters
from rcmplan.robot.pcjm import Pcjm

__all__ = ["DHChain", "DHLink", "Iramis", "IramisParameters", "Pcjm"]
