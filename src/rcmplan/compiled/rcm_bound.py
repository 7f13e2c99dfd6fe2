"""The step's RCM bound and the QP's RCM box and retina margin in the compiled loops, written
once for every robot.

`rcm_step` states the rules (`step_scale`: shorten a step whose second-order part carries the
needle past the bound; `box_margin`: solve the QP again with a narrower RCM box while its step
leaves the needle beyond the box; `retina_lift`: and with a raised retina floor while it leaves
the tip past the margin) and applies them to any robot model from Python (`bounded_step`,
`QpSolver.step`). Here the compiled loops apply them: `bound_step` and
`hold_box` hold the loop over tries once, and the robot's kinematics come, as in
`algorithm.run_targets`, in two arguments, one of them None:

- P: iRAM!S's closed forms' parameter vector; the moving joints are q[0:m] (a curved
  needle's roll q5 among them), the QP's solution moves the sliders (`qp_kernels.step_joints`);
- arm: (A, ix, W), a serial arm's chain arrays and its frame work array (W then holds the
  frames of the last joints measured); the moving joints are ix[first:first + m].

numba leaves out the branch of the argument that is None, so each family compiles with its own
kinematics only. A step d holds the moving joints' increments, then d lambda in d[m].

`hold_box` and `qp_solve` are inlined into their callers (`loop.qp_step`, `loop.period_step`,
`arm_loop.step`, `arm_loop.held_packed`) rather than compiled as functions of their own: numba
optimises a compiled kernel's whole callee tree for it and then again in each caller, and each
of their four versions held the QP's whole solve: 13-17 s (`hold_box`) and 11-14 s
(`qp_solve`) of a cold compile of every kernel. Inlined, a cold compile takes 0.93-0.94 of the
CPU time (docs/benchmarks.md).
Inlining the QP's solve itself (`qp_kernels.iteration_error`, `arm_qp_solve`) into the loops'
iterations made it slower (a cold compile still ran after 6 min, against 4 min before):
`algorithm.run_targets` then optimises it in each of its versions.
"""

from __future__ import annotations

import math

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.compiled.arm_qp_kernels import solve_arm_step
from rcmplan.compiled.chain_kernels import IntArray, frames, holds_frames, needle_point
from rcmplan.compiled.qp_kernels import X, iteration_error, step_joints
from rcmplan.compiled.qp_params import (
    CENTER,
    RCM_TOL,
    RETINA_MARGIN,
    RETINA_RADIUS,
    RETINA_RECOVERY,
)
from rcmplan.compiled.qp_rows import POINTS, retina_floor
from rcmplan.control.limits.retina import MAX_MARGIN
from rcmplan.control.limits.rows import radial_gap
from rcmplan.control.rcm_step import (
    BOX_TRIES,
    HELD,
    STEP_TRIES,
    STUCK,
    next_bounds,
    step_scale,
)
from rcmplan.robot import curved_arm, curved_iramis
from rcmplan.robot.iramis_kernels import point, trig
from rcmplan.robot.needle import closest_point


@njit(cache=True, borrows=True)
def rcm_distance(P: FloatArray, q: FloatArray, trocar: FloatArray, w: FloatArray) -> float:
    """Distance in [m] from the trocar to iRAM!S's needle (shaft) at joints q; w (6,) is
    scratch."""
    tr = trig(q)
    point(P, q, tr, 0.0, w[:3])
    point(P, q, tr, 1.0, w[3:])
    return closest_point(w[:3], w[3:], trocar)[1]


@njit(cache=True, borrows=True)
def closest_on_needle(
    A: FloatArray, n: int, W: FloatArray, trocar: FloatArray
) -> tuple[float, float]:
    """(lambda in [0, 1], distance [m]) of an arm's needle point closest to the trocar, at the
    frames in W (`needle.closest_point`)."""
    return closest_point(needle_point(A, n, W, 0.0), needle_point(A, n, W, 1.0), trocar)


@njit(cache=True, borrows=True)
def stepped(n: int, ix: IntArray, first: int, m: int, s: FloatArray, d: FloatArray,
            x: FloatArray) -> None:  # fmt: skip
    """An arm's stepped joints s + d (d over the moving joints ix[first:first + m]) into
    x (n,)."""
    for i in range(n):
        x[i] = s[i]
    for j in range(m):
        x[ix[first + j]] += d[j]


@njit(cache=True, borrows=True)
def distance_at(P: FloatArray | None, arm: tuple | None, x: FloatArray, trocar: FloatArray,
                w: FloatArray) -> float:  # fmt: skip
    """Distance in [m] from the trocar to the needle at joints x (an arm's W then holds the
    frames of x); w (6,) is iRAM!S's scratch."""
    if P is not None:
        return rcm_distance(P, x, trocar, w)
    if arm is not None:
        A, ix, W = arm
        frames(A, ix, x, W)
        return closest_on_needle(A, ix[0], W, trocar)[1]
    return math.nan


@njit(cache=True, borrows=True)
def stepped_distance(P: FloatArray | None, arm: tuple | None, q: FloatArray, d: FloatArray,
                     first: int, m: int, trocar: FloatArray, x: FloatArray,
                     w: FloatArray) -> float:  # fmt: skip
    """Distance in [m] from the trocar to the needle after the step d from joints q, the
    stepped joints into x."""
    if P is not None:
        for i in range(6):
            x[i] = q[i] + d[i] if i < m else q[i]
    if arm is not None:
        stepped(arm[1][0], arm[1], first, m, q, d, x)
    return distance_at(P, arm, x, trocar, w)


@njit(cache=True, borrows=True)
def bound_step(P: FloatArray | None, arm: tuple | None, q: FloatArray, d: FloatArray,
               first: int, m: int, trocar: FloatArray, now: float, bound: float,
               x: FloatArray, w: FloatArray) -> float:  # fmt: skip
    """`rcm_step.bounded_step`: shorten the step d from joints q until the needle passes within
    `bound` [m] of the trocar after it, or no farther than `now` [m] (its distance at q; NaN:
    measured when first needed); bound <= 0: no bound. x (n,) and w (6,) are scratch. Returns
    the factor applied (1.0: d untouched)."""
    total = 1.0
    for _ in range(STEP_TRIES if bound > 0.0 else 0):
        after = stepped_distance(P, arm, q, d, first, m, trocar, x, w)
        if after <= bound:
            break
        if math.isnan(now):
            now = distance_at(P, arm, q, trocar, w)
        f = step_scale(after, now, bound, total)
        if f == 1.0:
            break
        total *= f
        for j in range(m + 1):
            d[j] *= f
    return total


@njit(cache=True, borrows=True)
def arm_qp_solve(A: FloatArray, ix: IntArray, W: FloatArray, C: FloatArray | None, qpa: tuple,
                 K: FloatArray, s: FloatArray, lam: float, target: FloatArray, e: FloatArray,
                 d: FloatArray) -> int:  # fmt: skip
    """An arm's QP error e and step d at joints s (`ArmQpStep`): a curved needle's (C its work
    array) or a straight one's, planned from its servo's command if it has one; returns DAQP's
    exit flag, kept in qpa's flag."""
    travel, Q, contacts, bufs, act, flag, servo = qpa
    flag[0] = solve_arm_step(A, ix, W, C, travel, Q, contacts, K, s, lam, target, act, e, d, bufs,
                             servo)  # fmt: skip
    return flag[0]


@njit(cache=True, inline="always")  # see the module docstring
def qp_solve(P: FloatArray | None, arm: tuple | None, K: FloatArray, q: FloatArray, lam: float,
             target: FloatArray, fail: FloatArray, qpa: tuple, C: FloatArray | None,
             e: FloatArray, d: FloatArray) -> int:  # fmt: skip
    """The QP's solve at joints q, its error into e (iRAM!S: into fail, `iteration_error`);
    an arm's step into d. Returns DAQP's exit flag."""
    if P is not None:
        return iteration_error(P, K, q, trig(q), lam, target, fail, qpa, C)
    if arm is not None:
        A, ix, W = arm
        return arm_qp_solve(A, ix, W, C, qpa, K, q, lam, target, e, d)
    return 0


@njit(cache=True, borrows=True)
def solution_step(P: FloatArray | None, arm: tuple | None, q: FloatArray, first: int, m: int,
                  fail: FloatArray, qpa: tuple, d: FloatArray, x: FloatArray,
                  w: FloatArray) -> None:  # fmt: skip
    """The step d of the QP's last solution from joints q, its stepped joints into x. iRAM!S:
    the solution moves the sliders it was built at (fail[19 + m:25 + m]) and d is the joints'
    move (`step_joints`); an arm's solve left its step in d."""
    if P is not None:
        d[m] = step_joints(P, q, fail[19 + m : 25 + m], qpa[2][X], x, w)
        for i in range(m):
            d[i] = x[i] - q[i]
    if arm is not None:
        stepped(arm[1][0], arm[1], first, m, q, d, x)


@njit(cache=True, borrows=True)
def tip_at(P: FloatArray | None, arm: tuple | None, C: FloatArray | None, x: FloatArray,
           w: FloatArray) -> tuple[float, float, float]:  # fmt: skip
    """The needle's tip [m] at joints x: on the arc for a curved needle (C its work block,
    else None). An arm's W then holds the frames of x; w (6,) is iRAM!S's scratch."""
    if P is not None:
        tr = trig(x)
        if C is None:
            point(P, x, tr, 1.0, w[3:])
            return w[3], w[4], w[5]
        point(P, x, tr, 0.0, w[:3])
        a, b = curved_iramis.axes(x, tr)
        return curved_iramis.tip_of(P, (w[0], w[1], w[2]), a, b)
    if arm is not None:
        A, ix, W = arm
        if not holds_frames(ix, x, W):  # `distance_at` has framed x, as a rule
            frames(A, ix, x, W)
        if C is None:
            return needle_point(A, ix[0], W, 1.0)
        return curved_arm.tip(A, ix[0], W)
    return math.nan, math.nan, math.nan


@njit(cache=True, borrows=True)
def gap_at(P: FloatArray | None, arm: tuple | None, C: FloatArray | None, Q: FloatArray,
           contacts: FloatArray, pts: FloatArray, target: FloatArray, x: FloatArray,
           w: FloatArray, held: bool) -> float:  # fmt: skip
    """The tip's retina gap [m] at joints x (`tip_at`); with `held`, inf where the QP's retina
    barrier does not hold its margin there (no eye, the tip in the port zone, a contact
    target: `qp_rows.retina_floor`). pts (5, 3) is scratch (the QP's points, which the next
    solve writes again)."""
    tip = pts[0]
    tip[0], tip[1], tip[2] = tip_at(P, arm, C, x, w)
    if held and retina_floor(Q, contacts, target, tip, pts[4], pts[3]) != Q[RETINA_MARGIN]:
        return math.inf
    return radial_gap(Q[CENTER : CENTER + 3], Q[RETINA_RADIUS], tip)


@njit(cache=True, borrows=True)
def retina_gap(P: FloatArray | None, arm: tuple | None, C: FloatArray | None, Q: FloatArray,
               qpa: tuple, target: FloatArray, x: FloatArray, w: FloatArray,
               held: bool) -> float:  # fmt: skip
    """`gap_at` with the contacts and the points of the QP's arrays: iRAM!S's
    (`qp_kernels.loop_qp`) or an arm's (`arm_qp.qp_arrays`)."""
    if P is not None:
        return gap_at(P, arm, C, Q, qpa[1], qpa[2][POINTS], target, x, w, held)
    if arm is not None:
        return gap_at(P, arm, C, Q, qpa[2], qpa[3][POINTS], target, x, w, held)
    return math.nan


@njit(cache=True, borrows=True)
def held_bounds(P: FloatArray | None, arm: tuple | None, C: FloatArray | None, Q: FloatArray,
                qpa: tuple, q: FloatArray, x: FloatArray, target: FloatArray,
                trocar: FloatArray, margin: float, lift: float, now: float, gap_now: float,
                w: FloatArray) -> tuple[int, float, float, float, float]:  # fmt: skip
    """`rcm_step.next_bounds` after a QP step from joints q to x solved with the RCM box
    narrowed by `margin` and the retina floor raised by `lift` [m], measured on the robot's
    kinematics: (its decision, the next narrowing and lift, the needle's distance and the
    tip's retina gap at q [m], each measured here when first needed: NaN before). Q holds
    the QP's own tolerance and margin."""
    tol, floor = Q[RCM_TOL], Q[RETINA_MARGIN]
    after = distance_at(P, arm, x, trocar, w) if tol > 0.0 else 0.0
    if after > tol and math.isnan(now):
        now = distance_at(P, arm, q, trocar, w)
    gap = retina_gap(P, arm, C, Q, qpa, target, x, w, True)
    if gap < floor and math.isnan(gap_now):
        gap_now = retina_gap(P, arm, C, Q, qpa, target, q, w, False)
    status, narrower, higher = next_bounds(after, now, gap, gap_now, tol, floor,
                                           Q[RETINA_RECOVERY], margin, lift)  # fmt: skip
    return status, narrower, higher, now, gap_now


@njit(cache=True, inline="always")  # see the module docstring
def hold_box(P: FloatArray | None, arm: tuple | None, K: FloatArray, q: FloatArray, lam: float,
             target: FloatArray, trocar: FloatArray, now: float, first: int, m: int,
             fail: FloatArray, qpa: tuple, Q: FloatArray, C: FloatArray | None, e: FloatArray,
             d: FloatArray, x: FloatArray, w: FloatArray) -> tuple[float, bool]:  # fmt: skip
    """`QpSolver.step` after the loop's solve at joints q: the step d of the solution, the
    QP's RCM box and retina margin held on the true kinematics (`rcm_step.box_margin`,
    `retina_lift`). While the step leaves the needle beyond the box's tolerance (and farther
    than `now` [m]; NaN: measured when first needed) or the tip nearer the retina than its
    margin (and nearer than before), solve again (`qp_solve`) with the box narrowed and the
    floor raised, at most BOX_TRIES times; a solve that fails is repeated with the last
    bounds that solved; a step still beyond the box is shortened against its tolerance
    (`bound_step`). The error is then the last solve's. Q: the QP's parameters in qpa
    (iRAM!S's qpa[0], `qp_kernels.loop_qp`; an arm's qpa[1], `arm_qp.qp_arrays`), whose RCM
    tolerance and retina margin the narrower solves change and restore. Returns (the factor
    the step was shortened by, 1.0 if not; True if a narrower solve stood); x (n,) holds the
    stepped joints of the solution's step, w (6,) is scratch."""
    tol, floor = Q[RCM_TOL], Q[RETINA_MARGIN]
    solution_step(P, arm, q, first, m, fail, qpa, d, x, w)
    gap_now = math.nan  # the tip's retina gap before the step, measured if needed
    margin = lift = 0.0  # the box's narrowing and the floor's lift of the last solve
    for _ in range(BOX_TRIES):
        status, narrower, higher, now, gap_now = held_bounds(P, arm, C, Q, qpa, q, x, target,
                                                             trocar, margin, lift, now, gap_now,
                                                             w)  # fmt: skip
        if status == HELD:
            return 1.0, margin > 0.0 or lift > 0.0
        if status == STUCK:
            break
        Q[RCM_TOL], Q[RETINA_MARGIN] = tol - narrower, min(floor + higher, MAX_MARGIN)
        flag = qp_solve(P, arm, K, q, lam, target, fail, qpa, C, e, d)
        if flag != 1:
            Q[RCM_TOL], Q[RETINA_MARGIN] = tol - margin, min(floor + lift, MAX_MARGIN)
            qp_solve(P, arm, K, q, lam, target, fail, qpa, C, e, d)
        Q[RCM_TOL], Q[RETINA_MARGIN] = tol, floor
        solution_step(P, arm, q, first, m, fail, qpa, d, x, w)
        if flag != 1:
            break
        margin, lift = narrower, higher
    if tol == 0.0:
        return 1.0, margin > 0.0 or lift > 0.0
    return bound_step(P, arm, q, d, first, m, trocar, now, tol, x, w), margin > 0.0 or lift > 0.0
