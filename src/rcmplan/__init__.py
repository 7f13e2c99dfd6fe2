"""rcmplan: RCM-constrained needle motion planning for surgical robots (iRAM!S and serial arms)."""

from rcmplan.exceptions import RcmplanError
from rcmplan.robot import (
    ChainJoint,
    DHChain,
    DHLink,
    Iramis,
    IramisParameters,
    JointChain,
    Pcjm,
    RobotModel,
    SerialArm,
    StraightNeedle,
)

__version__ = "0.1.0"

import rcmplan.compiled  # noqa: F401  (registers the compiled runner as the default)

__all__ = [
    "ChainJoint",
    "DHChain",
    "DHLink",
    "Iramis",
    "IramisParameters",
    "JointChain",
    "Pcjm",
    "RcmplanError",
    "RobotModel",
    "SerialArm",
    "StraightNeedle",
    "__version__",
]
