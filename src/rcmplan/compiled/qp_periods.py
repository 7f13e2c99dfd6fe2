"""A block of control periods of the QP controller on the kinematic plant, compiled: one call
runs every period from one planned target to the last one planned (a subretinal episode: from
one iOCT estimate's arrival to the next, `subretinal.episode_blocks`).

Each period does what `Episode.period` does, in the same order: joints from the sliders (the
PCJMs), lambda of the needle point closest to the period's trocar (drift correction; the
distance is the RCM deviation; the trocar moves with the eye when the eye moves), the depth
limit's floor and centre written into the QP's parameters Q (the floor at `floor_at`, the
centre `FLOOR_AT` before it; -1: no depth limit), the X_ext error at this state, the QP's step
as the loop takes it (`loop.period_step`: built and solved, the RCM box held on the true
kinematics), the sliders of the stepped joints with the plant's travel rule
(`loop.command_status`, the kernel `Iramis.check_actuators` calls), the record
(`records.REC_COLUMNS`, `loop.record`) and the plant's move (the kinematic plant reaches the
command). The RCM bound is checked last, after the period's record and move, as
`Episode.period` raises after them.

The kernel stops instead of raising: QP_FAILED (DAQP's exit flag in info[1]), BAD_JOINTS or
SLIDER_LIMIT (the slider in info[2]) before the period's record and move, RCM_BOUND after
them; info[0] holds the periods done. The caller repeats a period stopped before its move on
the per-period path, which raises the reference exception.
"""

from __future__ import annotations

import numpy as np

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.compiled.kernels import task
from rcmplan.compiled.loop import command_status, period_step, put, record
from rcmplan.compiled.records import DONE, FAIL_WIDTH, QP_FAILED, STEPPED
from rcmplan.control.limits.tissue_depth import FLOOR_AT
from rcmplan.robot.iramis_kernels import joints_from_actuators, point, trig
from rcmplan.robot.needle import closest_point

RCM_BOUND = QP_FAILED + 1  # the RCM deviation passed the bound (after the period's record)


@njit(cache=True)
def run_periods(
    P: FloatArray, Q: FloatArray, contacts: FloatArray, K: FloatArray, floor_at: int,
    bound: float, trocars: FloatArray, t: FloatArray, targets: FloatArray, desired: FloatArray,
    floors: FloatArray, centers: FloatArray, s: FloatArray, rec: FloatArray, deviation: FloatArray,
    info: np.ndarray, qp: tuple,
) -> int:  # fmt: skip
    """Run the periods j = 0.. of a block from sliders s (6,) (see the module docstring): at
    time t[j] [s] towards X_ext targets[j] (6,) with the trocar at trocars[j] (3,) [m], the
    desired tip desired[j] (3,) [m] recorded, the depth limit's floor floors[j] [m] at
    Q[floor_at] and its centre centers[j] (3,) [m] before it. s ends at the last period's command;
    rec[j] (35,) and deviation[j] [m] hold each period's record and RCM deviation. Returns
    DONE or a stop code (info as in the module docstring)."""
    q, qn, sn, d = np.empty(6), np.empty(6), np.empty(6), np.empty(6)
    e, w, fail = np.empty(6), np.empty(6), np.empty(FAIL_WIDTH)
    qpa = (Q, contacts, qp, np.empty(0), np.empty(0))  # `qp_kernels.loop_qp`: no servo
    for j in range(t.shape[0]):
        info[0] = j
        joints_from_actuators(P, s, q)
        tr = trig(q)
        point(P, q, tr, 0.0, w[:3])
        point(P, q, tr, 1.0, w[3:])
        lam, dev = closest_point(w[:3], w[3:], trocars[j])
        if floor_at >= 0:
            Q[floor_at] = floors[j]
            for i in range(3):
                Q[floor_at - FLOOR_AT + i] = centers[j, i]
        task(P, q, tr, lam, e)
        for i in range(6):
            e[i] = targets[j, i] - e[i]
        flag = period_step(P, K, q, lam, targets[j], fail, qpa, w, d)
        if flag != 1:
            info[1] = flag
            return QP_FAILED
        for i in range(6):
            qn[i] = q[i] + d[i] if i < 5 else q[i]
        status = command_status(P, qn, sn, info)
        if status != STEPPED:
            return status
        record(P, rec[j], t[j], s, q, tr, lam, trocars[j], desired[j], e, 6)
        deviation[j] = dev
        put(s, 0, sn, 0, 6)
        if dev > bound:
            info[0] = j + 1
            return RCM_BOUND
    info[0] = t.shape[0]
    return DONE
