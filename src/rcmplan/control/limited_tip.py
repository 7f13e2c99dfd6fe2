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

The two factors are kernels (`step_fraction`, `tip_fraction`) that this solver and the compiled
loops' limited steps (iRAM!S `loop.limit_step`, arms `arm_loop.limit_step`) call alike.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from rcmplan._jit import njit
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
        """The tip step scaled by `step_fraction` (and `tip_fraction` with a tip speed); lambda
        unchanged."""
        dq, _ = self._tip.step(robot, q, lam, target, error)
        f = 1.0
        if self.tip_speed is not None:
            J = np.ascontiguousarray(TIP_POSITION.jacobian(robot, q, lam))
            f = tip_fraction(J, 0, dq, dq.shape[0], self.tip_speed * self.dt)
        return limited_step(robot, q, dq, self.dt, self.travel_margin, f), 0.0


def limited_step(
    robot: RobotModel,
    q: FloatArray,
    dq: FloatArray,
    dt: float,
    margin: float,
    at_most: float = 1.0,
) -> FloatArray:
    """The joint step dq (of the active joints) shortened along the actuators' motion so that
    each actuator moves at most speed x dt and stays within travel less `margin`
    (`step_fraction`), and by at most the factor `at_most` (in [0, 1]); the joints recovered
    exactly through the actuator map."""
    active = list(robot.active)
    s = robot.actuators_from_joints(q)
    q_full = q.copy()
    q_full[active] += dq
    ds = robot.actuators_from_joints(q_full) - s
    f = step_fraction(s, ds, robot.speed * dt, robot.lower, robot.upper, margin, at_most)
    return np.asarray((robot.joints_from_actuators(s + f * ds) - q)[active], dtype=float)


@njit(cache=True, borrows=True)
def step_fraction(s: FloatArray, ds: FloatArray, limit: FloatArray, lower: FloatArray,
                  upper: FloatArray, margin: float, f: float) -> float:  # fmt: skip
    """The largest factor in [0, f] (f <= 1) scaling the actuators' increment ds (n,) from s
    (n,) so that each moves at most limit_i and stays inside [lower_i + margin, upper_i -
    margin]; an actuator already outside that band may only move back towards it."""
    for i in range(s.shape[0]):
        if abs(ds[i]) > 0.0:
            f = min(f, limit[i] / abs(ds[i]))
    for i in range(s.shape[0]):
        lo, hi = lower[i] + margin, upper[i] - margin
        if ds[i] > 0.0 and s[i] + f * ds[i] > hi:
            f = min(f, max(0.0, (hi - s[i]) / ds[i]))
        elif ds[i] < 0.0 and s[i] + f * ds[i] < lo:
            f = min(f, max(0.0, (lo - s[i]) / ds[i]))
    return f


@njit(cache=True, borrows=True)
def tip_fraction(J: FloatArray, r: int, d: FloatArray, m: int, bound: float) -> float:
    """The largest factor in [0, 1] keeping each component of the tip's first-order step
    J[r:r + 3, :m] d within bound [m] (tip speed x dt); 1 for bound <= 0 or no tip motion."""
    if not bound > 0.0:
        return 1.0
    tip = 0.0
    for i in range(3):
        acc = 0.0
        for j in range(m):
            acc += J[r + i, j] * d[j]
        tip = max(tip, abs(acc))
    return min(1.0, bound / tip) if tip > 0.0 else 1.0
