"""The QP controller's step for a serial arm in compiled code: the QP of `qp_problem.build_step`
on any arm the chain kernels reproduce, solved by DAQP's C function, and the step read from its
solution.

The arm's kinematics come from the chain kernels (`robot/chain_kinematics.py`: frames, needle
points and axis, point Jacobians, the exact angle rows, X_ext) and its singular term from
`robot/chain_singular.py` (the measure kappa and its gradient); `qp_rows.assemble` then writes
the QP with the code every robot's compiled step shares. An arm's actuators are its joints, so
T = d(q[active], lambda) / d(s[active], l lambda) is the identity on the active joints and 1 / l
for lambda (`limits.base.variable_map`): variables x = (dq[active], l dlambda) / SCALE.

The arm travels as the chain kernels' (A, ix) with a work array W (`chain_kinematics.
work_shape`, made by `blank_work`: a step computes the frames of its joints unless W already
holds them, `holds_frames`, as after the loop's iteration at the same joints), its active
joints' travel as travel (2, m) [rad or m], the settings as Q
(`qp_params`, the speeds of the active joints last), and the buffers of one solve as
`qp_rows.buffers(m + 1)`. Called from Python once per period (`arm_qp.ArmQpStep`), the step
receives all of them packed in two buffers (`packed`, `solve_packed`).
"""

from __future__ import annotations

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.compiled.packed import ints, mat, vec
from rcmplan.compiled.qp_rows import (
    X,
    assemble,
    buffers,
    lead_error,
    solve_assembled,
    solve_planned,
    views,
)
from rcmplan.control import curved_step
from rcmplan.control.cost import x_c_point_rows, x_ext_jacobian
from rcmplan.control.limits.base import SCALE
from rcmplan.control.resolution import quantised
from rcmplan.robot import curved_arm
from rcmplan.robot import curved_block as ck
from rcmplan.robot.chain_kinematics import (
    IntArray,
    angle_rows,
    frames,
    holds_frames,
    needle_axis,
    needle_point,
    point_jacobian,
    task_at,
)
from rcmplan.robot.chain_singular import singular_terms

__all__ = ["arm_kinematics", "buffers", "build_arm_step", "solve_arm_step", "solve_packed",
           "step_arrays"]  # fmt: skip


@njit(cache=True, borrows=True)
def arm_kinematics(A: FloatArray, ix: IntArray, W: FloatArray, lam: float, J: FloatArray,
                   JT: FloatArray, pts: FloatArray) -> None:  # fmt: skip
    """What the rows read (`limits.base.kinematics`) at the frames in W: J (6, w) the tip's and
    the RCM point's Jacobians over (q[active], lambda); JT = (J_tip T, J_rcm T, the angle rows
    times T); the tip, the RCM point and the needle axis (rows of pts)."""
    n, m = ix[0], ix[1]
    point_jacobian(A, ix, W, 1.0, J, 0)
    J[0, m] = J[1, m] = J[2, m] = 0.0  # the tip does not move with lambda
    point_jacobian(A, ix, W, lam, J, 3)
    per_l = 1.0 / A[5 * n + 12, 0]  # T's lambda entry
    for i in range(6):
        for j in range(m):
            JT[i, j] = J[i, j]
        JT[i, m] = J[i, m] * per_l
    angle_rows(A, ix, W, False, JT, 6)  # no lambda column: T leaves the rows as they are
    pts[0, 0], pts[0, 1], pts[0, 2] = needle_point(A, n, W, 1.0)
    pts[1, 0], pts[1, 1], pts[1, 2] = needle_point(A, n, W, lam)
    pts[2, 0], pts[2, 1], pts[2, 2] = needle_axis(A, n, W)


@njit(cache=True, borrows=True)
def build_arm_step(A: FloatArray, ix: IntArray, W: FloatArray, travel: FloatArray,
                   Q: FloatArray, contacts: FloatArray, K: FloatArray, q: FloatArray, lam: float,
                   target: FloatArray, s: FloatArray, e: FloatArray,
                   qp: tuple) -> int:  # fmt: skip
    """The QP of one step at joints q (n,), lambda (`qp_problem.build_step`) into the buffers;
    also the active actuators s (m,) and the X_ext error e (6,). Returns the number of rows of
    A (`qp_rows.assemble`)."""
    n, m = ix[0], ix[1]
    J = qp[8]
    JT, pts, _, grads = qp[15:19]
    if not holds_frames(ix, q, W):  # the loop's iteration left those of q
        frames(A, ix, q, W)
    for j in range(m):
        s[j] = q[ix[2 + n + j]]
    task_at(A, n, W, lam, e)
    for i in range(6):
        e[i] = target[i] - e[i]
    arm_kinematics(A, ix, W, lam, J, JT, pts)
    x_ext_jacobian(JT[:3], JT[6:8], JT[3:6], qp[6])
    values = qp[9][:1]
    values[0] = singular_terms(A, ix, W, grads[0])  # SerialArm.singular_terms, over active
    grads[0, m] = 0.0  # kappa does not depend on lambda
    return assemble(Q, contacts, K, lam, target, e, s, travel[0], travel[1], A[5 * n + 12, 0],
                    values, qp)  # fmt: skip


@njit(cache=True, borrows=True)
def planned_joints(servo: FloatArray, n: int) -> None:
    """`QpSolver.planned_joints`: the servo's last command servo[:n] rounded to its resolution
    servo[n:2n] (0: none; `control.resolution.quantised`), into servo[2n:3n]."""
    quantised(servo[:n], servo[n : 2 * n], servo[2 * n : 3 * n])


@njit(cache=True, borrows=True)
def build_curved_arm_step(A: FloatArray, ix: IntArray, W: FloatArray, travel: FloatArray,
                          Q: FloatArray, contacts: FloatArray, K: FloatArray, q: FloatArray,
                          lam: float, target: FloatArray, s: FloatArray, e: FloatArray,
                          qp: tuple) -> int:  # fmt: skip
    """`build_arm_step` for a curved needle on the arm (A, ix: `curved_arm.pack`'s arrays, W
    its work array): variables the curved needle's m_c active joints and l dlambda, the cost
    on X_c's rows J_c T (7, m_c + 1) (T: 1 / l for lambda), the tip the arc's end, the arm's
    singular measure over its straight active joints (0 for a joint only the curved needle
    moves, as `SerialArm.singular_terms`); e (7,) the X_c error at q. Returns the number of
    rows (`qp_rows.assemble`)."""
    n, m = ix[0], ix[1]
    first, mc = curved_arm.active_span(ix)
    c = curved_arm.block_row(n)
    task_, JT, pts, grads = qp[6], qp[15], qp[16], qp[18]
    if not holds_frames(ix, q, W):  # the loop's iteration left those of q
        frames(A, ix, q, W)
    for j in range(mc):
        s[j] = q[ix[first + j]]
    curved_arm.task(A, n, W, lam, False, e)
    curved_step.error(e, target, e)
    curved_arm.jacobian(A, ix, W, lam, False)
    per_l = 1.0 / A[5 * n + 12, 0]  # T's lambda entry
    for i in range(7):
        for j in range(mc):
            task_[i, j] = W[c + ck.J + i, j]
        task_[i, mc] = W[c + ck.J + i, mc] * per_l
    x_c_point_rows(task_, JT)
    pts[0, 0], pts[0, 1], pts[0, 2] = curved_arm.tip(A, n, W)
    pts[1, 0], pts[1, 1], pts[1, 2] = needle_point(A, n, W, lam)
    pts[2, 0], pts[2, 1], pts[2, 2] = needle_axis(A, n, W)
    values = qp[9][:1]
    values[0] = singular_terms(A, ix, W, grads[1])  # over the straight active joints
    for j in range(mc + 1):
        grads[0, j] = 0.0
        for p in range(m):
            if j < mc and ix[first + j] == ix[2 + n + p]:
                grads[0, j] = grads[1, p]
    return assemble(Q, contacts, K, lam, target, e, s, travel[0], travel[1], A[5 * n + 12, 0],
                    values, qp)  # fmt: skip


@njit(cache=True, borrows=True)
def solve_arm_step(A: FloatArray, ix: IntArray, W: FloatArray, C: FloatArray | None,
                   travel: FloatArray, Q: FloatArray, contacts: FloatArray, K: FloatArray,
                   q: FloatArray, lam: float, target: FloatArray, s: FloatArray, e: FloatArray,
                   d: FloatArray, qp: tuple, servo: FloatArray) -> int:  # fmt: skip
    """One QP step at the measured joints q: build and solve the QP; returns DAQP's exit flag
    (1: optimal). Then e holds `QpSolver.error` (J x* / K, or the plain task error at q when a
    joint moves at full speed) and d `QpSolver.step`: the moving joints' increments and
    d lambda.

    C None: a straight needle (`build_arm_step`: X_ext's error (6,), the active joints'
    step (m + 1,)); else a curved needle's work array, used in W's place
    (`build_curved_arm_step`: X_c's error (7,), the step (m_c + 1,) of its active joints, the
    roll among them). Without a servo (servo (0,)) the QP is built at q and d = (q + x SCALE)
    - q. With one (`QpSolver`'s `servo`, `control/qp.py`'s module docstring; servo = (command
    (n,), resolution (n,), 0: none), then scratch (n + 12,), a curved needle's (n + 14,)) it
    is built at the plant's last command rounded to its resolution, its cost synchronised to
    the speed window (`cost.synchronise`); e adds the command's lead X(q) - X(plan), d runs
    from q to the plan moved by the solution, and the work array holds the frames of q."""
    n = ix[0]
    first, m, k = 2 + n, ix[1], 6  # the moving joints ix[first:first + m]; the task's rows
    if C is not None:
        first, m = curved_arm.active_span(ix)
        k = 7
    plan = q
    if servo.shape[0] > 0:
        planned_joints(servo, n)
        plan = servo[2 * n : 3 * n]
    if C is None:
        rows = build_arm_step(A, ix, W, travel, Q, contacts, K, plan, lam, target, s, e, qp)
    else:
        rows = build_curved_arm_step(A, ix, C, travel, Q, contacts, K, plan, lam, target, s, e,
                                     qp)  # fmt: skip
    if servo.shape[0] == 0:
        flag = solve_assembled(Q, K, rows, e, qp)
    else:
        e_plan, now = servo[3 * n : 3 * n + k], servo[3 * n + k :]
        flag = solve_planned(Q, K, rows, e, e_plan, qp)
        if flag == 1:  # the task's error at the measured joints, and the command's lead
            if C is None:
                if not holds_frames(ix, q, W):  # the plan's are there, unless it is q
                    frames(A, ix, q, W)
                task_at(A, n, W, lam, now)
                for i in range(6):
                    now[i] = target[i] - now[i]
            else:
                if not holds_frames(ix, q, C):
                    frames(A, ix, q, C)
                curved_arm.task(A, n, C, lam, False, now)
                curved_step.error(now, target, now)
            lead_error(Q, qp[X], now[:k], e_plan, e)
    if flag != 1:
        return flag
    x = qp[X]
    for j in range(m):  # `qp.joints_step`: the moving joints moved by x, from the plan
        i = ix[first + j]
        d[j] = (plan[i] + x[j] * SCALE) - q[i]
    d[m] = x[m] * SCALE / A[5 * n + 12, 0]
    return flag


# Inlined into solve_packed: its thirty views cost about 0.7 us there, 1.1-1.4 us as a call.
@njit(cache=True, inline="always")
def step_arrays(F: FloatArray, Z: IntArray) -> tuple:
    """Views of the arrays `packed.pack` holds in F and Z, in `arm_qp.step_buffers`' order:
    (A, ix, W, travel, Q, contacts, K, s, e, d, servo, qp), qp the tuple of `buffers`."""
    qp = views(F, Z, 11)
    return (mat(F, Z, 0), ints(Z, 1), mat(F, Z, 2), mat(F, Z, 3), vec(F, Z, 4), mat(F, Z, 5),
            vec(F, Z, 6), vec(F, Z, 7), vec(F, Z, 8), vec(F, Z, 9), vec(F, Z, 10), qp)  # fmt: skip


@njit(cache=True, borrows=True)
def solve_packed(F: FloatArray, Z: IntArray, q: FloatArray, lam: float,
                 target: FloatArray) -> int:  # fmt: skip
    """`solve_arm_step` (with a servo if the servo array has a length) on the arrays packed in
    F and Z (`step_arrays`); returns DAQP's exit flag."""
    A, ix, W, travel, Q, contacts, K, s, e, d, servo, qp = step_arrays(F, Z)
    return solve_arm_step(A, ix, W, None, travel, Q, contacts, K, q, lam, target, s, e, d, qp,
                          servo)  # fmt: skip
