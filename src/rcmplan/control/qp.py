"""The hard-constrained QP controller: one small QP per control step (`--method qp`).

Each step minimises the weighted X_ext error plus damping over the slider increments and
delta lambda, subject to the RCM, slider travel and speed over the control period, lambda in
[0, 1], a retina margin and a singular margin (qp_problem.py; docs/qp.md). In the spirit of
constrained-optimisation virtual fixtures (Li and Taylor); the thesis's pseudoinverse and DLS,
and V-REP's IK, hold no limits.

Termination at a limit. The loop (Algorithm 1) stops when every error component is within
tolerance. The QP solver's `error` is the part of the task error that a feasible step can still
remove: J x* / K (componentwise), with x* the QP's solution at this state. With no constraint
active it equals the X_ext error (up to the damping, relative size D^2/sigma_min^2); at the
closest feasible point to the target it is zero, so the loop moves on to the next target. A step
at an actuator's full speed is not at such a point (the speed bound only slows the motion): then
`error` is the plain X_ext error, so a tolerance looser than one period's motion cannot end a
target early. The true X_ext error stays available through `task_error`, and the log's tip and
target records.

On a plant whose servos follow the command over several periods (`servo`: the dynamic MuJoCo
plant, whose reference ramps towards the command within speed and acceleration) the QP plans
the command the servo follows: each step is built at the plant's last command, rounded to the
actuator resolution as the plant rounds it (the position the servo settles at), so the speed
window, the RCM and every other limit hold on the commanded motion; built at the lagging
measured actuators, a speed-bounded command could pull the servo reference back, and
limits linearised there hold on a pose up to a ramp's lead (about 0.15 mm) away. The loop then
stops on `error` = J x* / K at the command plus the command's lead over the measured pose
(X(command) - X(measured)): zero once the command is where the QP would stay and the
servo has arrived.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any, ClassVar

import numpy as np

from rcmplan._validate import F64, FloatArray, scalar, vector
from rcmplan.control.augmented import extended_task
from rcmplan.control.cost import synchronise
from rcmplan.control.curved import (
    CURVED_TASKS,
    LimitedPoseSolver,
    check_gains7,
    gains_from_x_ext,
)
from rcmplan.control.curved import task_error as curved_error
from rcmplan.control.curved_targets import solve_curved_pose
from rcmplan.control.eye_model import EyeModel
from rcmplan.control.limited_tip import LimitedTipSolver
from rcmplan.control.limits import Limit, RcmLimit
from rcmplan.control.limits.base import SPEED_ACTIVE
from rcmplan.control.limits.retina import MAX_MARGIN, RetinaBarrier
from rcmplan.control.qp_backends import DEFAULT_BACKEND, QpResult, check_backend, solve
from rcmplan.control.qp_checks import check_qp_args
from rcmplan.control.qp_limits import QpLimits
from rcmplan.control.qp_problem import SCALE, CostTerm, StepInput, StepQP, build_step
from rcmplan.control.rcm_step import (
    BOX_TRIES,
    HELD,
    STUCK,
    bounded_step,
    needle_distance,
    next_bounds,
)
from rcmplan.control.resolution import quantised
from rcmplan.control.solvers import SolverKind, Tolerance, check_damping, check_gains
from rcmplan.control.targets import checked_target, solve_pose, target_tip
from rcmplan.exceptions import QPError, UnreachableTargetError
from rcmplan.robot.curved import CurvedTipRobot
from rcmplan.robot.model import RobotModel


class QpSolver:
    """Step solver holding RCM, slider, lambda, eye and singular limits at every step.

    Args:
        robot: The robot whose limits are held.
        eye: The eye (retina margin); None holds no eye constraint.
        dt: Control period in [s]: slider speed limits apply over it.
        K: Diagonal gains (6,), each in (0, 2).
        damping: Damping D >= 0 on the step (dimensionless, per unit slider motion).
        tol: Loop tolerance.
        limits: What is held (checked against robot and eye here, before any motion).
        backend: QP solver (see qp_backends.BACKENDS).
        servo: The plant, when its servos follow commands over several periods (it has
            `exact_commands` False and a `command`): steps are planned from its last command
            (module docstring). None, or a plant with exact commands: from the measured state.
            A `Controller` sets it to its own plant (`follow`).
        extra_limits: Limits held besides the standard ones (`QpLimits.rows`), for
            example a `limits.WorkspaceBound` for the tip or a `limits.TissueDepthLimit` (the
            compiled QP step holds these two; a solver with others runs in Python).
        objectives: Cost terms besides the X_ext task (`objective.Objective`: a task with
            its target, gain and weight), for example a posture for a redundant arm (the
            solver with any runs in Python).
    """

    name: ClassVar[str] = "qp"
    kind: ClassVar[SolverKind] = "rcm"

    def __init__(
        self,
        robot: RobotModel,
        eye: EyeModel | None = None,
        dt: float = 1e-3,
        K: tuple[float, ...] = (1.0,) * 6,
        damping: float = 1e-4,
        tol: Tolerance | None = None,
        limits: QpLimits | None = None,
        backend: str = DEFAULT_BACKEND,
        servo: Any | None = None,
        extra_limits: tuple[Limit, ...] = (),
        objectives: tuple[CostTerm, ...] = (),
    ) -> None:
        check_qp_args(robot, eye, K, tol, limits, servo, extra_limits, objectives)
        self.robot = robot
        self.eye = eye
        self.dt = scalar("dt", dt, 0.0, 1.0, low_open=True)
        # A curved needle: X_c (7 rows, `rcmplan.control.curved`), gains from X_ext's.
        self.curved = isinstance(robot, CurvedTipRobot) and robot.needle.curved
        if self.curved:
            self.K = check_gains7(gains_from_x_ext(K) if len(K) == 6 else K)
        else:
            self.K = check_gains(K)
        self.target_width = 7 if self.curved else 6
        self._seed: FloatArray | None = None
        self.damping = check_damping(damping)
        self.tol = (tol or Tolerance()).checked()
        self.limits = (limits or QpLimits()).check(robot, eye)
        self.backend = check_backend(backend)
        self.follow(servo)
        self.extra_limits = tuple(extra_limits)
        self.rows: tuple[Limit, ...] = (*self.limits.rows(eye, self.dt), *self.extra_limits)
        self.bounds = self.limits.bounds()
        self.objectives = tuple(objectives)
        self.weights = self.limits.weights(self.target_width)
        self.last: tuple[StepQP, QpResult] | None = None
        self._planned_error: FloatArray = np.zeros(0)  # the task error of the last solve
        self._key: bytes = b""
        self._checked: set[bytes] = set()  # targets already checked (their bytes)

    def follow(self, plant: Any | None) -> None:
        """Plan the steps from `plant`'s last command if its servos follow commands over
        several periods (it has `exact_commands` False and a `command`), else from the measured
        state (module docstring). A `Controller` hands the solver its plant so."""
        follows = plant is not None and not getattr(plant, "exact_commands", True)
        self.servo = plant if follows and hasattr(plant, "command") else None
        res = getattr(self.servo, "actuator_resolution", None)
        n = len(self.robot.home_actuators)
        self._resolution = None if res is None else vector("servo.actuator_resolution", res, n)
        self._plan, self._plan_key = np.zeros(0), b""  # the joints of the last command planned

    @classmethod
    def from_settings(
        cls,
        cfg: Any,
        robot: RobotModel,
        eye: EyeModel | None = None,
        dt: float = 1e-3,
        servo: Any | None = None,
        **extra: Any,
    ) -> QpSolver:
        """From MethodSettings (K, damping, tolerance, extra); `extra` adds or overrides keys."""
        options: dict[str, Any] = {**dict(cfg.extra), **extra}
        backend = str(options.pop("solver", DEFAULT_BACKEND))
        limits = QpLimits.from_extra(options)
        return cls(robot, eye, dt, tuple(cfg.K), cfg.damping, cfg.tolerance, limits, backend,
                   servo)  # fmt: skip

    # --- the Solver protocol ---------------------------------------------------------------
    def error(self, robot: RobotModel, q: FloatArray, lam: float, target: FloatArray) -> FloatArray:
        """The X_ext error a feasible step can still remove, J x* / K, plus with a servo the
        command's lead over the measured pose (see module docstring)."""
        target, q = self.check_target(target), _joints(robot, q)
        plan = self.planned_joints(robot, q)
        step, result = self._solve(robot, plan, lam, target)
        if self.speed_limited(robot, result.x):
            return self.task_error(robot, q, lam, target)
        e = np.asarray(step.task @ result.x / self.K, dtype=float)
        if plan is not q:
            e += self.task_error(robot, q, lam, target) - self._planned_error
        return e

    def speed_limited(self, robot: RobotModel, x: FloatArray) -> bool:
        """True if an actuator moves at its full speed in the step x: the target is still being
        approached, not the closest feasible point (a speed bound only slows the motion, so
        the error it leaves is not one that no feasible motion removes)."""
        m = len(robot.active)
        full = robot.speed[list(robot.active)] * self.dt / SCALE
        return bool(np.any(np.abs(x[:m]) >= (1.0 - SPEED_ACTIVE) * full))

    def tolerance(self) -> FloatArray:
        """(position, angle, angle, position x3); curved: (position x3, angle, position x3)."""
        if self.curved:
            p, a = self.tol
            return np.array([p, p, p, a, p, p, p])
        return self.tol.x_ext()

    def step(
        self, robot: RobotModel, q: FloatArray, lam: float, target: FloatArray, error: FloatArray
    ) -> tuple[FloatArray, float]:
        """The QP's step: joint increments recovered exactly from the actuator increments
        (with a servo: from the measured joints q to the planned command), its RCM box and
        retina margin held on the true kinematics (`rcm_step`: solved again with a narrower
        box or a raised floor, then shortened against the box)."""
        target, q = checked_target(target, self.target_width), _joints(robot, q)
        plan = self.planned_joints(robot, q)
        step, result = self._solve(robot, plan, lam, target)
        dq, dlam = joints_step(robot, step.sliders, result.x, q)
        tol, barrier = self.limits.rcm_tolerance, self._barrier()
        floor, recovery = (0.0, 0.0) if barrier is None else (barrier.margin, barrier.recovery)
        trocar, active, tip_t = target[-3:], list(robot.active), target_tip(target)
        now = gap_now = math.nan  # the distance and the retina gap before the step, if needed
        margin = lift = 0.0  # the box's narrowing and the floor's lift of the last solve
        for _ in range(BOX_TRIES):
            x = q.copy()
            x[active] += dq
            after = needle_distance(robot, x, trocar) if tol > 0.0 else 0.0
            if after > tol and math.isnan(now):
                now = needle_distance(robot, q, trocar)
            gap = math.inf  # where the barrier does not hold its margin
            if barrier is not None:
                tip = robot.tip(x)
                if barrier.floor(tip, tip_t) == barrier.margin:  # on, and no contact target
                    gap = self.eye.distance_to_retina(tip)  # type: ignore[union-attr]
                if gap < barrier.margin and math.isnan(gap_now):
                    gap_now = self.eye.distance_to_retina(robot.tip(q))  # type: ignore[union-attr]
            status, narrower, higher = next_bounds(after, now, gap, gap_now, tol, floor,
                                                   recovery, margin, lift)  # fmt: skip
            if status == HELD:
                return dq, dlam
            if status == STUCK:
                break
            try:
                step, result = self._solve(robot, plan, lam, target, (tol - narrower, higher))
            except QPError:
                break  # the last step that solved stands
            dq, dlam = joints_step(robot, step.sliders, result.x, q)
            margin, lift = narrower, higher
        if tol == 0.0:
            return dq, dlam
        return bounded_step(robot, q, dq, dlam, trocar, tol)  # a second-order part beyond it

    def _barrier(self) -> RetinaBarrier | None:
        """The retina barrier among this solver's limits, or None without an eye."""
        return next((lim for lim in self.rows if isinstance(lim, RetinaBarrier)), None)

    def free_solver(self) -> LimitedTipSolver | LimitedPoseSolver:
        """The free-space solver that holds this QP's actuator travel and speed outside the eye
        (the controller's default for free phases with this solver): the tip's step, or on a
        curved needle whole poses (its arc must pass the trocar)."""
        lim = self.limits
        if self.curved:
            return LimitedPoseSolver(tol=self.tol, dt=self.dt, travel_margin=lim.travel_margin)
        return LimitedTipSolver(self.dt, lim.travel_margin, tol=self.tol, tip_speed=lim.tip_speed)

    # --- helpers ----------------------------------------------------------------------------
    def planned_joints(self, robot: RobotModel, q: FloatArray) -> FloatArray:
        """The joints a step is planned from: q itself, or with a servo the joints of the
        plant's last command rounded to its resolution."""
        if self.servo is None:
            return q
        command = np.asarray(self.servo.command, dtype=float)
        s = command
        if self._resolution is not None:  # the command as the plant rounds it
            s = np.empty(command.shape[0])
            quantised(command, self._resolution, s)
        key = s.tobytes()
        if key != self._plan_key:  # `error` and `step` ask in turn for the same command
            self._plan, self._plan_key = robot.joints_from_actuators(s), key
        return self._plan

    def task_error(
        self, robot: RobotModel, q: FloatArray, lam: float, target: FloatArray
    ) -> FloatArray:
        """The plain X_ext (or X_c) error, target minus its value now."""
        if self.curved:
            return curved_error(CURVED_TASKS, robot, q, lam, target)
        return np.asarray(target - extended_task(robot, q, lam), dtype=float)

    def _solve(
        self,
        robot: RobotModel,
        q: FloatArray,
        lam: float,
        target: FloatArray,
        held: tuple[float, float] | None = None,
    ) -> tuple[StepQP, QpResult]:
        """Build and solve this state's QP once; `error` and `step` share the result. With
        `held` = (RCM tolerance [m], retina lift [m]) in place of the limits' tolerance and on
        top of the barrier's margin (a narrower box, a raised floor: `step`), solved anew and
        not kept."""
        key = np.concatenate([q, [lam], target]).tobytes()
        if held is None and self.last is not None and key == self._key:
            return self.last
        e = self.task_error(robot, q, lam, target)
        inp = StepInput(q, lam, target, e, self.K, self.damping, self.dt, self.weights)
        rows = self.rows if held is None else self._held_rows(*held)
        step = build_step(robot, inp, rows, self.bounds, self.objectives)
        if self.servo is not None:
            step = synchronised_step(robot, step, self.dt)
        result = solve(step.problem, self.backend)
        if held is None:
            self._planned_error = e
            self.last, self._key = (step, result), key
        return step, result

    def _held_rows(self, rcm_tolerance: float, lift: float) -> tuple[Limit, ...]:
        """The solver's limits with the RCM box's tolerance `rcm_tolerance` [m] and the retina
        barrier's margin raised by `lift` [m]."""
        rows: list[Limit] = [RcmLimit(rcm_tolerance)]
        for lim in self.rows[1:]:
            if lift > 0.0 and isinstance(lim, RetinaBarrier):
                lim = replace(lim, margin=min(lim.margin + lift, MAX_MARGIN))
            rows.append(lim)
        return tuple(rows)

    def check_target(self, target: FloatArray, pose: bool = True) -> FloatArray:
        """Refuse a target no feasible motion reaches, before moving towards it; return it as
        a float64 array.

        Pose within slider travel and the singular range (solve_pose; skipped with
        `pose=False`, for a target whose pose the caller has checked), and with an eye the
        target tip inside the eye (on or within the retina) and in front of the trocar.
        InvalidInputError unless the target is (6,) finite numbers ((7,) on a curved needle).
        """
        target = checked_target(target, self.target_width)
        key = target.tobytes()
        if key in self._checked:
            return target
        if pose and self.curved:  # each check continues from the last pose: the last is kept
            self._seed = solve_curved_pose(self.robot, target, self._seed).q
            self._checked.clear()
        elif pose:
            solve_pose(self.robot, target)
        if self.eye is not None:
            tip = target_tip(target)
            depth = self.eye.distance_to_retina(tip)
            if depth < -self.limits.contact_tolerance and not self._in_port(tip):
                raise UnreachableTargetError(
                    f"the target tip lies {1e3 * -depth:.3f} mm beyond the retina; the QP "
                    "keeps the tip inside the eye",
                    target,
                )
        self._checked.add(key)
        return target

    def check_targets(self, targets: FloatArray) -> None:
        """The QP's own check of a phase's targets (N, 6), which a `Controller` makes before
        motion after it has checked every target's pose itself (`Controller.check_targets`):
        `check_target` without the pose search; the targets then count as checked."""
        for t in np.atleast_2d(targets):
            self.check_target(t, pose=False)

    def _in_port(self, tip: FloatArray) -> bool:
        eye = self.eye
        return eye is not None and bool(np.linalg.norm(tip - eye.port) <= self.limits.port_zone)


def _joints(robot: RobotModel, q: Any) -> FloatArray:
    """q as a float64 array of the robot's joints (NaN shows in the robot's results)."""
    n = len(robot.home)
    if q.__class__ is np.ndarray and q.dtype is F64 and q.shape == (n,):
        return q
    return vector("q", q, n)


def synchronised_step(robot: RobotModel, step: StepQP, dt: float) -> StepQP:
    """The step's QP tracking K e / sigma instead of K e, sigma >= 1 the largest fraction of
    an actuator's speed window that the unconstrained optimum x = -P^-1 q would use: a
    straight, synchronised sub-goal along the way to the target, as the plant's servo
    reference moves (`sim.mujoco.actuators.velocity_into`, ramp 0); the unconstrained optimum
    then just fits the window.

    Tracking K e itself, a step that cannot reach the target within the window spends its
    window on whatever error it reduces fastest (on iRAM!S: a retraction tilts the needle by up
    to 0.1 mrad and back, slider reversals at full speed); a servo reference with bounded
    acceleration cannot follow such reversals, and leaves the commanded (RCM-holding) path.
    Only the linear cost term changes (it is linear in e); the limits are untouched.
    """
    speed = np.ascontiguousarray(robot.speed[list(robot.active)], dtype=np.float64)
    f = np.array(step.problem.q, dtype=np.float64)
    H = np.ascontiguousarray(step.problem.P, dtype=np.float64)
    if synchronise(H, f, speed, dt, np.empty((f.shape[0] + 1, f.shape[0]))) <= 1.0:
        return step
    return replace(step, problem=replace(step.problem, q=f))


def make_qp(
    robot: RobotModel, eye: EyeModel | None = None, dt: float = 1e-3, **options: Any
) -> QpSolver:
    """A QpSolver with default settings and unit-suffixed options (as in a scenario's [qp])."""
    from rcmplan.control.method_settings import MethodSettings

    return QpSolver.from_settings(MethodSettings(), robot, eye, dt, **options)


def joints_step(
    robot: RobotModel, sliders: FloatArray, x: FloatArray, q: FloatArray
) -> tuple[FloatArray, float]:
    """The step of a QP solution x at actuators `sliders`: (joint increments of the active
    joints from q, recovered exactly from the actuators moved by x, d lambda)."""
    active = list(robot.active)
    m = len(active)
    s = np.array(sliders, dtype=float)
    s[active] += x[:m] * SCALE
    dq = robot.joints_from_actuators(s) - q
    return dq[active], float(x[m] * SCALE / robot.needle_length)
