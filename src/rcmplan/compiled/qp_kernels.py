"""The QP controller's step for iRAM!S in compiled code: the QP of `qp_problem.build_step`,
solved by DAQP's C function (`daqp_c`), and the step read from its solution.

The assembly computes iRAM!S's kinematics with its kernels (`robot/iramis_kernels.py`) and
its singular terms (cos q1, cos q3), then writes the QP with `qp_rows.assemble`, the code every
robot's compiled step shares (the limits' own row kernels and `cost.weighted_cost`):
variables x = (ds[L1..L5], l dlambda) / SCALE. A curved needle (`build_curved_step`) adds the
roll's actuator L6 to the variables, x = (ds[L1..L6], l dlambda) / SCALE, and its task is X_c
(`control.curved`: tip, roll, RCM point), its kinematics `curved_iramis`'s.

Settings travel as one float64 vector Q (`qp_params`), the robot as the kernels' P
(`iramis_kernels.PARAMS`), retina contact points as a (k, 3) array, and the buffers of one
solve as the tuple `qp` of `buffers()`.
"""

from __future__ import annotations

import numpy as np

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.compiled import qp_rows
from rcmplan.compiled.daqp_c import EQUALITY
from rcmplan.compiled.kernels import task
from rcmplan.compiled.qp_rows import X, assemble, lead_error, solve_assembled, solve_planned
from rcmplan.control import curved_step
from rcmplan.control.cost import x_c_point_rows, x_ext_jacobian
from rcmplan.control.limits.base import SCALE
from rcmplan.control.limits.rows import times
from rcmplan.control.resolution import quantised
from rcmplan.robot import curved_block as ck
from rcmplan.robot import curved_iramis
from rcmplan.robot.iramis_kernels import (
    actuators_from_joints,
    joints_from_actuators,
    point,
    point_jacobian,
    trig,
)

__all__ = [
    "EQUALITY",
    "N_BOUNDS",
    "X",
    "buffers",
    "build_curved_step",
    "build_step",
    "iteration_error",
    "loop_qp",
    "solve_step",
    "step_joints",
]

N_VAR = 6  # L1..L5 and l dlambda
N_BOUNDS = N_VAR
CURVED_VAR = 7  # a curved needle's: L1..L6 and l dlambda


def buffers(curved: bool = False) -> tuple:
    """The arrays one step's solve works in (`qp_rows.buffers`): a straight needle's, or with
    `curved` a curved needle's (seven variables, X_c's seven task rows)."""
    return qp_rows.buffers(CURVED_VAR, 7) if curved else qp_rows.buffers(N_VAR)


def loop_qp(
    params: tuple[FloatArray, FloatArray],
    res: FloatArray | None = None,
    cmd: FloatArray | None = None,
    curved: bool = False,
) -> tuple:
    """The QP's arrays as the iRAM!S loop reads them (`loop.iterate`'s qpa, None for the other
    methods): (Q, contacts, `buffers(curved)`, res, cmd). params: `qp_params.qp_params`'s
    (Q, contacts); res (6,) the plant's slider resolution and cmd (6,) its last command when
    the plant is the QP's servo (`QpSolver.servo`), the same array the loop commands
    through."""
    Q, contacts = params
    return (Q, contacts, buffers(curved), np.zeros(0) if res is None else res,
            np.zeros(6) if cmd is None else cmd)  # fmt: skip


@njit(cache=True, borrows=True)
def variable_map(P: FloatArray, tr: tuple, T: FloatArray) -> None:
    """T = d(q[active], lambda) / d(s[active], l lambda) (`limits.base.variable_map`) into T
    (w, w), whose other entries stay zero: the PCJM rates (`Iramis.joint_rates`), 1 for q4 (and
    a curved needle's roll q5, w = 7) and 1 / l6."""
    w = T.shape[0]
    for i in (0, 2):
        g = tr[i] ** 2 / P[6]
        T[i, i] = T[i, i + 1] = 0.5
        T[i + 1, i], T[i + 1, i + 1] = -g, g
    for i in range(4, w - 1):
        T[i, i] = 1.0
    T[w - 1, w - 1] = 1.0 / P[5]


@njit(cache=True, borrows=True)
def singular_rows(q: FloatArray, tr: tuple, T: FloatArray, qp: tuple) -> None:
    """`Iramis.singular_terms` (cos q1, cos q3) into qp's values (qp[9][:2]), their gradients
    times T into its gradient rows."""
    grads = qp[18]
    for a in range(2):
        j_q = 1 + 2 * a
        for j in range(T.shape[0]):
            grads[a, j] = -np.sin(q[j_q]) * T[j_q, j]
    qp[9][0], qp[9][1] = tr[0], tr[2]


@njit(cache=True, borrows=True)
def kinematics(P: FloatArray, q: FloatArray, tr: tuple, lam: float, T: FloatArray,
               J: FloatArray, JT: FloatArray, pts: FloatArray) -> None:  # fmt: skip
    """What the rows read (`limits.base.kinematics`): T; J (6, 6) the tip's and the RCM
    point's Jacobians; JT = (J_tip T, J_rcm T, the angle rows e_q1 T, e_q3 T); the tip, the
    RCM point and the needle axis (rows of pts)."""
    c1, s1, c3, s3 = tr
    variable_map(P, tr, T)
    point_jacobian(P, q, tr, 1.0, J, 0)
    J[0, 5] = J[1, 5] = J[2, 5] = 0.0  # the tip does not move with lambda
    point_jacobian(P, q, tr, lam, J, 3)
    times(J, T, JT[:6])
    for j in range(N_VAR):  # Iramis.needle_angles_jacobian: the rows of q1 and q3
        JT[6, j], JT[7, j] = T[1, j], T[3, j]
    point(P, q, tr, 1.0, pts[0])
    point(P, q, tr, lam, pts[1])
    pts[2, 0], pts[2, 1], pts[2, 2] = -c1 * c3, -s3, s1 * c3


@njit(cache=True, borrows=True)
def build_step(P: FloatArray, Q: FloatArray, contacts: FloatArray, K: FloatArray,
               q: FloatArray, tr: tuple, lam: float, target: FloatArray, s: FloatArray,
               e: FloatArray, qp: tuple) -> int:  # fmt: skip
    """The QP of one step at joints q, lambda (`qp_problem.build_step`) into the buffers;
    also the actuators s (6,) and the X_ext error e (6,). Returns the number of rows of A
    (`qp_rows.assemble`)."""
    T, J = qp[7:9]
    JT, pts = qp[15:17]
    actuators_from_joints(P, q, s)
    task(P, q, tr, lam, e)
    for i in range(6):
        e[i] = target[i] - e[i]
    kinematics(P, q, tr, lam, T, J, JT, pts)
    x_ext_jacobian(JT[:3], JT[6:8], JT[3:6], qp[6])
    singular_rows(q, tr, T, qp)
    return assemble(Q, contacts, K, lam, target, e, s[:5], P[7:12], P[13:18], P[5], qp[9][:2],
                    qp)  # fmt: skip


@njit(cache=True, borrows=True)
def build_curved_step(P: FloatArray, Q: FloatArray, contacts: FloatArray, K: FloatArray,
                      q: FloatArray, tr: tuple, lam: float, target: FloatArray, s: FloatArray,
                      e: FloatArray, qp: tuple, C: FloatArray) -> int:  # fmt: skip
    """`build_step` for iRAM!S holding a curved needle (P with its arc, `curved_iramis.params`):
    the QP at joints q, lambda towards X_c target (7,), its task rows J_c T (7, 7) with J_c
    from the work block C (`curved_block`); also the actuators s (6,) and the X_c error e (7,).
    Returns the number of rows of A."""
    T, task_ = qp[7], qp[6]
    JT, pts = qp[15:17]
    w = pts[3]  # scratch: the target's tip is written later, by the retina's row
    actuators_from_joints(P, q, s)
    curved_iramis.task(P, q, tr, lam, False, e, w)
    curved_step.error(e, target, e)
    variable_map(P, tr, T)
    curved_iramis.jacobian(P, q, tr, lam, False, C, 0, w)
    times(C[ck.J : ck.J + 7], T, task_)
    x_c_point_rows(task_, JT)
    _, a, _, tip = curved_iramis.frame(P, q, tr, w)
    pts[0, 0], pts[0, 1], pts[0, 2] = tip
    point(P, q, tr, lam, pts[1])
    pts[2, 0], pts[2, 1], pts[2, 2] = a
    singular_rows(q, tr, T, qp)
    return assemble(Q, contacts, K, lam, target, e, s, P[7:13], P[13:19], P[5], qp[9][:2], qp)


@njit(cache=True, borrows=True)
def solve_step(P: FloatArray, Q: FloatArray, contacts: FloatArray, K: FloatArray,
               q: FloatArray, tr: tuple, lam: float, target: FloatArray, s: FloatArray,
               e: FloatArray, qp: tuple, C: FloatArray | None,
               e_plan: FloatArray) -> int:  # fmt: skip
    """Build and solve the step's QP at joints q; returns DAQP's exit flag (1: optimal). The
    solution is in qp[X]; e holds the error a feasible step removes, J x* / K, or the plain
    task error when an actuator moves at full speed (`QpSolver.error`). C: None for a straight
    needle (`build_step`, X_ext's error (6,)), a curved needle's work block for its step
    (`build_curved_step`, X_c's (7,)). e_plan (0,): no servo; on a plant whose servos follow
    the command (`QpSolver`'s `servo`), q are the joints of the plant's last command, e_plan
    keeps the task's error there and the cost is synchronised to the actuators' speed window
    (`qp_rows.solve_planned`)."""
    if C is None:
        rows = build_step(P, Q, contacts, K, q, tr, lam, target, s, e, qp)
    else:
        rows = build_curved_step(P, Q, contacts, K, q, tr, lam, target, s, e, qp, C)
    if e_plan.shape[0] == 0:
        return solve_assembled(Q, K, rows, e, qp)
    return solve_planned(Q, K, rows, e, e_plan, qp)


@njit(cache=True, borrows=True)
def iteration_error(P: FloatArray, K: FloatArray, q: FloatArray, tr: tuple, lam: float,
                    target: FloatArray, fail: FloatArray, qpa: tuple,
                    C: FloatArray | None) -> int:  # fmt: skip
    """The QP's solve of one loop iteration at joints q (`QpSolver.error`): its error into
    fail[18:18 + k] and the actuators it was built at into fail[18 + k:24 + k], k the task's
    rows (X_ext's 6; a curved needle's X_c, 7, C its work block, else None); returns DAQP's
    exit flag (1: optimal), the solution in qpa[2][X]. qpa = (Q, contacts, qp, res, cmd)
    (`qp_params.loop_qp`): with a servo (res (6,), the plant's slider resolution, 0 where it
    has none; cmd (6,), its last command) the QP is planned from the command as the plant
    rounds it, its error the plan's plus the command's lead (`lead_error`; the plan's error,
    joints and the error at q after the actuators, fail[24 + k:37 + 2k]); without (res empty)
    it is built at q."""
    Q, contacts, qp, res, cmd = qpa
    k = 6 if C is None else 7  # the task's rows: X_ext's, or a curved needle's X_c
    e, s_qp = fail[18 : 18 + k], fail[18 + k : 24 + k]
    if res.shape[0] == 0:
        return solve_step(P, Q, contacts, K, q, tr, lam, target, s_qp, e, qp, C, fail[:0])
    e_plan, q_plan = fail[24 + k : 24 + 2 * k], fail[24 + 2 * k : 30 + 2 * k]
    now = fail[30 + 2 * k : 37 + 2 * k]
    quantised(cmd, res, now[:6])  # the command as the plant rounds it (`QpSolver.planned_joints`)
    joints_from_actuators(P, now[:6], q_plan)
    flag = solve_step(P, Q, contacts, K, q_plan, trig(q_plan), lam, target, s_qp, e, qp, C,
                      e_plan)  # fmt: skip
    if flag == 1:  # the task's error at the measured joints
        if C is None:
            task(P, q, tr, lam, now[:6])
            for i in range(6):
                now[i] = target[i] - now[i]
        else:
            curved_iramis.task(P, q, tr, lam, False, now, qp[16][3])
            curved_step.error(now, target, now)
        lead_error(Q, qp[X], now[:k], e_plan, e)
    return flag


@njit(cache=True, borrows=True)
def step_joints(P: FloatArray, q: FloatArray, s: FloatArray, x: FloatArray, qn: FloatArray,
                w: FloatArray) -> float:  # fmt: skip
    """The step of a solution x (`QpSolver.step`): joints q + (q(s + x SCALE) - q) into qn,
    with the actuators s the QP was built at, x's first w - 1 of them moved (a straight
    needle's L1..L5, a curved one's L1..L6); returns d lambda. w (>= 6) is scratch."""
    moved = x.shape[0] - 1
    for i in range(6):
        w[i] = s[i] + x[i] * SCALE if i < moved else s[i]
    joints_from_actuators(P, w, qn)
    for i in range(6):
        qn[i] = q[i] + (qn[i] - q[i]) if i < moved else q[i]
    return x[moved] * SCALE / P[5]
