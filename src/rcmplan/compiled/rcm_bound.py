"""The step's RCM bound and the QP's RCM box in the compiled loops, written once for every robot.

`rcm_step` states the two rules (`step_scale`: shorten a step whose second-order part carries
the needle past the bound; `box_margin`: solve the QP again with a narrower RCM box while its
step leaves the needle beyond the box) and applies them to any robot model from Python
(`bounded_step`, `QpSolver.step`). Here the compiled loops apply them: `bound_step` and
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
from rcmplan.compiled.chain_kernels import IntArray, frames, needle_point
from rcmplan.compiled.qp_kernels import X, iteration_error, step_joints
from rcmplan.compiled.qp_params import RCM_TOL
from rcmplan.control.rcm_step import BOX_TRIES, STEP_TRIES, box_margin, step_scale
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


@njit(cache=True, inline="always")  # see the module docstring
def hold_box(P: FloatArray | None, arm: tuple | None, K: FloatArray, q: FloatArray, lam: float,
             target: FloatArray, trocar: FloatArray, now: float, first: int, m: int,
             fail: FloatArray, qpa: tuple, Q: FloatArray, C: FloatArray | None, e: FloatArray,
             d: FloatArray, x: FloatArray, w: FloatArray) -> tuple[float, bool]:  # fmt: skip
    """`QpSolver.step` after the loop's solve at joints q: the step d of the solution, the
    QP's RCM box held on the true kinematics (`rcm_step.box_margin`). While the step leaves
    the needle beyond the box's tolerance (and farther than `now` [m]; NaN: measured when
    first needed), solve again (`qp_solve`) with the box narrowed, at most BOX_TRIES times; a
    solve that fails is repeated with the last box that solved; a step still beyond is
    shortened against the box's tolerance (`bound_step`). The error is then the last solve's.
    Q: the QP's parameters in qpa (iRAM!S's qpa[0], `qp_kernels.loop_qp`; an arm's qpa[1],
    `arm_qp.qp_arrays`), whose RCM tolerance Q[RCM_TOL] the narrower solves change and restore.
    Returns (the factor the step was shortened by, 1.0 if not; True if a narrower box
    solved); x (n,) holds the stepped joints of the solution's step, w (6,) is scratch."""
    tol = Q[RCM_TOL]
    solution_step(P, arm, q, first, m, fail, qpa, d, x, w)
    if tol == 0.0:  # an equality: no box
        return 1.0, False
    margin = 0.0
    for _ in range(BOX_TRIES):
        after = distance_at(P, arm, x, trocar, w)
        if after <= tol:
            return 1.0, margin > 0.0
        if math.isnan(now):
            now = distance_at(P, arm, q, trocar, w)
        narrower = box_margin(after, now, tol, margin)
        if narrower == 0.0:
            return 1.0, margin > 0.0
        if narrower == margin:
            break
        Q[RCM_TOL] = tol - narrower
        flag = qp_solve(P, arm, K, q, lam, target, fail, qpa, C, e, d)
        if flag != 1:
            Q[RCM_TOL] = tol - margin
            qp_solve(P, arm, K, q, lam, target, fail, qpa, C, e, d)
        Q[RCM_TOL] = tol
        solution_step(P, arm, q, first, m, fail, qpa, d, x, w)
        if flag != 1:
            break
        margin = narrower
    return bound_step(P, arm, q, d, first, m, trocar, now, tol, x, w), margin > 0.0
