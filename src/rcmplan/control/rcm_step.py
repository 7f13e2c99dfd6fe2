"""The controller bounds its own step from the stated RCM tolerance.

A step of the augmented Jacobian (or of DLS, or of the QP) moves the RCM point to first order
exactly where the task asks, onto the trocar; what it leaves is second order in the step's
length (the needle's rotation bends the path of every point of it). A step scaled by f then
leaves at most (1 - f) times the deviation before it plus f^2 times its own second-order part:
a step that would leave the needle farther than the bound from the trocar is scaled to bring
that sum to 0.9 bound (`step_scale`; without a deviation before it, by sqrt(0.9 bound /
deviation)) and tried again, at most STEP_TRIES times, and a step that leaves it no farther
than it was is kept (the loop then converges from where it stands). Scaling by the second-order
part alone, a needle already near the bound was carried past it by the first-order part left
over: `rcmplan inject --robot ur5` with 0.99 mm and 10 mrad steps ended at 1.05 um against
0.8 (0.80 um now). The loop tolerance then takes more iterations
per target where a robot turns the needle through long levers, instead of needing smaller
target steps from the plan.

The QP holds the RCM inside its own box (`QpLimits.rcm_tolerance`), linearised at the step's
start, so the same second-order part can carry the needle past the box by up to that part's
size: shrinking the step does not help there (the box's edge is where the QP puts the needle,
whatever the step's length). So the QP's step is checked on the true kinematics, and a step
that leaves the needle beyond the box (and farther than it was) is solved again with the box
narrowed by a margin that grows with the excess (`box_margin`), at most BOX_TRIES times; the
last step that solved is kept, and if even the narrowest box leaves it beyond (a step whose
second-order part alone exceeds the tolerance) it is shortened against the QP's tolerance by
the rule above (`bounded_step`), before the loop's own bound applies to it.

The retina barrier is linearised the same way: riding its floor (a grazing path), each step's
second-order part carried the tip past it, by up to 55 nm a step on Baxter's and 109 records
of a Kinova Jaco's grazing spiral. The same tries hold it: a step that leaves the tip nearer
the retina than the floor (and nearer than it was; outside the port zone, towards a target
that is no contact) is solved again with the floor raised by a lift that grows with the excess
(`retina_lift`, up to the barrier's recovery per step), together with the narrower box. A step
the lifted floor still leaves beyond is kept, and counted by the run's limit check.

`step_scale`, `box_margin` and `retina_lift` are the rules, and `next_bounds` the hold's
decision from what a step measured (held, no narrower bound left, or the next bounds); the
compiled loops apply them once for every robot (`rcm_bound.bound_step`, `rcm_bound.hold_box`),
the Python loop and `QpSolver.step` here on any robot model (`bounded_step`): each measures on
its own kinematics and decides with the same kernels.
"""

from __future__ import annotations

import math
from typing import Any

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.robot.needle import closest_point

STEP_TRIES = 4  # the scaled step is tried again at most this many times
SHRINK_FLOOR = 0.1  # no single try shrinks a step by more than this factor
BOX_TRIES = 3  # the QP is solved again with a narrower RCM box at most this many times
BOX_GROWTH = 1.25  # the margin grows by this multiple of the excess over the box
HELD, STUCK, AGAIN = 0, 1, 2  # `next_bounds`: the step holds; no narrower bound; solve again


@njit(cache=True, borrows=True)
def step_scale(after: float, before: float, bound: float, total: float) -> float:
    """1.0 if a step leaves the needle within `bound` [m] of the trocar, or no farther than
    `before` [m]; else the factor (in [SHRINK_FLOOR, 1]) for the step, itself `total` times
    the solver's step, that brings the needle to 0.9 bound, or as near as a shorter step can.

    The solver's step s puts the RCM point on the trocar to first order, so the scaled step
    f s leaves at most (1 - f) before + f^2 c, c the second-order size of s (the triangle
    inequality); `after`, measured at f = total, gives c. The largest f with that sum at
    0.9 bound is taken, or where no f reaches it (`before` near the bound and c large: a long
    step) the f that brings the needle nearest, b / 2c. Without `before` (0) this is the
    second-order rule f = sqrt(0.9 bound / c)."""
    if after <= bound or after <= before:
        return 1.0
    c = max(after - (1.0 - total) * before, 0.0) / (total * total)
    if not c > 0.0 or not math.isfinite(c):
        return SHRINK_FLOOR
    goal = 0.9 * bound
    disc = before * before - 4.0 * c * (before - goal)
    f = (before + math.sqrt(disc)) / (2.0 * c) if disc >= 0.0 else before / (2.0 * c)
    return min(max(SHRINK_FLOOR, f / total), 1.0)


@njit(cache=True, borrows=True)
def box_margin(after: float, before: float, tol: float, margin: float, cap: float) -> float:
    """0.0 if a QP step solved with a limit's bound `tol` less `margin` leaves the limited value
    within `tol` (`after`), or no farther than it was (`before`); else the margin for the
    next solve: margin + BOX_GROWTH (after - tol), at most `cap`. A result equal to `margin`
    means no narrower bound is left.

    The RCM box: the needle's distance from the trocar [m] within the RCM tolerance, cap the
    tolerance (the box then an equality). The retina margin: minus the tip's retina gap
    within minus the floor (`retina_lift`)."""
    if after <= tol or after <= before:
        return 0.0
    return min(cap, margin + BOX_GROWTH * (after - tol))


@njit(cache=True, borrows=True)
def retina_lift(after: float, before: float, floor: float, lift: float, cap: float) -> float:
    """`box_margin` for the retina barrier: 0.0 if a QP step solved with its floor [m] raised
    by `lift` leaves the tip's retina gap at least `floor` (`after` [m]) or no nearer the
    retina than it was (`before` [m]); else the lift for the next solve, at most `cap` (the
    barrier's recovery per step: past its floor it asks no more)."""
    return box_margin(-after, -before, -floor, lift, cap)


@njit(cache=True, borrows=True)
def next_bounds(after: float, now: float, gap: float, gap_now: float, tol: float,
                floor: float, recovery: float, margin: float,
                lift: float) -> tuple[int, float, float]:  # fmt: skip
    """The QP hold's decision after a step solved with its RCM box narrowed by `margin` and
    its retina floor raised by `lift` [m]: (HELD, margin, lift) if the step holds both
    (`box_margin`, `retina_lift` give 0.0); (STUCK, margin, lift) if neither bound can
    narrow further; else (AGAIN, the narrowing, the lift) of the next solve, a bound that
    holds keeping its own.

    after, now: the needle's distance from the trocar after and before the step [m] (`now`
    measured once after > tol; tol 0: an equality, no box). gap, gap_now: the tip's retina
    gap after and before it [m] (inf where the barrier does not hold its margin; `gap_now`
    measured once gap < floor). floor: the barrier's margin; recovery: its return per step."""
    narrower = box_margin(after, now, tol, margin, tol) if tol > 0.0 else 0.0
    higher = retina_lift(gap, gap_now, floor, lift, recovery)
    if narrower == 0.0 and higher == 0.0:
        return HELD, margin, lift
    narrower = margin if narrower == 0.0 else narrower
    higher = lift if higher == 0.0 else higher
    if narrower == margin and higher == lift:
        return STUCK, margin, lift
    return AGAIN, narrower, higher


def needle_distance(robot: Any, q: FloatArray, trocar: FloatArray) -> float:
    """Distance in [m] from the trocar to the needle (its shaft's closest point) at joints q,
    on any robot model (the compiled loops: `rcm_bound.distance_at`)."""
    base, end = robot.needle_point(q, 0.0), robot.needle_point(q, 1.0)
    return float(closest_point(base, end, trocar)[1])


def bounded_step(
    robot: Any, q: FloatArray, dq: FloatArray, dlam: float, trocar: FloatArray, bound: float
) -> tuple[FloatArray, float]:
    """The step (dq over the robot's active joints, dlam) shortened until the needle passes
    within `bound` [m] of the trocar after it, or no farther than before it (`step_scale`);
    bound <= 0: the step as it is (the compiled loops: `rcm_bound.bound_step`)."""
    if not bound > 0.0:
        return dq, dlam
    active, now = list(robot.active), math.nan  # the distance before, measured if needed
    total = 1.0  # the step's scale so far
    for _ in range(STEP_TRIES):
        x = q.copy()
        x[active] += dq
        after = needle_distance(robot, x, trocar)
        if after <= bound:
            break
        now = needle_distance(robot, q, trocar) if math.isnan(now) else now
        f = step_scale(after, now, bound, total)
        if f == 1.0:
            break
        total *= f
        dq, dlam = dq * f, dlam * f
    return dq, dlam
