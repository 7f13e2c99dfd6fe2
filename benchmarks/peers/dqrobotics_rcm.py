"""The iRAM!S visits p3 -> p4..p7 -> p3 controlled with DQ Robotics: the peer of rcmplan's QP.

What DQ Robotics does here, as its users would use it:
- the robot is a `DQ_SerialManipulatorDH` built from the iRAM!S standard-DH table (thesis
  Table 2.1, `Iramis.dh_links`): joints q0..q5, the needle tip is the end effector and the
  effector's z axis the needle axis;
- every control step takes `fkm`, `pose_jacobian`, `translation_jacobian` (the tip) and
  `line_jacobian` (the needle as a Plücker line l + E_ m along the effector's z) from it;
- the RCM: the needle line's moment about the trocar c, m_c = m - c x l, whose norm is the
  trocar's distance to the line, with its Jacobian from the line Jacobian; two components
  normal to the needle kept in a box of half-width tol / sqrt(2) (rcmplan's RCM box);
- the retina margin: the tip's distance to the eye centre from `DQ_Geometry` and
  `point_to_point_distance_jacobian`, as a velocity damper (a vector-field inequality);
- the QP is solved by `DQ_QuadprogSolver` (quadprog).

rcmplan supplies what DQ Robotics has no model for: the PCJM slider map
(`Iramis.actuators_from_joints` and its Jacobian), the eye, the targets and the start pose.

Made equivalent to rcmplan's QP (`rcmplan.control.qp`, docs/qp.md):
- the same start (the exact p3 pose), targets (the default injection's visit phases) and
  control period (1 ms), on a kinematic plant (the joints reach each command);
- the objective: tip position and needle direction error, gain K = 1, rcmplan's angle weight
  (10 mm per rad, the direction rows being unit-vector components, radians to first order) and
  damping (1e-4 on the variables in um and urad);
- limits of the same sizes, read from rcmplan's `QpLimits` defaults: RCM 0.5 um; slider speed
  10 mm/s over the period and travel with the 0.5 mm margin, through ds/dq of the PCJM map at
  the current state (linear: a slider may exceed its 10 um by a second-order term, which
  rcmplan's violation counter reports); retina margin 0.25 mm at gain 0.5, off in the 2 mm
  port zone, lowered to a contact target's depth, recovering at most 1 um per step when past
  it (all as rcmplan's `RetinaBarrier`); singular floor cos q1, cos q3 >= 0.15 as joint limits
  on q1 and q3 approached at gain 0.5;
- the termination rule of rcmplan's QP (Algorithm 1 with `QpSolver.error`): a target is done
  when the error a feasible step can still remove, J dq* / K, is within 10 nm per tip
  coordinate and 1e-7 per direction component (rcmplan: 1e-7 rad per needle angle).

Differences that remain: rcmplan's variables are slider increments and the RCM's lambda, here
the joint increments of q0..q4 (DQ Robotics works in joint space; the needle roll q5 stays
still in both); lambda in [0, 1] is not a constraint here (the trocar stays between needle
base and tip on these visits: the violation counter checks).

DQ Robotics' own RCM inequality, `line_to_point_distance_jacobian` on the squared distance D
(J_D dq <= eta (tol^2 - D)), is `rcm_form="squared"` (`python
benchmarks/peers/dqrobotics_rcm.py --rcm squared`). It does not finish this task: its gradient
vanishes on the line, so with a 0.5 um safe distance the second-order part of a step (the
needle turns up to about 60-75 urad per period, moving the line about 0.6 um at the trocar)
outweighs the linear model. At the first waypoint held off by the retina margin (p3-p4 target
73) the step alternates in sign with the trocar 2.3 um off the line (eta = 1; 3.5 um with
eta = 0.1) and the target is not done within 100 iterations.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from dqrobotics import DQ, E_, conj, cross, k_, rotation, translation, vec4
from dqrobotics.robot_modeling import DQ_Kinematics, DQ_SerialManipulatorDH
from dqrobotics.solvers import DQ_QuadprogSolver
from dqrobotics.utils import DQ_Geometry

from rcmplan import Iramis
from rcmplan.control.limits.base import RECOVERY
from rcmplan.control.limits.rcm import normal_basis
from rcmplan.control.log import RunLog
from rcmplan.control.phase import Phase
from rcmplan.control.qp_limits import QpLimits
from rcmplan.control.solvers import Tolerance
from rcmplan.control.targets import target_tip
from rcmplan.robot.needle import axis_from_angles
from rcmplan.scene.eye import Eye

SCALE = 1e-6  # [m] or [rad] per unit of the QP variables (um, urad), as in rcmplan's QP
ACTIVE = 5  # q0..q4 move; the roll q5 moves no point of the straight needle
RCM_FORMS = ("moment", "squared")


def damper_room(gap: float, gain: float) -> float:
    """How far [m] a distance kept below a bound may grow in one step, `gap` the room left:
    `gain` of it; past the bound (gap < 0) it must shrink, by up to RECOVERY per step (rcmplan's
    `damper_row`, so that a limit already passed never makes the QP infeasible)."""
    return gain * gap if gap >= 0.0 else max(gain * gap, -RECOVERY)


def dh_matrix(robot: Iramis) -> np.ndarray:
    """DQ Robotics' standard-DH matrix (5, 6): rows theta, d, a, alpha, joint type (0 revolute,
    1 prismatic), from `robot.dh_links()` (thesis Table 2.1, lengths in m, angles in rad)."""
    links = robot.dh_links()
    return np.array(
        [
            [lk.theta for lk in links],
            [lk.d for lk in links],
            [lk.a for lk in links],
            [lk.alpha for lk in links],
            [1.0 if lk.joint == "prismatic" else 0.0 for lk in links],
        ]
    )


def dq_point(p: np.ndarray) -> DQ:
    """A point (3,) in [m] as DQ Robotics' pure quaternion."""
    return DQ([0.0, float(p[0]), float(p[1]), float(p[2])])


class Goal(NamedTuple):
    """What one rcmplan X_ext target asks for: the tip (3,) [m], the unit needle axis (3,), the
    trocar as a DQ point, and the retina floor [m] for this target."""

    tip: np.ndarray
    axis: np.ndarray
    trocar: DQ
    floor: float


class Step(NamedTuple):
    """One step's solution: joint increments dq (5,) of q0..q4 in [m] / [rad], and the error a
    feasible step can still remove, J dq / K (6,): tip [m], needle direction (unit vector)."""

    dq: np.ndarray
    removable: np.ndarray


@dataclass
class DqRun:
    """A run's records, one per control iteration (the state reached after each step).

    Attributes:
        joints: (N, 6) joints q [m, rad]. target_tip, trocar: (N, 3) in [m].
        phase: (N,) phase index into `phase_names`. step: (N,) target index within the phase.
        step_times: (M,) wall time [s] of every `DqRcmController.step` call (kinematics,
            assembly and solve), including the final check of each target.
        wall_time: Wall time [s] of the whole run (loop included).
    """

    joints: np.ndarray
    target_tip: np.ndarray
    trocar: np.ndarray
    phase: np.ndarray
    step: np.ndarray
    phase_names: tuple[str, ...]
    step_times: np.ndarray
    wall_time: float

    def __len__(self) -> int:
        return int(self.joints.shape[0])

    def log(self, robot: Iramis) -> RunLog:
        """The records as an rcmplan RunLog (sliders from the PCJM map, the RCM point the needle
        point closest to the trocar, lambda unclamped), for rcmplan's metrics and counters."""
        n = len(self)
        sliders = np.array([robot.actuators_from_joints(q) for q in self.joints])
        base = np.array([robot.needle_base(q) for q in self.joints])
        tip = np.array([robot.tip(q) for q in self.joints])
        axis = tip - base
        lam = np.sum((self.trocar - base) * axis, axis=1) / np.sum(axis * axis, axis=1)
        period = np.arange(1, n + 1, dtype=np.float64) * 1e-3  # records 1 ms apart
        return RunLog(
            time=period, sliders=sliders, joints=self.joints, lam=lam, tip=tip,
            rcm=base + lam[:, None] * axis, trocar=self.trocar, base=base,
            target_tip=self.target_tip, error=np.full((n, 6), np.nan), step=self.step,
            iteration=np.zeros(n, dtype=np.int64), solver=np.zeros(n, dtype=np.int64),
            phase=self.phase, phase_names=self.phase_names, solver_names=("dqrobotics-qp",),
        )  # fmt: skip


class Needle(NamedTuple):
    """The needle at one state, from the DQ model: tip p (DQ), the Plücker line l + E_ m (DQ),
    the translation Jacobian (4, 6) and line Jacobian (8, 6) over q0..q5, the tip (3,) [m] and
    the unit axis l (3,)."""

    p: DQ
    line: DQ
    Jt: np.ndarray
    Jl: np.ndarray
    tip: np.ndarray
    axis: np.ndarray


def trocar_moment(
    Jl: np.ndarray, line: DQ, axis: np.ndarray, trocar: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The needle line's moment about the trocar c (3,) [m], m_c = m - c x l (3,) [m], normal
    to the axis l with |m_c| the trocar's distance to the line, and its Jacobian (3, 5) over
    q0..q4 from the line Jacobian Jl (8, n): d m - c x d l."""
    m_c = vec4(line.D())[1:] - np.cross(trocar, axis)
    J_l, J_m = Jl[1:4, :ACTIVE], Jl[5:8, :ACTIVE]
    return m_c, J_m - np.cross(trocar, J_l, axisb=0, axisc=0)


class DqRcmController:
    """RCM-constrained needle control of iRAM!S with DQ Robotics and quadprog (module docstring).

    Args:
        robot: The iRAM!S model (DH table, slider map, travel and speed).
        eye: The eye (trocar, retina).
        dt: Control period in [s].
        limits: Sizes of the limits (rcmplan's QpLimits defaults).
        gain: Task gain K per period, in (0, 2).
        damping: Damping D on the variables in um and urad.
        tol: Termination tolerance: 10 nm on tip rows, 1e-7 on direction rows by default.
        rcm_form: "moment" (the default, see the module docstring) or "squared".
        rcm_gain: eta of the "squared" RCM inequality per period.
        max_iterations: Iteration cap per target.
    """

    def __init__(
        self,
        robot: Iramis,
        eye: Eye,
        dt: float = 1e-3,
        limits: QpLimits | None = None,
        gain: float = 1.0,
        damping: float = 1e-4,
        tol: Tolerance | None = None,
        rcm_form: str = "moment",
        rcm_gain: float = 1.0,
        max_iterations: int = 100,
    ) -> None:
        if rcm_form not in RCM_FORMS:
            raise ValueError(f"rcm_form {rcm_form!r}: one of {RCM_FORMS}")
        self.rcm_form = rcm_form
        self.robot, self.eye, self.dt = robot, eye, dt
        self.limits = lim = limits or QpLimits()
        self.kin = DQ_SerialManipulatorDH(dh_matrix(robot))
        self.qp = DQ_QuadprogSolver()
        self.gain, self.damping, self.rcm_gain = gain, damping, rcm_gain
        self.max_iterations = max_iterations
        t = tol or Tolerance()
        self.tolerance = np.array(3 * [t.position] + 3 * [t.angle])
        self.weight = np.array(3 * [1.0] + 3 * [lim.angle_weight])
        self.center = dq_point(eye.center)
        self.q_max = math.acos(lim.singular_floor(robot))  # |q1|, |q3| below it
        self.lower = robot.lower[:ACTIVE] + lim.travel_margin
        self.upper = robot.upper[:ACTIVE] - lim.travel_margin
        self.reach = robot.speed[:ACTIVE] * dt

    def goal(self, target: np.ndarray) -> Goal:
        """The tip, needle axis, trocar and retina floor an X_ext target (6,) asks for."""
        tip = target_tip(target)
        floor = self.limits.retina_margin
        depth = self.eye.distance_to_retina(tip)
        if abs(depth) <= self.limits.contact_tolerance:  # a contact: rcmplan's RetinaBarrier
            floor = min(floor, max(depth, 0.0))
        axis = axis_from_angles(target[1], target[2])
        return Goal(tip, axis, dq_point(target[3:]), floor)

    def needle(self, q: np.ndarray) -> Needle:
        """The needle at joints q (6,) from the DQ model: fkm, pose, translation and line
        Jacobians."""
        x = self.kin.fkm(q)
        J = self.kin.pose_jacobian(q)
        p = translation(x)
        r = rotation(x)
        direction = r * k_ * conj(r)
        return Needle(
            p, direction + E_ * cross(p, direction), DQ_Kinematics.translation_jacobian(J, x),
            DQ_Kinematics.line_jacobian(J, x, k_), vec4(p)[1:], vec4(direction)[1:],
        )  # fmt: skip

    def step(self, q: np.ndarray, goal: Goal) -> Step:
        """The QP of one control step at joints q (6,), solved with DQ_QuadprogSolver."""
        p, line, Jt, Jl, tip, axis = self.needle(q)

        # Objective 1/2 |W (task x SCALE - K e)|^2 / SCALE^2 + 1/2 D^2 |x|^2, x in um / urad.
        task = np.vstack([Jt[1:4, :ACTIVE], Jl[1:4, :ACTIVE]])
        Aw = self.weight[:, None] * task
        e = np.concatenate([goal.tip - tip, goal.axis - axis])
        H = Aw.T @ Aw + self.damping**2 * np.eye(ACTIVE)
        f = -Aw.T @ (self.weight * self.gain * e / SCALE)

        # Slider speed and travel through ds/dq of the PCJM map at this state (5 sliders).
        S = self.robot.actuators_from_joints_jacobian(q)[:ACTIVE, :ACTIVE]
        s = self.robot.actuators_from_joints(q)[:ACTIVE]
        up = np.minimum(self.reach, np.maximum(self.upper - s, 0.0)) / SCALE
        down = np.minimum(self.reach, np.maximum(s - self.lower, 0.0)) / SCALE
        rows, rhs = [S, -S], [up, down]

        if self.rcm_form == "moment":
            rows_rcm, rhs_rcm = self._rcm_moment(Jl, line, axis, goal)
        else:
            rows_rcm, rhs_rcm = self._rcm_squared(Jl, line, goal)
        rows.append(rows_rcm)
        rhs.append(rhs_rcm)

        # Retina: the tip's distance from the eye centre below radius - floor, except in the
        # port zone; DQ's squared-distance Jacobian over 2 |p - c| is the distance's gradient.
        if np.linalg.norm(tip - self.eye.port) > self.limits.port_zone:
            rho = self.eye.retina_radius - goal.floor
            dist = math.sqrt(DQ_Geometry.point_to_point_squared_distance(p, self.center))
            Jc = DQ_Kinematics.point_to_point_distance_jacobian(Jt, p, self.center)[:, :ACTIVE]
            rows.append(Jc / (2.0 * dist))  # [m] of distance per unit of x, times 1 / SCALE
            rhs.append(np.array([damper_room(rho - dist, self.limits.eye_gain) / SCALE]))

        # Singular floor: |q1|, |q3| <= acos(floor), approached at singular_gain.
        g = self.limits.singular_gain
        Q = np.zeros((4, ACTIVE))
        Q[0, 1], Q[1, 1], Q[2, 3], Q[3, 3] = 1.0, -1.0, 1.0, -1.0
        rows.append(Q)
        rhs.append(g * np.array([self.q_max - q[1], self.q_max + q[1],
                                 self.q_max - q[3], self.q_max + q[3]]) / SCALE)  # fmt: skip

        xs = self.qp.solve_quadratic_program(H, f, np.vstack(rows), np.concatenate(rhs), None, None)
        return Step(xs * SCALE, task @ xs * SCALE / self.gain)

    def _rcm_moment(
        self, Jl: np.ndarray, line: DQ, axis: np.ndarray, goal: Goal
    ) -> tuple[np.ndarray, np.ndarray]:
        """The RCM as two components of `trocar_moment` normal to the needle, each kept within
        tol / sqrt(2) (4 rows, in um per unit of x)."""
        m_c, J_mc = trocar_moment(Jl, line, axis, vec4(goal.trocar)[1:])
        N = np.empty((2, 3))
        normal_basis(np.ascontiguousarray(axis, dtype=np.float64), N)
        box = self.limits.rcm_tolerance / math.sqrt(2.0)
        G = N @ J_mc  # [m] of m_c per unit of x, times 1 / SCALE
        r = N @ m_c
        return np.vstack([G, -G]), np.concatenate([box - r, box + r]) / SCALE

    def _rcm_squared(self, Jl: np.ndarray, line: DQ, goal: Goal) -> tuple[np.ndarray, np.ndarray]:
        """The RCM as DQ Robotics' vector-field inequality on the squared line-to-point distance
        D: J_D dq <= eta (tol^2 - D) (1 row, in um^2)."""
        D = DQ_Geometry.point_to_line_squared_distance(goal.trocar, line)
        Jd = DQ_Kinematics.line_to_point_distance_jacobian(Jl, line, goal.trocar)[:, :ACTIVE]
        D_safe = self.limits.rcm_tolerance**2
        return Jd / SCALE, np.array([self.rcm_gain * (D_safe - D) / SCALE**2])

    def run(self, q0: np.ndarray, phases: Sequence[Phase]) -> DqRun:
        """Algorithm 1 on every X_ext target of each phase (with a target array) in turn, from
        joints q0 (6,); raises RuntimeError if a target is not done within the iteration cap."""
        q = np.array(q0, dtype=float)
        joints, tips, trocars, pids, steps, times = [], [], [], [], [], []
        start = time.perf_counter()
        for pid, phase in enumerate(phases):
            for k, target in enumerate(phase.plan(q)):
                goal = self.goal(target)
                for it in range(self.max_iterations + 1):
                    t0 = time.perf_counter()
                    st = self.step(q, goal)
                    times.append(time.perf_counter() - t0)
                    if it > 0:
                        joints.append(q.copy())
                        tips.append(goal.tip)
                        trocars.append(target[3:])
                        pids.append(pid)
                        steps.append(k)
                    if (np.abs(st.removable) <= self.tolerance).all():
                        break
                    if it == self.max_iterations:
                        raise RuntimeError(
                            f"phase {phase.name!r} target {k}: removable error "
                            f"{np.abs(st.removable).max():.3g} after {it} iterations"
                        )
                    q[:ACTIVE] += st.dq
        return DqRun(
            np.array(joints), np.array(tips), np.array(trocars), np.array(pids, dtype=np.int64),
            np.array(steps, dtype=np.int64), tuple(ph.name for ph in phases), np.array(times),
            time.perf_counter() - start,
        )  # fmt: skip


def main() -> None:
    """Run the peer alone on the visits and print its figures (or where it stopped)."""
    import argparse
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from peers.visits import visits
    from rcmplan.analysis.limits import violations

    parser = argparse.ArgumentParser(description=main.__doc__)
    parser.add_argument("--rcm", choices=RCM_FORMS, default="moment", help="RCM rows")
    parser.add_argument("--eta", type=float, default=1.0, help="eta of the squared form")
    args = parser.parse_args()
    task = visits()
    peer = DqRcmController(task.robot, task.eye, rcm_form=args.rcm, rcm_gain=args.eta)
    try:
        run = peer.run(task.q0, task.phases)
    except RuntimeError as exc:
        print(f"stopped: {exc}")
        return
    log = run.log(task.robot)
    print(f"{len(run)} iterations in {run.wall_time:.2f} s; step median "
          f"{1e6 * np.median(run.step_times):.1f} us; max RCM deviation "
          f"{1e6 * np.max(log.line_distance()):.4f} um")  # fmt: skip
    print(violations(log, task.robot, task.eye))


if __name__ == "__main__":
    main()
