"""The QP's step one period at a time, compiled: for loops that take ONE step per control
period towards a target that moves (teleoperation), where the controller's phase loop
(`qp_phase`) does not apply.

`period_step` returns a function (q, lam, target) -> dq that equals `QpSolver.step` to rounding
(the same QP assembled and solved in compiled code, its RCM box held on the true kinematics
as the loop holds it: `loop.period_step` on iRAM!S, `arm_qp.ArmQpStep` on a serial arm; the
joints recovered exactly from the actuator step as the reference does), or None where the
compiled step does not apply. A solve that fails in compiled code is
repeated on the reference path, which raises its own QPError (or, at the edge of DAQP's
tolerances, returns its step).
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.arm_qp import ArmQpStep, arm_qp_applies
from rcmplan.compiled.packed import pack
from rcmplan.compiled.qp_params import pack_extras, qp_params
from rcmplan.compiled.records import FAIL_WIDTH, robot_params
from rcmplan.compiled.runner import kernel_params
from rcmplan.control.augmented import extended_task
from rcmplan.control.qp import QpSolver
from rcmplan.exceptions import RcmplanError
from rcmplan.robot.chain_kinematics import IntArray
from rcmplan.robot.model import RobotModel

StepFunction = Callable[[FloatArray, float, FloatArray], FloatArray]


def period_step(solver: QpSolver) -> StepFunction | None:
    """A compiled `solver.step`, or None: not a plain QpSolver with DAQP and a straight needle,
    a robot or eye or limit the kernels do not reproduce
    (`qp_params`: up to `MAX_EXTRA` workspace boxes and tissue-depth limits as extra limits),
    DAQP's C binding unusable. With a servo (the dynamic MuJoCo plants) the step is
    planned from the plant's last command as the reference plans it (`QpSolver.planned_joints`,
    the cost synchronised: `qp_kernels.iteration_error`)."""
    if type(solver) is not QpSolver or solver.backend != "daqp" or solver.curved:
        return None
    robot = solver.robot
    if arm_qp_applies(solver):  # with a servo too (`arm_qp_kernels.solve_arm_step`)
        return _arm_period_step(solver)
    loop = fast_cache.qp_loop() if kernel_params(robot) is not None else None
    params = None if loop is None else qp_params(robot, solver)
    if loop is None or params is None:
        return None
    F, Z, views = period_buffers(robot, solver, params)
    Q, cmd, d = views[5], views[-1], views[4]  # views of F (`period_buffers`): written below
    servo, period_packed, d5 = solver.servo, loop.period_packed, d[:5]

    def step(q: FloatArray, lam: float, target: FloatArray) -> FloatArray:
        q = np.ascontiguousarray(q, dtype=np.float64)
        target = np.ascontiguousarray(target, dtype=np.float64)
        if servo is not None:
            cmd[:] = servo.command
        if solver.extra_limits:  # a moving limit's parameters as they are now
            pack_extras(solver, Q)
        if period_packed(F, Z, q, float(lam), target) != 1:
            e = solver.task_error(robot, q, lam, target)
            return solver.step(robot, q, lam, target, e)[0]
        return d5.copy()

    # Load the compiled code now (numba's cache, the first call's dispatch), and the reference
    # step a failed solve falls back to (its first call imports and builds what it needs:
    # about 45 ms), so a loop paced at 1 kHz pays for neither in a period.
    home = robot.home
    target = extended_task(robot, home, 1.0)
    with contextlib.suppress(RcmplanError):
        step(home, 1.0, target)
        solver.step(robot, home, 1.0, target, solver.task_error(robot, home, 1.0, target))
    return step


def period_buffers(
    robot: RobotModel, solver: QpSolver, params: tuple
) -> tuple[FloatArray, IntArray, list[np.ndarray]]:
    """`packed.pack` of the arrays of `loop.period_step` in `loop.period_arrays`' order: P, K,
    fail, w, d, then qpa (`qp_kernels.loop_qp`: Q, contacts, the solve's buffers, the servo's
    slider resolution (none without a servo) and its last command)."""
    P, K = robot_params(robot), np.ascontiguousarray(solver.K, dtype=np.float64)
    res = getattr(solver.servo, "actuator_resolution", None)  # `planned_joints` rounds to it
    res = np.zeros(6) if res is None else np.array(res, dtype=np.float64)
    args = () if solver.servo is None else (res, np.zeros(6))
    Q, contacts, bufs, res, cmd = fast_cache.qp_kernels().loop_qp(params, *args)
    fail, w, d = np.zeros(FAIL_WIDTH), np.zeros(6), np.zeros(6)
    return pack((P, K, fail, w, d, Q, contacts, *bufs, res, cmd))


def _arm_period_step(solver: QpSolver) -> StepFunction:
    """`period_step` on a serial arm (`arm_qp.ArmQpStep`), its compiled code loaded now."""
    robot, fast = solver.robot, ArmQpStep(solver)
    home = robot.home
    target = extended_task(robot, home, 1.0)
    with contextlib.suppress(RcmplanError):  # the reference step a failed solve falls back to
        fast.step(robot, home, 1.0, target, fast.e)  # the solve and the RCM box's hold
        solver.step(robot, home, 1.0, target, solver.task_error(robot, home, 1.0, target))

    def step(q: FloatArray, lam: float, target: FloatArray) -> FloatArray:
        return fast.step(robot, q, lam, target, fast.e)[0]

    return step
