"""Parallel Coupled Joint Mechanism: two parallel sliders <-> a prismatic and a revolute joint.

Thesis eqs. 2.1-2.4. Two sliders at spacing d move by L1 and L2; the coupler stage translates
by q_lin = (L1 + L2) / 2 (eq. 2.1) and turns by q_rot = arctan((L2 - L1) / d) (eq. 2.2).

Erratum: eq. 2.3 prints L1 = d tan(q_rot) / 2 + q_lin, which with eq. 2.4 gives
L2 - L1 = -d tan(q_rot) and so contradicts eq. 2.2. rcmplan keeps eqs. 2.1 and 2.2 as the
definition and inverts them exactly: L1 = q_lin - d tan(q_rot) / 2, L2 = q_lin + d tan(q_rot) / 2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rcmplan._validate import FloatArray, scalar
from rcmplan.exceptions import InvalidInputError, PcjmAngleError
from rcmplan.robot.iramis_kernels import pcjm_joints, pcjm_sliders


@dataclass(frozen=True)
class Pcjm:
    """One PCJM.

    Attributes:
        spacing: Distance d between the two sliders in [m], positive.
    """

    spacing: float

    def __post_init__(self) -> None:
        scalar("spacing", self.spacing, 0.0, np.inf, low_open=True)

    def joints(self, L1: float, L2: float) -> tuple[float, float]:
        """(q_lin [m], q_rot [rad]) from slider positions (L1, L2) in [m] (eqs. 2.1, 2.2).

        Accepts any finite pair: every slider difference has an angle in (-pi/2, pi/2).
        """
        return pcjm_joints(self.spacing, _finite("L1", L1), _finite("L2", L2))

    def sliders(self, q_lin: float, q_rot: float) -> tuple[float, float]:
        """(L1, L2) in [m] from (q_lin [m], q_rot [rad]); |q_rot| must be below pi/2
        (PcjmAngleError)."""
        q_lin, q_rot = _finite("q_lin", q_lin), _finite("q_rot", q_rot)
        if abs(q_rot) >= 0.5 * math.pi:
            raise PcjmAngleError(
                "(q_lin, q_rot)", (q_lin, q_rot), "finite values with |q_rot| < pi/2 rad"
            )
        return pcjm_sliders(self.spacing, q_lin, q_rot)

    def joints_jacobian(self, L1: float, L2: float) -> FloatArray:
        """d(q_lin, q_rot) / d(L1, L2), a (2, 2) array."""
        d = float(self.spacing)  # Python floats: u * u goes to inf (g to its limit 0) silently
        u = float(scalar("L2", L2) - scalar("L1", L1)) / d
        g = 1.0 / (d * (1.0 + u * u))
        return np.array([[0.5, 0.5], [-g, g]])

    def sliders_jacobian(self, q_rot: float) -> FloatArray:
        """d(L1, L2) / d(q_lin, q_rot), a (2, 2) array; the inverse of joints_jacobian.
        |q_rot| must be below pi/2 (PcjmAngleError)."""
        q_rot = _finite("q_rot", q_rot)
        if abs(q_rot) >= 0.5 * math.pi:
            raise PcjmAngleError("q_rot", q_rot, "|q_rot| < pi/2 rad")
        h = 0.5 * self.spacing / math.cos(q_rot) ** 2
        return np.array([[1.0, -h], [1.0, h]])


def _finite(name: str, value: float) -> float:
    """value as a finite float, else PcjmAngleError (a slider pair or joint with no partner)."""
    try:
        return scalar(name, value)
    except InvalidInputError as exc:
        raise PcjmAngleError(name, value, f"a finite number in m or rad ({exc.valid})") from exc
