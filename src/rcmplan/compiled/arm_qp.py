"""The QP controller's error and step on a serial arm, compiled, one call per step from Python
(`arm_qp_kernels.solve_arm_step`): the step function of code that drives the solver period by
period (`qp_period.period_step`: teleoperation, the subretinal episode). A `Controller` runs the
same solve inside the arm loop (`arm_loop.arm_iterate`, method QP).

Applies to a `QpSolver` itself (exact type: a subclass may change its step) with the DAQP back
end and a straight needle (with a servo planned from its last command, as the solver plans),
on a `SerialArm` itself whose kinematics the chain kernels reproduce (`arm.arm_arrays`), with
an eye whose retina is the kernels' sphere, extra limits the kernels hold and no extra cost
terms (`qp_params`), where DAQP's C function can be called from compiled code
(`cache.daqp_callable`). `ArmQpStep` then gives the solver's task error, tolerance and step to
rounding, the QP assembled with the same row kernels. A solve that
DAQP does not finish optimally is repeated by the solver itself, which raises its QPError (or
returns its step at the edge of DAQP's tolerances).
"""

from __future__ import annotations

import math
import struct

import numpy as np

from rcmplan._validate import FloatArray, scalar, vector
from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.arm import arm_arrays
from rcmplan.compiled.curved import curved_arrays
from rcmplan.compiled.packed import pack
from rcmplan.compiled.qp_params import pack_extras, qp_params
from rcmplan.compiled.qp_rows import buffers
from rcmplan.control.limits.base import SCALE
from rcmplan.control.qp import QpSolver
from rcmplan.control.qp_problem import QPProblem, StepQP
from rcmplan.control.solvers import SolverKind
from rcmplan.control.targets import checked_target
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.model import RobotModel, SerialArm

_DOUBLE = struct.Struct("d").pack  # lambda's 8 bytes in a state's key


def arm_qp_applies(solver: object) -> bool:
    """True if `ArmQpStep` reproduces this solver (see the module docstring)."""
    if type(solver) is not QpSolver or solver.backend != "daqp" or solver.curved:
        return False
    if type(solver.robot) is not SerialArm:
        return False
    if arm_arrays(solver.robot) is None or not fast_cache.daqp_callable():
        return False
    return qp_params(solver.robot, solver) is not None


def curved_qp_applies(solver: object) -> bool:
    """True for a curved needle's QpSolver the arm loop runs (method CURVED_QP): the DAQP back
    end, a `CurvedTipRobot` itself holding the needle on an arm (`curved.curved_arrays`: an
    arm's arrays), the settings the kernels hold (`qp_params`); with a servo the QP is planned
    from its command (`arm_qp_kernels.solve_arm_step` given its work array)."""
    if type(solver) is not QpSolver or solver.backend != "daqp" or not solver.curved:
        return False
    arrays = curved_arrays(solver.robot)
    if arrays is None or arrays.P is not None:
        return False
    return fast_cache.daqp_callable() and qp_params(solver.robot, solver) is not None


def qp_arrays(solver: object, n: int) -> tuple | None:
    """What the arm QP's solve reads (`arm_loop.arm_iterate`'s qpa) for n joints and the m
    active joints of the solver's robot (a curved needle's robot: the roll among them):
    travel (2, m), the settings Q and contacts (`qp_params`, extra limits as they are now), the
    solve's buffers (`qp_rows.buffers`), the active joints (m,), DAQP's exit flag (1,) and with
    a servo its array (`arm_qp_kernels.solve_arm_step`'s: the command, filled before each
    solve by `servo_command`, the resolution, scratch), else (0,). None for another solver."""
    curved = isinstance(solver, QpSolver) and curved_qp_applies(solver)
    if not (isinstance(solver, QpSolver) and (curved or arm_qp_applies(solver))):
        return None
    servo = np.zeros(0)
    robot, active = solver.robot, list(solver.robot.active)
    m = len(active)
    travel = np.ascontiguousarray([robot.lower[active], robot.upper[active]])
    Q, contacts = qp_params(robot, solver)  # type: ignore[misc]
    if solver.servo is not None:
        servo = np.zeros(3 * n + (14 if curved else 12))  # the plan, X's error there and at q
        res = getattr(solver.servo, "actuator_resolution", None)
        servo[n : 2 * n] = 0.0 if res is None else res
    bufs = buffers(m + 1, 7) if curved else buffers(m + 1)
    return travel, Q, contacts, bufs, np.empty(m), np.zeros(1, dtype=np.int64), servo


def servo_command(solver: object, qpa: tuple | None) -> None:
    """Copy the servo's last command into qpa's servo array (a QP with a servo)."""
    servo = np.zeros(0) if qpa is None else qpa[-1]
    if servo.shape[0] > 0:
        command = np.asarray(solver.servo.command, dtype=np.float64)  # type: ignore[attr-defined]
        servo[: command.shape[0]] = command


def step_buffers(solver: QpSolver, K: FloatArray) -> tuple:
    """What one compiled step on the solver's arm reads and writes, in `arm_qp_kernels.
    step_arrays`' order: the arm (A, ix), its work array W, travel, Q, contacts (`qp_arrays`),
    the gains K (6,), the active joints s (m,), the error e (6,), the step d (m + 1,), the
    servo array and the QP's buffers (`qp_rows.buffers`)."""
    A, ix = arm_arrays(solver.robot)  # type: ignore[misc]
    n, m = int(ix[0]), int(ix[1])
    arrays = qp_arrays(solver, n)
    if arrays is None:
        raise InvalidInputError("solver", solver, "a QpSolver the compiled arm step runs "
                                "(`arm_qp_applies`)")  # fmt: skip
    travel, Q, contacts, qp, _, _, servo = arrays
    kin = fast_cache.chain_kernels()
    W = kin.blank_work(kin.work_shape(n, m), n)  # no frames yet (`holds_frames`)
    return (A, ix, W, travel, Q, contacts, K, np.zeros(m), np.zeros(6), np.zeros(m + 1), servo,
            *qp)  # fmt: skip


class ArmQpStep:
    """A QpSolver's `error` and `step` on its serial arm, each state's QP assembled and solved
    in compiled code once (`error` and `step` at the same state share the solve). The arrays
    of a step live in two buffers (`packed`), made once: a call from Python passes the kernel
    those two, the joints, lambda and the target.

    Args:
        solver: The QP solver reproduced (InvalidInputError unless `arm_qp_applies`).
    """

    def __init__(self, solver: QpSolver) -> None:
        if not arm_qp_applies(solver):
            raise InvalidInputError("solver", solver, "a QpSolver on a SerialArm that the "
                                    "compiled arm QP reproduces (`arm_qp_applies`)")  # fmt: skip
        self.solver = solver
        self.name: str = solver.name
        self.kind: SolverKind = solver.kind
        self._k = fast_cache.arm_qp_kernels()
        K = np.array(solver.K, dtype=np.float64)
        self.F, self.Z, views = pack(step_buffers(solver, K))  # `step_arrays`' order
        (self.A, self.ix, self.W, self.travel, self.Q, self.contacts, self.K, self.s, self.e,
         self.d, self.servo), self.qp = views[:11], tuple(views[11:])  # fmt: skip
        self.n, self.m = int(self.ix[0]), int(self.ix[1])
        self.qpa = (self.travel, self.Q, self.contacts, self.qp, self.s, None, self.servo)
        self._key, self._checked, self._flag = b"", b"", 0
        self._loop = fast_cache.arm_loop()  # the RCM box held on the true kinematics
        self._fail, self._flags = np.empty(2 * self.n), np.zeros(1, dtype=np.int64)

    def tolerance(self) -> FloatArray:
        """The solver's tolerance per X_ext component."""
        return self.solver.tolerance()

    def check_targets(self, targets: FloatArray) -> None:
        """The solver's own target check (`QpSolver.check_targets`)."""
        self.solver.check_targets(targets)

    def solve(self, q: FloatArray, lam: float, target: FloatArray) -> int:
        """Assemble and solve the QP at (q, lambda) for the X_ext target (float64 arrays (n,)
        and (6,)), once per state; DAQP's exit flag (1: optimal, then `e` and `d` hold the
        error and the step)."""
        return self._solve(self._state(q, lam, target), q, lam, target)

    def _state(self, q: FloatArray, lam: float, target: FloatArray) -> bytes:
        """The state's key: the bytes of q, lambda, the target and with a servo its last
        command, copied now into the servo array (the plan is that command)."""
        key = q.tobytes() + _DOUBLE(lam) + target.tobytes()
        if self.servo.shape[0] > 0:
            servo_command(self.solver, self.qpa)
            key += self.servo[: self.n].tobytes()  # the command (the rest is the solve's scratch)
        return key

    def _solve(self, key: bytes, q: FloatArray, lam: float, target: FloatArray) -> int:
        """`solve` at the state of this key (`_state`): one compiled call unless it is the
        state solved last."""
        if key != self._key:
            if self.solver.extra_limits:  # a moving limit's parameters as they are now
                pack_extras(self.solver, self.Q)
            self._flag = self._k.solve_packed(self.F, self.Z, q, float(lam), target)
            self._key = key
        return int(self._flag)

    def problem(self, q: FloatArray, lam: float, target: FloatArray) -> StepQP:
        """The QP at (q, lambda) for the X_ext target as `qp_problem.build_step` returns it
        (contact left False; `sliders` the joints); `e` then holds the X_ext error."""
        q = np.ascontiguousarray(vector("q", q, self.n))
        target = np.ascontiguousarray(vector("target", target, 6))
        if self.solver.extra_limits:
            pack_extras(self.solver, self.Q)
        rows = self._k.build_arm_step(self.A, self.ix, self.W, self.travel, self.Q,
                                      self.contacts, self.K, q, float(lam), target, self.s,
                                      self.e, self.qp)  # fmt: skip
        self._key = b""  # the buffers no longer hold the last solve
        return assembled_step(self.qp, rows, q)

    def error(self, robot: RobotModel, q: FloatArray, lam: float, target: FloatArray) -> FloatArray:
        """`QpSolver.error`: J x* / K, or the plain X_ext error at an actuator's full speed."""
        target, lam = self.solver.check_target(target), _finite("lam", lam)
        q = checked_target(q, self.n, "q")
        key = self._checked = self._state(q, lam, target)
        if self._solve(key, q, lam, target) != 1:
            return self.solver.error(robot, q, lam, target)
        return self.e.copy()

    def step(
        self, robot: RobotModel, q: FloatArray, lam: float, target: FloatArray, error: FloatArray
    ) -> tuple[FloatArray, float]:
        """`QpSolver.step`: the active joints' increments and d lambda. The numbers of q and
        the target are checked unless they are those `error` or `step` checked last."""
        target, lam = checked_target(target, 6, finite=False), _finite("lam", lam)
        q = checked_target(q, self.n, "q", finite=False)
        key = self._state(q, lam, target)
        if key != self._checked:  # a state not checked yet: its numbers must be finite
            checked_target(target, 6)
            checked_target(q, self.n, "q")
            self._checked = key
        if self._solve(key, q, lam, target) != 1:
            return self.solver.step(robot, q, lam, target, error)
        if self._loop.held_packed(self.F, self.Z, q, float(lam), target, self._fail, self._flags):
            self._key = b""  # the buffers hold a narrower box's solve, or a shortened step
        return self.d[: self.m].copy(), float(self.d[self.m])


def _finite(name: str, value: float) -> float:
    """value as a finite float, or InvalidInputError naming it (`scalar`)."""
    if value.__class__ is float and math.isfinite(value):
        return value
    return scalar(name, value)


def arm_qp_step(solver: QpSolver) -> ArmQpStep | None:
    """The compiled stand-in for `solver` on its arm, or None where it does not apply."""
    return ArmQpStep(solver) if arm_qp_applies(solver) else None


def assembled_step(qp: tuple, rows: int, s: FloatArray) -> StepQP:
    """The QP a compiled assembly left in its buffers `qp` (`qp_rows.buffers`, `rows` rows of
    A) as `qp_problem.build_step` returns it, at actuators s (contact left False)."""
    from rcmplan.compiled.daqp_c import EQUALITY

    H, f, A, upper, lower, sense, task = (a.copy() for a in qp[:7])
    nb = H.shape[0]
    eq = sense[nb : nb + rows] == EQUALITY
    G, h = A[:rows][~eq], upper[nb : nb + rows][~eq]
    problem = QPProblem(H, f, G, h, A[:rows][eq], upper[nb : nb + rows][eq], lower[:nb],
                        upper[:nb])  # fmt: skip
    return StepQP(problem, task * SCALE, s.copy(), False)
