"""Free-space tip steps that hold the actuators' travel and speed (approach and withdraw).

Outside the eye no RCM is held, so the QP's step reduces to the tip pseudoinverse; what the QP
must still hold there is the actuators' travel (less its margin) and speed over one control
period. `LimitedTipSolver` takes the tip pseudoinverse (or DLS) step, maps it to actuator
increments ds through the actuator map, and scales ds by the largest factor f in (0, 1] that
keeps every active actuator within its speed bound |ds_i| <= v_i dt and inside its travel less
the margin. The step is scaled in actuator space and mapped back exactly
(`joints_from_actuators`), so the bounds hold exactly, not only to first order; scaling the
whole increment keeps its direction, so the tip still heads for its target (the first-order
tip motion is f times the unscaled one). An actuator already outside the margin band (a home
pose in it) may move back towards the band, never further out. With a tip speed bound, f also
keeps each component of the tip's step (to first order, J_tip dq) within tip_speed x dt.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from rcmplan._validate import FloatArray, scalar
from rcmplan.control.solvers import SolverKind, TipSolver, Tolerance
from rcmplan.control.tasks import TIP_POSITION
from rcmplan.robot.model import RobotModel


@dataclass
class LimitedTipSolver:
    """The tip step of `TipSolver`, scaled to hold actuator speed and travel.

    Attributes:
        dt: Control period in [s]; the speed bound is robot.speed * dt per step.
        travel_margin: Distance kept from each actuator's travel ends, in its unit.
        damping: 0 for the pseudoinverse step, D > 0 for damped least squares.
        tol: Loop tolerance (positions only).
        tip_speed: Largest tip speed per base axis in [m/s], or None.
    """

    dt: float = 1e-3
    travel_margin: float = 0.5e-3
    damping: float = 0.0
    tol: Tolerance = field(default_factory=Tolerance)
    tip_speed: float | None = None
    kind: ClassVar[SolverKind] = "free"

    def __post_init__(self) -> None:
        scalar("dt", self.dt, 0.0, 1.0, low_open=True)
        scalar("travel_margin", self.travel_margin, 0.0, 0.1)
        if self.tip_speed is not None:
            scalar("tip_speed", self.tip_speed, 0.0, 1.0, low_open=True)
        self._tip = TipSolver(self.damping, self.tol)

    @property
    def name(self) -> str:
        """ "tip-limited"."""
        return "tip-limited"

    def error(self, robot: RobotModel, q: FloatArray, lam: float, target: FloatArray) -> FloatArray:
        """Tip target minus tip, in [m]."""
        return self._tip.error(robot, q, lam, target)

    def tolerance(self) -> FloatArray:
        """Position tolerance on x, y, z."""
        return self._tip.tolerance()

    def step(
        self, robot: RobotModel, q: FloatArray, lam: float, target: FloatArray, error: FloatArray
    ) -> tuple[FloatArray, float]:
        """The tip step scaled by `scale_factor`; lambda unchanged."""
        dq, _ = self._tip.step(robot, q, lam, target, error)
        bound = None
        if self.tip_speed is not None:
            tip_step = float(np.max(np.abs(TIP_POSITION.jacobian(robot, q, lam)[:, :-1] @ dq)))
            if tip_step > 0.0:
                bound = self.tip_speed * self.dt / tip_step
        return limited_step(robot, q, dq, self.dt, self.travel_margin, bound), 0.0


def limited_step(
    robot: RobotModel,
    q: FloatArray,
    dq: FloatArray,
    dt: float,
    margin: float,
    at_most: float | None = None,
) -> FloatArray:
    """The joint step dq (of the active joints) shortened along the actuators' motion so that
    each actuator moves at most speed x dt and stays within travel less `margin`
    (`scale_factor`), and by at most the factor `at_most` (None: 1); the joints recovered
    exactly through the actuator map."""
    active = list(robot.active)
    s = robot.actuators_from_joints(q)
    q_full = q.copy()
    q_full[active] += dq
    ds = robot.actuators_from_joints(q_full) - s
    f = scale_factor(robot, s, ds, dt, margin)
    if at_most is not None:
        f = min(f, at_most)
    return np.asarray((robot.joints_from_actuators(s + f * ds) - q)[active], dtype=float)


def scale_factor(
    robot: RobotModel, s: FloatArray, ds: FloatArray, dt: float, margin: float
) -> float:
    """The largest f in [0, 1] with |f ds_i| <= speed_i dt and s + f ds inside the travel less
    the margin for every actuator (an actuator outside the band may only move back)."""
    f = 1.0
    limit = robot.speed * dt
    moving = np.abs(ds) > 0.0
    if np.any(moving):
        f = min(f, float(np.min(limit[moving] / np.abs(ds[moving]))))
    lo, hi = robot.lower + margin, robot.upper - margin
    for i in np.flatnonzero(moving):
        if ds[i] > 0.0 and s[i] + f * ds[i] > hi[i]:
            f = min(f, max(0.0, (hi[i] - s[i]) / ds[i]))
        elif ds[i] < 0.0 and s[i] + f * ds[i] < lo[i]:
            f = min(f, max(0.0, (lo[i] - s[i]) / ds[i]))
    return f
