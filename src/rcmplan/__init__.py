"""rcmplan: RCM-constrained needle motion planning for ophthalmic surgical robots."""

from rcmplan.exceptions import RcmplanError
from rcmplan.robot import DHChain, DHLink, Iramis, IramisParameters, Pcjm

__version__ = "0.1.0"

__all__ = ["DHChain", "DHLink", "Iramis", "IramisParameters", "Pcjm", "RcmplanError", "__version__"]
