"""The control loops of the thesis: Algorithm 1 (converge on one target) and Algorithm 2 (walk a
far target in equal steps), run against any plant.

Departures from the thesis, each measured in the benchmarks:
- Tolerances are per unit (metres and radians apart); Algorithm 1's single 0.0002 mixed them.
- Algorithm 2 splits a move into N equal steps with N set by the largest component relative to
  its step size (metres and radians apart); the thesis added sign(distance) * step_size to every
  component, which moves components by the same number whatever their unit.
- Drift correction (thesis chapter 5): before each iteration the RCM is re-declared as the needle
  point closest to the trocar (lambda updated). Switchable.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.compiled.runner import CompiledRunner
from rcmplan.control.checks import check_controller_args
from rcmplan.control.log import LogBuilder, RunLog
from rcmplan.control.phase import (
    LoopSettings,
    Phase,
    check_phases,
    check_plan_size,
)
from rcmplan.control.plant import Plant
from rcmplan.control.qp import QpSolver
from rcmplan.control.rcm_step import bounded_step
from rcmplan.control.runner import Runner, registered_default
from rcmplan.control.solvers import Solver, TipSolver
from rcmplan.control.targets import solve_pose, target_tip, target_tips
from rcmplan.exceptions import (
    ConvergenceError,
    InvalidInputError,
    RcmBoundError,
    RcmplanError,
    UnreachableTargetError,
)
from rcmplan.robot.model import RobotModel
from rcmplan.robot.needle import closest_lambda

NAN3 = np.full(3, np.nan)
_COMPILED = CompiledRunner()  # every phase a kernel implements runs compiled

__all__ = ["Controller"]


class Controller:
    """Runs phases of targets on a plant with an RCM solver and a free-space solver.

    Args:
        plant: Any Plant.
        solver: Step solver for RCM phases.
        free_solver: Step solver for free-space phases (default: the RCM solver's own
            `free_solver()` if it has one, as the QP does to hold its limits in every phase,
            else the tip pseudoinverse).
        settings: Loop settings.
        runner: Runs phases in compiled code where it applies (default: the compiled runner,
            `rcmplan.compiled.runner`); see `control.runner`.
        robot: The model the controller drives, with the plant's actuators (default: the
            plant's own; a curved needle's model on a plant built for its shaft).
    """

    def __init__(
        self,
        plant: Plant,
        solver: Solver,
        free_solver: Solver | None = None,
        settings: LoopSettings | None = None,
        runner: Runner | None = None,
        robot: RobotModel | None = None,
    ) -> None:
        check_controller_args(plant, solver, free_solver, settings, runner, robot)
        self.plant = plant
        self.robot: RobotModel = robot or plant.robot
        self.solver = solver
        if isinstance(solver, QpSolver):  # it plans from the plant's command if servos follow it
            solver.follow(plant)
        own = getattr(solver, "free_solver", None)
        self.free_solver: Solver = free_solver or (own() if own is not None else TipSolver())
        self.settings = settings or LoopSettings()
        self._runner = runner
        self.lam = 1.0
        self.log = LogBuilder.for_robot(self.robot)
        self.phase_times: dict[str, float] = {}
        # Per phase, the code that ran its motion: "compiled" (the runner ran it), "reference"
        # (the Python loop), or "mixed" (a phase name run more than once, on both).
        self.phase_paths: dict[str, str] = {}
        self._planned = 0  # targets planned so far in this run (at most MAX_TARGETS)
        self._check_seed: FloatArray | None = None
        self.on_phase: Callable[[Phase], None] | None = None

    @property
    def runner(self) -> Runner:
        """The runner given, else the registered default, else the compiled runner."""
        return self._runner or registered_default() or _COMPILED

    def check_targets(self, targets: FloatArray) -> None:
        """Refuse, before motion, RCM targets the robot cannot realise (closed-form pose), and
        those the solver's own limits refuse (a solver may define `check_targets`)."""
        if targets.shape[1] == 7:
            self._check_curved_targets(targets)
        elif not self.runner.check_targets(self.robot, targets):
            seed = None  # each target's pose search starts from the last one's (arms: Newton)
            for target in targets:
                seed = solve_pose(self.robot, target, seed).q
        solver_check = getattr(self.solver, "check_targets", None)
        if solver_check is not None:
            solver_check(targets)

    def _check_phase_targets(self, name: str, targets: FloatArray) -> None:
        """`check_targets` on a phase's targets; a refusal names the phase and the target
        (its first row equal to the refused target, counted from 0)."""
        try:
            self.check_targets(targets)
        except UnreachableTargetError as exc:
            where = f"phase {name!r}"
            if exc.target is not None and np.shape(exc.target) == targets.shape[1:]:
                rows = np.flatnonzero(np.all(targets == np.asarray(exc.target), axis=1))
                if rows.size:
                    where += f", target {rows[0]} of 0..{len(targets) - 1}"
            raise exc.restated(f"{where}: {exc.reason}") from exc

    def _check_curved_targets(self, targets: FloatArray) -> None:
        """A curved needle's poses are found by Newton's method: each target's solve continues
        from the last target's joints, across phases."""
        seed = self.runner.check_curved_targets(self.robot, targets, self._check_seed)
        if seed is None:
            from rcmplan.control.curved_targets import solve_curved_pose

            seed = self._check_seed
            for target in targets:
                seed = solve_curved_pose(self.robot, target, seed).q
        self._check_seed = seed

    def run(self, phases: list[Phase]) -> RunLog:
        """Run every phase; on any error the partial log is attached to the exception.

        Phases with target arrays are all checked before any motion; a planned phase is checked
        when it is planned, before its own motion.
        """
        phases = check_phases(phases)
        try:
            sizes = [len(ph.targets) for ph in phases if not callable(ph.targets)]
            self._planned = check_plan_size(sum(sizes), "targets of the run")
            for ph in phases:
                if ph.kind == "rcm" and not callable(ph.targets):
                    self._check_phase_targets(ph.name, ph.plan(self.robot.home))
            for ph in phases:
                self.run_phase(ph)
                if self.on_phase is not None:
                    self.on_phase(ph)
        except (RcmplanError, KeyboardInterrupt) as exc:
            exc.log = self.log.finish()  # type: ignore[union-attr]
            raise
        return self.log.finish()

    def run_phase(self, phase: Phase) -> None:
        """Algorithm 2: Algorithm 1 on each target of the phase in turn."""
        if phase.kind not in ("rcm", "free"):
            raise InvalidInputError("phase.kind", phase.kind, "'rcm' or 'free'")
        solver = self.solver if phase.kind == "rcm" else self.free_solver
        pid = self.log.phase_id(phase.name)
        sid = self.log.solver_id(solver.name)
        start = time.perf_counter()
        try:
            q = self.robot.joints_from_actuators(self.plant.read_actuators())
            targets = phase.plan(q)
            width = getattr(solver, "target_width", 6 if phase.kind == "rcm" else 3)
            if targets.ndim != 2 or targets.shape[1] != width:
                raise InvalidInputError(
                    f"targets of phase {phase.name!r}", targets.shape, f"shape (N, {width})"
                )
            if callable(phase.targets):
                self._planned += len(targets)
                check_plan_size(self._planned, "targets of the run")
            if phase.kind == "rcm":
                if callable(phase.targets):
                    self._check_phase_targets(phase.name, targets)
                self._check_target_steps(phase.name, q, targets)
                self.lam = self._closest_lambda(q, targets[0][-3:])
            first = len(self.log)
            try:
                try:
                    ran = self.runner.run_phase(self, solver, targets, pid, sid)
                except BaseException:
                    if len(self.log) > first:  # stopped in the runner's code, after moving
                        self._note_path(phase.name, "compiled")
                    raise
                self._note_path(phase.name, "compiled" if ran else "reference")
                if not ran:
                    for k, target in enumerate(targets):
                        self.converge(solver, target, pid, sid, k)
            except KeyboardInterrupt:
                raise  # an interrupt is reported as such, the bound unchecked
            except BaseException:
                self._check_rcm_bound(phase.name, first)
                raise
            self._check_rcm_bound(phase.name, first)
        finally:
            spent = time.perf_counter() - start
            self.phase_times[phase.name] = self.phase_times.get(phase.name, 0.0) + spent

    def _note_path(self, name: str, path: str) -> None:
        before = self.phase_paths.get(name, path)
        self.phase_paths[name] = path if before == path else "mixed"

    def _check_target_steps(self, name: str, q: FloatArray, targets: FloatArray) -> None:
        """Refuse an RCM phase whose target tips jump farther than `max_target_step`, from the
        needle's tip to the first or between consecutive ones (a pivot's tip stays at the
        trocar)."""
        bound = self.settings.max_target_step
        if bound is None:
            return
        tips = target_tips(targets)
        jumps = np.linalg.norm(np.diff(np.vstack([self.robot.tip(q), tips]), axis=0), axis=1)
        k = int(np.argmax(jumps))
        if jumps[k] > bound:
            where = "the needle's tip to target 0" if k == 0 else f"target {k - 1} to {k}"
            raise InvalidInputError(
                f"targets of phase {name!r}",
                f"a {1e3 * jumps[k]:.3f} mm jump from {where}",
                f"steps of at most {1e3 * bound:g} mm (make them with split_steps, or raise "
                "LoopSettings.max_target_step)",
            )

    def _check_rcm_bound(self, name: str, first: int) -> None:
        """Raise RcmBoundError if a record from `first` on has the RCM beyond the bound (both
        paths check the same records, after the phase or where it stopped)."""
        bound = self.settings.rcm_bound
        if bound is None or len(self.log) == first:
            return
        worst = self.log.max_rcm_deviation(first)
        if worst > bound:
            raise RcmBoundError(name, worst, bound)

    def _closest_lambda(self, q: FloatArray, trocar: FloatArray) -> float:
        return closest_lambda(
            self.robot.needle_point(q, 0.0), self.robot.needle_point(q, 1.0), trocar
        )

    def converge(self, solver: Solver, target: FloatArray, pid: int, sid: int, step: int) -> int:
        """Algorithm 1: iterate until every error component is within its tolerance."""
        robot, plant, cfg = self.robot, self.plant, self.settings
        tol = solver.tolerance()
        rcm = solver.kind == "rcm"
        trocar = target[-3:] if rcm else NAN3
        goal_tip = target_tip(target, solver.kind)
        active = list(robot.active)
        for it in range(cfg.max_iterations + 1):
            s = plant.read_actuators()
            q = robot.joints_from_actuators(s)
            base, end = robot.needle_point(q, 0.0), robot.needle_point(q, 1.0)
            if rcm and cfg.drift_correction:
                self.lam = closest_lambda(base, end, trocar)
            e = solver.error(robot, q, self.lam, target)
            if it > 0:
                self._record(s, q, base, end, trocar, goal_tip, e, step, it, sid, pid)
            if (np.abs(e) <= tol).all():
                return it
            if it == cfg.max_iterations:
                break
            robot.check_singularity(q, cfg.singular_threshold)
            dq, dlam = solver.step(robot, q, self.lam, target, e)
            if rcm and cfg.rcm_tolerance is not None:
                dq, dlam = bounded_step(robot, q, dq, dlam, trocar, cfg.rcm_tolerance)
            q_new = q.copy()
            q_new[active] += dq
            self.lam += dlam
            plant.command_actuators(robot.actuators_from_joints(q_new))
            plant.advance()
        raise ConvergenceError(
            cfg.max_iterations,
            np.abs(e),
            tol,
            where=f"phase {self.log.phase_names[pid]!r} step {step}",
        )

    def _record(
        self, s: FloatArray, q: FloatArray, base: FloatArray, end: FloatArray,
        trocar: FloatArray, target_tip: FloatArray, e: FloatArray,
        step: int, it: int, sid: int, pid: int,
    ) -> None:  # fmt: skip
        """One record; `end` is the needle's (shaft's) end, the tip comes from the model. A
        curved needle's error (tip x3, roll, RCM or needle base x3) goes to the log's six error
        columns and its roll error column; a straight needle's roll error is NaN."""
        err, roll = np.full(6, np.nan), np.nan
        if e.shape[0] == 7:
            err, roll = np.delete(e, 3), e[3]
        else:
            err[: e.shape[0]] = e
        self.log.append(
            time=self.plant.time, sliders=s, joints=q, lam=self.lam, tip=self.robot.tip(q),
            rcm=base + self.lam * (end - base), trocar=trocar, base=base, target_tip=target_tip,
            error=err, roll_error=roll, step=step, iteration=it, solver=sid, phase=pid,
        )  # fmt: skip
