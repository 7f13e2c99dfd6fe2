"""Settings shared by the control methods (gains, damping, tolerance, method options)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from rcmplan.control.solvers import Tolerance


@dataclass(frozen=True)
class MethodSettings:
    """Settings shared by the methods; each method reads the ones it uses.

    Attributes:
        K: Diagonal gains of the pseudoinverse methods, each in (0, 2).
        damping: Damping D of DLS, in units of the stacked task [m]; the QP reads it as its
            dimensionless regularisation per unit of slider motion.
        tolerance: Loop tolerance (m and rad apart).
        extra: Method-specific keyword arguments (for example the QP's limits).
    """

    K: tuple[float, ...] = (1.0,) * 6
    damping: float = 1e-4
    tolerance: Tolerance = field(default_factory=Tolerance)
    extra: dict[str, Any] = field(default_factory=dict)
