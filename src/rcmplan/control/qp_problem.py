"""The quadratic programme of one QP control step, built as plain arrays tests can inspect.

Decision variables x = (ds[active], l dlambda) / SCALE: the increments of the actuators of the
active joints (iRAM!S: the sliders L1..L5, the roll q5 is not moved; an arm: its joints) and the
RCM's move along the needle, in micrometres or microradians (SCALE = 1e-6) so that every solver
sees numbers of order one. Actuator increments (not joint increments) make travel and speed
limits exact variable bounds; the joint step is recovered exactly through the actuator map
(iRAM!S: the PCJM maps, eqs. 2.1, 2.2).

    minimise   1/2 |W (J x SCALE - K e)|^2 / SCALE^2 + 1/2 D^2 |x|^2
    subject to lb <= x <= ub                      slider travel, speed over dt, lambda in [0, 1]
               A x = b  or  G_rcm x <= h_rcm      RCM: linearised equality or a box bound
               G_eye x <= h_eye                   retina margin, velocity damper with a gain
               G_sing x <= h_sing                 the robot's singular terms kept above a margin
                                                  (iRAM!S: cos q1 and cos q3)

J = J_a(q, lambda) T is the augmented Jacobian (eq. 3.15, exact angle rows) times the map
T = d(q[active], lambda) / d(s[active], l lambda); e the X_ext error; W weights the task rows
(angles in metres through `angle_weight`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.control.qp_limits import QpLimits
from rcmplan.control.targets import tip_of_target
from rcmplan.robot.model import RobotModel
from rcmplan.scene.eye import Eye

SCALE = 1e-6  # [m] per unit of the decision variables
RECOVERY = 1e-6  # [m] largest push back per step when a damped quantity is past its floor


@dataclass(frozen=True)
class QPProblem:
    """min 1/2 x'Px + q'x s.t. Gx <= h, Ax = b, lb <= x <= ub (qpsolvers' convention)."""

    P: FloatArray
    q: FloatArray
    G: FloatArray
    h: FloatArray
    A: FloatArray
    b: FloatArray
    lb: FloatArray
    ub: FloatArray


@dataclass(frozen=True)
class StepQP:
    """A step's QP and what is needed to read its solution.

    Attributes:
        problem: The QP.
        task: d X_ext / d x (6, m + 1) in SI units per unit of x (times SCALE).
        sliders: The actuator positions s (n,) at which the QP was built.
        contact: True if the step's target is a retina contact (margin relaxed).
    """

    problem: QPProblem
    task: FloatArray
    sliders: FloatArray
    contact: bool


@dataclass(frozen=True)
class StepInput:
    """State and settings of one step: joints q (6,), lambda, X_ext target and error (6,),
    gains K (6,), damping D, control period dt in [s], eye (or None) and the limits."""

    q: FloatArray
    lam: float
    target: FloatArray
    error: FloatArray
    K: FloatArray
    damping: float
    dt: float
    eye: Eye | None
    limits: QpLimits


class Kinematics(NamedTuple):
    """Quantities of one state shared by the QP rows, computed once.

    Attributes:
        s: Actuators (n,). T: d(q[active], lambda)/d(s[active], l lambda) (m + 1, m + 1).
        J_tip, J_rcm: d p / d(q[active], lambda) (3, m + 1) of the tip and of p(lambda).
        tip, rcm: Tip and RCM point (3,) in [m]. axis: Unit needle axis (3,).
    """

    s: FloatArray
    T: FloatArray
    J_tip: FloatArray
    J_rcm: FloatArray
    tip: FloatArray
    rcm: FloatArray
    axis: FloatArray


def variable_map(robot: RobotModel, q: FloatArray) -> FloatArray:
    """T = d(q[active], lambda) / d(s[active], l lambda), (m + 1, m + 1): the actuator map's
    dq/ds on the active joints (iRAM!S: eqs. 2.1, 2.2) and 1 / l for lambda."""
    active = list(robot.active)
    m = len(active)
    T = np.zeros((m + 1, m + 1))
    T[:m, :m] = robot.joint_rates(q)[np.ix_(active, active)]
    T[m, m] = 1.0 / robot.needle_length
    return T


def kinematics(robot: RobotModel, q: FloatArray, lam: float) -> Kinematics:
    """The shared quantities at (q, lambda)."""
    J_tip = robot.needle_point_jacobian(q, 1.0)
    J_tip[:, -1] = 0.0
    return Kinematics(
        robot.actuators_from_joints(q),
        variable_map(robot, q),
        J_tip,
        robot.needle_point_jacobian(q, lam),
        robot.needle_point(q, 1.0),
        robot.needle_point(q, lam),
        robot.needle_axis(q),
    )


def task_jacobian(kin: Kinematics, J_angles: FloatArray) -> FloatArray:
    """d X_ext / d x = J_a T, J_a with the exact angle rows J_angles (2, m + 1) (eq. 3.15)."""
    T = kin.T
    task = np.empty((6, T.shape[1]))
    task[0] = kin.J_tip[0] @ T
    task[1:3] = J_angles @ T  # on iRAM!S the rows e_q1, e_q3: T[1] and T[3]
    task[3:] = kin.J_rcm @ T
    return task


def damper_row(
    grad: FloatArray, value: float, floor: float, gain: float
) -> tuple[FloatArray, float]:
    """One velocity-damper row G x <= h for value + grad x SCALE >= floor, approached at `gain`.

    value_next - floor >= (1 - gain)(value - floor) to first order; past the floor, the state
    must not get worse and recovers by up to RECOVERY per step.
    """
    gap = value - floor
    need = -gain * gap if gap >= 0.0 else min(-gain * gap, RECOVERY)
    return -grad, -need / SCALE


def slider_bounds(
    robot: RobotModel, s: FloatArray, lam: float, dt: float, lim: QpLimits
) -> tuple[FloatArray, FloatArray]:
    """lb, ub on x: actuator travel (less the margin) and speed over dt; lambda in [0, 1].

    An actuator already past its soft travel may stay or move back, never further out.
    """
    active = list(robot.active)
    lo = robot.lower[active] + lim.travel_margin - s[active]
    hi = robot.upper[active] - lim.travel_margin - s[active]
    step = robot.speed[active] * dt
    length = robot.needle_length
    lb = np.append(np.minimum(np.maximum(lo, -step), 0.0), -lam * length)
    ub = np.append(np.maximum(np.minimum(hi, step), 0.0), (1.0 - lam) * length)
    return lb / SCALE, ub / SCALE


def cost(task: FloatArray, inp: StepInput) -> tuple[FloatArray, FloatArray]:
    """P and q of the weighted task error plus damping."""
    lim = inp.limits
    w = np.array([1.0, lim.angle_weight, lim.angle_weight, *(3 * (lim.rcm_weight,))])
    Aw = w[:, None] * task
    bw = w * inp.K * inp.error / SCALE
    P = Aw.T @ Aw
    P[np.diag_indices(P.shape[0])] += inp.damping**2
    return P, -Aw.T @ bw


def cross(a: FloatArray, b: FloatArray) -> FloatArray:
    """a x b for (3,) arrays (numpy's cross costs about 20 us per call)."""
    return np.array(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def normal_basis(axis: FloatArray) -> FloatArray:
    """Two unit vectors (2, 3) normal to a unit axis and to each other."""
    helper = np.zeros(3)
    helper[int(np.argmin(np.abs(axis)))] = 1.0
    n1 = cross(axis, helper)
    n1 /= math.sqrt(n1 @ n1)
    return np.array([n1, cross(axis, n1)])


def rcm_rows(inp: StepInput, kin: Kinematics) -> tuple[FloatArray, FloatArray]:
    """The needle line through the trocar, normal to the needle (the along-needle part is
    lambda's bookkeeping): N J_c T x = -N r / SCALE (equality) or a box of half-width
    tol / sqrt(2) per normal axis, so the deviation stays within tol to first order (eq. 3.10).
    """
    N = normal_basis(kin.axis)
    Jc = N @ kin.J_rcm @ kin.T
    r = N @ (kin.rcm - inp.target[3:])
    tol = inp.limits.rcm_tolerance
    if tol == 0.0:
        return Jc, -r / SCALE
    box = tol / math.sqrt(2.0)
    return np.vstack([Jc, -Jc]), np.concatenate([box - r, box + r]) / SCALE


def is_contact(eye: Eye, lim: QpLimits, tip_target: FloatArray) -> bool:
    """True if the target tip lies on the retina or on a listed contact point."""
    if abs(eye.distance_to_retina(tip_target)) <= lim.contact_tolerance:
        return True
    return any(np.linalg.norm(tip_target - c) <= lim.contact_tolerance for c in lim.contacts)


def eye_rows(inp: StepInput, kin: Kinematics) -> tuple[FloatArray, FloatArray, bool]:
    """The retina damper row (none while the tip is within the port zone or with no eye)."""
    eye, lim = inp.eye, inp.limits
    no_rows = np.zeros((0, kin.T.shape[1]))
    if eye is None:
        return no_rows, np.zeros(0), False
    tip = kin.tip
    tip_target = tip_of_target(inp.target)
    contact = is_contact(eye, lim, tip_target)
    if np.linalg.norm(tip - eye.port) <= lim.port_zone:
        return no_rows, np.zeros(0), contact
    u = (tip - eye.center) / np.linalg.norm(tip - eye.center)
    grad = -(u @ kin.J_tip) @ kin.T
    floor = lim.retina_margin
    if contact:
        floor = min(floor, max(eye.distance_to_retina(tip_target), 0.0))
    g, h = damper_row(grad, eye.distance_to_retina(tip), floor, lim.eye_gain)
    return g[None, :], np.array([h]), contact


def singular_rows(
    robot: RobotModel, inp: StepInput, T: FloatArray, floor: float
) -> tuple[FloatArray, FloatArray]:
    """Damper rows keeping each of the robot's singular terms above `floor` (iRAM!S: cos q1
    and cos q3, with |q1|, |q3| < pi/2 on the PCJMs)."""
    values, grads = robot.singular_terms(inp.q)
    active = list(robot.active)
    rows, hs = [], []
    for value, grad in zip(values, grads[:, active] @ T[: len(active)], strict=True):
        g, h = damper_row(grad, float(value), floor, inp.limits.singular_gain)
        rows.append(g)
        hs.append(h)
    return np.array(rows), np.array(hs)


def build_step(robot: RobotModel, inp: StepInput) -> StepQP:
    """The QP of one control step (see module docstring)."""
    kin = kinematics(robot, inp.q, inp.lam)
    task = task_jacobian(kin, robot.needle_angles_jacobian(inp.q))
    P, qv = cost(task, inp)
    lb, ub = slider_bounds(robot, kin.s, inp.lam, inp.dt, inp.limits)
    Rg, rh = rcm_rows(inp, kin)
    Eg, eh, contact = eye_rows(inp, kin)
    Sg, sh = singular_rows(robot, inp, kin.T, inp.limits.singular_floor(robot))
    equality = inp.limits.rcm_tolerance == 0.0
    G = np.vstack([Eg, Sg] if equality else [Rg, Eg, Sg])
    h = np.concatenate([eh, sh] if equality else [rh, eh, sh])
    A, b = (Rg, rh) if equality else (np.zeros((0, task.shape[1])), np.zeros(0))
    return StepQP(QPProblem(P, qv, G, h, A, b, lb, ub), task * SCALE, kin.s, contact)
