"""One simulated subretinal injection on the RCM controller, under iOCT with motion compensation.

The needle starts inserted through the trocar, `start_height_m` above the target's ILM point.
Every 1 kHz period does what a teleoperated session's period does (`rcmplan.teleop.session`):
read the plant, lambda by `closest_lambda`, the target X_ext (`rcm_targets(tip, trocar)`, for
the periods up to the next iOCT estimate at once: `Episode.plan`), one `QpSolver.step`, command
the plant. Where the compiled QP applies on the kinematic plant the planned periods run as one
compiled call (`episode_blocks`); elsewhere one period at a time (`Episode.period`, its step
compiled by `compiled.qp_period.period_step` where that applies). On a plant whose servos lag
their commands (the dynamic MuJoCo plant) the QP plans each step from the plant's last command
(`QpSolver`'s `servo`, as `rcmplan inject --plant mujoco --method qp` does). The QP holds the RCM,
actuator travel and speed and, as an extra limit, `TissueDepthLimit`: the tip above the
ESTIMATED RPE less `rpe_margin_m`. The QP's retina barrier is off (no eye is given to it): the
needle has to pass the ILM.

The tip target lies on the target's normal n (the ray from the eye centre along `direction`):
p = (R_ilm + d_pred(t) + c(t)) n, with d_pred the compensation's prediction of the ILM
displacement and c(t) the commanded depth below it: a ramp from the start to -standoff
(approach), -standoff (hover), a ramp to the target depth (advance; to `puncture_depth_m` for a
shallower target, then back up to it: withdraw), the target depth (hold), back to -standoff
(retract, settle). The true wall moves with the motion model; the tip's depth
in tissue comes from the tissue model (tenting until puncture). The iOCT estimates (every
1 / rate, delivered `latency_s` after acquisition; `episode_ioct`) are by default segmented
from the B-scan of the true state at the acquisition (`episode_ioct.true_state`: the tip where
the robot held it, the ILM tented as the tissue model had it), rendered when the volume is
delivered; a volume whose segmentation finds no ILM delivers nothing. With
`ioct_estimates="noise"` they are the measured-noise stand-in of `trace.noisy_trace`. They are
fed to the predictor as they arrive; the `warmup_s` of estimates before the approach (the
needle still at its start point) start the predictor (the kalman filter needs 8 s). The depth
limit uses the compensation's prediction, or with `none` the newest estimate (`hold`).

With whole-eye motion on (`eye_drift_m` > 0) the eye translates by T(t) (`motion.eye_translation`,
drawn from its own generator so the wall motion and the iOCT noise of a seed stay the same): its
centre, the retina, the target point and the trocar (fixed in the sclera) all move by T(t).
Each period's RCM target is the trocar where it is in that period (the controller is assumed
to know it, e.g. by tracking the trocar), the tip targets and the depth limit's sphere are
about the moved centre, and the RCM deviation is measured against the moving trocar. The iOCT
estimates are of the wall's displacement relative to the eye (the tracked translation along
the beam removed).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from rcmplan import servo
from rcmplan._signals import raise_interrupt
from rcmplan._validate import FloatArray
from rcmplan.control.limits import TissueDepthLimit
from rcmplan.control.log import LogBuilder, RunLog
from rcmplan.control.qp import QpSolver
from rcmplan.control.qp_limits import QpLimits
from rcmplan.control.targets import rcm_target, rcm_targets, solve_pose
from rcmplan.exceptions import RcmBoundError, UnreachableTargetError
from rcmplan.robot.registry import make_robot
from rcmplan.scene.eye import default_eye, default_points, eye_frame
from rcmplan.sim.registry import make_plant
from rcmplan.subretinal.episode_blocks import PeriodBlocks
from rcmplan.subretinal.episode_ioct import EpisodeIoct, Received, true_state
from rcmplan.subretinal.episode_phases import PHASES, phase_durations, phases_at, tip_radius
from rcmplan.subretinal.episode_settings import EpisodeSettings
from rcmplan.subretinal.layers import RetinaLayers, unit_direction
from rcmplan.subretinal.monitor import heart_rate_input
from rcmplan.subretinal.motion import (
    MotionModel,
    MotionTrajectory,
    eye_translation,
    sample_motion,
)
from rcmplan.subretinal.predictors import make_predictor
from rcmplan.subretinal.tissue import TissueContact
from rcmplan.subretinal.trace import IlmTrace

SERIES = ("t_s", "phase", "wall_m", "predicted_m", "limit_m", "command_depth_m",
          "depth_vs_undeformed_m", "depth_m", "tissue_state", "rcm_deviation_m")  # fmt: skip


@dataclass
class EpisodeResult:
    """One episode: settings, per-period series (`SERIES`, SI units), the run log, the iOCT
    estimates the controller received (`trace`: dropped volumes left out, their count in it),
    every volume delivered (`received`, `episode_ioct.Received`), the phase start times, and a
    status ("ok", or what stopped or broke it)."""

    settings: EpisodeSettings
    layers: RetinaLayers
    series: dict[str, FloatArray]
    log: RunLog
    trace: IlmTrace
    received: tuple[Received, ...]
    phase_starts_s: dict[str, float]
    status: str = "ok"
    message: str = ""
    extra: dict[str, Any] = field(default_factory=dict)


class Episode:
    """Everything one episode needs, built and checked before any motion."""

    phase_names = PHASES

    def __init__(self, cfg: EpisodeSettings) -> None:
        self.cfg = cfg
        self.robot = robot = make_robot(cfg.robot)
        self.eye = eye = default_eye(robot)
        self.R = eye_frame(eye)
        self.layers = layers = RetinaLayers.from_eye(
            eye, target_fraction=cfg.target_fraction, band_fraction=cfg.band_fraction
        )
        self.normal = unit_direction(cfg.direction)
        self.normal_base = self.R @ self.normal  # the target's normal in the base frame
        self.durations = phase_durations(cfg, layers)
        self.length_s = sum(self.durations.values())
        motion = MotionModel(
            breathing_amplitude_m=cfg.breathing_m,
            breathing_rate_hz=cfg.breathing_rate_hz,
            cardiac_amplitude_m=cfg.cardiac_m,
            cardiac_rate_hz=cfg.cardiac_rate_hz,
        )
        rng = np.random.default_rng(cfg.seed)
        self.motion = sample_motion(motion, cfg.warmup_s + self.length_s + 1.0, rng)
        self.ioct = EpisodeIoct(cfg, layers, eye, self.motion, rng)
        self.motion = self.with_eye_motion(self.motion)
        self.arrival_s = self.ioct.arrival_s
        self.predictor = make_predictor(cfg.compensation, **heart_rate_input(cfg, motion))
        bounded = "hold" if cfg.compensation == "none" else cfg.compensation
        self.guard = self.predictor if bounded == cfg.compensation else make_predictor(bounded)
        self._next = 0
        self.n_periods = round(self.length_s / cfg.dt)
        self.t_s: FloatArray = cfg.warmup_s + cfg.dt * np.arange(self.n_periods, dtype=float)
        self.wall_m = self.motion.displacement(self.t_s)
        shift = self.motion.translation(self.t_s)  # the eye's translation per period [m]
        self.center_m = np.ascontiguousarray(eye.center + shift)  # (n, 3) per period
        self.trocar_m = np.ascontiguousarray(eye.port + shift)
        n = self.n_periods  # per period, planned a block at a time (`plan`):
        self.predicted_m, self.bound_m, self.command_m = np.empty(n), np.empty(n), np.empty(n)
        self.floor_m = np.empty(n)  # the depth limit's floor radius [m]
        self.tip_m, self.base_m = np.empty((n, 3)), np.empty((n, 3))  # per period run [m]
        self.tent_m = np.empty(n)  # the ILM's tenting under the tip per period run [m]
        self.phase = np.zeros(n, dtype=int)  # index in PHASES
        self.desired, self.targets = np.empty((n, 3)), np.empty((n, 6))
        self._planned_to = 0  # periods [0, _planned_to) are planned
        self.start_radius = layers.ilm_radius_m - cfg.start_height_m
        start_tip = self.to_base(self.start_radius, 0)
        pose = solve_pose(robot, rcm_target(start_tip, self.trocar_m[0]))
        scene = {"eye": eye, "points": default_points(eye)}
        self.plant = make_plant(cfg.plant, robot, scene=scene, dt=cfg.dt)
        self.plant.reset(robot.actuators_from_joints(pose.q))
        self.start_tip, self.start_base = self.needle_now()  # held there during the warm-up
        floor_m = float(self.limit_radius(np.zeros(())))
        self.depth_limit = TissueDepthLimit(self.center_m[0], floor_m)
        extra = (self.depth_limit,) if cfg.depth_limit else ()
        self.solver = QpSolver(
            robot, None, cfg.dt, limits=QpLimits(), servo=self.plant, extra_limits=extra
        )  # a servo only on a plant that lags (MuJoCo)
        self.fast_step = servo.fast_period_step(self.solver)  # the compiled step where it applies
        self.tissue = TissueContact()
        self.log = LogBuilder.for_robot(robot)
        self._pids = {p: self.log.phase_id(p) for p in PHASES}
        self._pid_of = np.array([self._pids[p] for p in PHASES], dtype=float)  # by PHASES index
        self._sid = self.log.solver_id(self.solver.name)
        self.series = {k: np.empty(n) for k in SERIES}
        self.done = 0  # periods run (their records logged and stored)
        self.blocks = PeriodBlocks.make(self)  # None: one period at a time

    def with_eye_motion(self, motion: MotionTrajectory) -> MotionTrajectory:
        """`motion` with the whole-eye translation of the settings (`eye_drift_m`), drawn from
        the generator of (seed, 1): the rest of the seed's draws do not change with it."""
        cfg = self.cfg
        model = MotionModel(eye_drift_m=cfg.eye_drift_m, eye_drift_time_s=cfg.eye_drift_time_s)
        rng = np.random.default_rng(np.random.SeedSequence(cfg.seed, spawn_key=(1,)))
        shift = eye_translation(model, motion.t_s.size, rng)
        return replace(motion, translation_m=shift)

    @property
    def trace(self) -> IlmTrace:
        """The iOCT estimates delivered so far (`EpisodeIoct.trace`)."""
        return self.ioct.trace()

    def needle_now(self) -> tuple[FloatArray, FloatArray]:
        """The needle's tip and base (3,) each [m] where the plant holds them now."""
        q = self.robot.joints_from_actuators(self.plant.read_actuators())
        return self.robot.tip(q), self.robot.needle_point(q, 0.0)

    def depth_of(self, tip_m: FloatArray, k: int | slice) -> FloatArray:
        """Depth [m] of tips below the undeformed ILM of period k (the tissue model's input)."""
        center = self.center_m[k]
        wall = self.wall_m[k]
        return np.asarray(
            np.linalg.norm(tip_m - center, axis=-1) - (self.layers.ilm_radius_m + wall)
        )

    def to_base(self, radius_m: float | FloatArray, k: int | slice) -> FloatArray:
        """The point (3,) at `radius_m` [m] from the eye centre of period k on the target's
        normal, base frame; (N, 3) for N radii and a slice k of N periods."""
        return np.asarray(self.center_m[k] + np.multiply.outer(radius_m, self.normal_base))

    def limit_radius(self, displacement_m: FloatArray) -> FloatArray:
        """Radii [m] the depth limit holds the tip within: the RPE displaced by
        `displacement_m` [m] less the margin."""
        return np.asarray(self.layers.rpe_radius_m + displacement_m - self.cfg.rpe_margin_m)

    def deliver(self, t_s: float) -> None:
        """Acquire every volume that has arrived by episode time t_s [s] (the time of the next
        period to run) from the true state at its acquisition and feed its estimate to the
        predictors; a dropped volume feeds nothing."""
        while self._next < self.arrival_s.size and self.arrival_s[self._next] <= t_s:
            k = self._next
            t_acq = float(self.ioct.t_acq_s[k])
            value = self.ioct.acquire(k, true_state(self, t_acq))
            self._next += 1
            if value is None:
                continue
            self.predictor.update(t_acq, value)
            if self.guard is not self.predictor:
                self.guard.update(t_acq, value)

    def plan(self, k: int) -> None:
        """Plan the periods from k to the next estimate's arrival: the compensation's
        prediction, the depth limit's displacement, the phase, the commanded depth, the tip
        target and its X_ext. The predictors change only when an estimate arrives, so one call
        predicts the whole block (as `trace.prediction_errors` does)."""
        t, dt = self.t_s, self.cfg.dt
        self.deliver(float(t[k]))
        arrival = self.arrival_s[self._next] if self._next < self.arrival_s.size else np.inf
        end = max(k + 1, int(np.searchsorted(t, arrival, side="left")))
        block = slice(k, end)
        self.predicted_m[block] = self.predictor.predict(t[block])
        guard = self.guard.predict(t[block]) if self.guard is not self.predictor else None
        self.bound_m[block] = self.predicted_m[block] if guard is None else guard
        self.floor_m[block] = self.limit_radius(self.bound_m[block])
        bad = ~((self.floor_m[block] > 0.0) & (self.floor_m[block] <= 0.05))  # NaN too
        if bad.any():  # the limit's own check raises
            self.depth_limit.set_floor(float(self.floor_m[block][bad][0]))
        self.phase[block], a = phases_at(self.durations, np.arange(k, end, dtype=float) * dt)
        radius, self.command_m[block] = tip_radius(
            self.phase[block], a, self.predicted_m[block], self.start_radius, self.cfg, self.layers
        )
        self.desired[block] = self.to_base(radius, block)
        self.targets[block] = rcm_targets(self.desired[block], self.trocar_m[block])
        if not np.isfinite(self.targets[block]).all():  # as rcm_target refuses it
            raise UnreachableTargetError("the tip target coincides with the trocar")
        self._planned_to = end

    def period(self) -> None:
        """Run the next control period on its own (module docstring)."""
        robot, plant, cfg, k = self.robot, self.plant, self.cfg, self.done
        if k >= self._planned_to:
            self.plan(k)
        trocar = self.trocar_m[k]
        self.depth_limit.set_floor(float(self.floor_m[k]))
        self.depth_limit.set_center(self.center_m[k])
        desired, target = self.desired[k], self.targets[k]
        now = servo.read(robot, plant, trocar)
        e = servo.step(robot, plant, self.solver, self.fast_step, now, target)
        tip, rcm = now.tip, now.rcm
        self.log.append(time=float(self.t_s[k]), sliders=now.s, joints=now.q, lam=now.lam,
                        tip=tip, rcm=rcm, trocar=trocar, base=now.base, target_tip=desired,
                        error=e, step=k, iteration=0, solver=self._sid,
                        phase=self._pids[PHASES[self.phase[k]]])  # fmt: skip
        deviation = float(np.linalg.norm(rcm - trocar))
        self.store(k, tip[None, :], now.base[None, :], np.array([deviation]))
        if deviation > cfg.rcm_bound_m:
            raise RcmBoundError(PHASES[self.phase[k]], deviation, cfg.rcm_bound_m)

    def store(self, k: int, tips: FloatArray, bases: FloatArray, deviation_m: FloatArray) -> None:
        """The series of the periods k.. that ran, from their needle tips and bases (n, 3) [m]
        and RCM deviations (n,) [m]; the tissue model reads the tips in turn
        (`TissueContact.read`)."""
        n = tips.shape[0]
        block, wall = slice(k, k + n), self.wall_m[k : k + n]
        z = self.depth_of(tips, block)
        states, tent, _, depth, _ = self.tissue.read(z)
        self.tip_m[block], self.base_m[block] = tips, bases
        self.tent_m[block] = tent
        columns: tuple[Any, ...] = (
            self.t_s[block], self._pid_of[self.phase[block]], wall, self.predicted_m[block],
            self.bound_m[block], self.command_m[block], z, depth, states, deviation_m,
        )  # fmt: skip
        for key, values in zip(SERIES, columns, strict=True):
            self.series[key][block] = values
        self.done = k + n

    def run(self) -> EpisodeResult:
        """Feed the warm-up estimates, run every period (a planned block at a time where the
        compiled block loop applies), return the result (also when the RCM bound stopped it:
        status "rcm_bound_exceeded"). An interrupt (KeyboardInterrupt: SIGINT, SIGTERM in the
        `rcmplan` command) carries the periods recorded so far as `exc.result`, status
        "interrupted", and propagates (itself where Python or numba wrapped it in another
        exception: `rcmplan._signals.wrapped_interrupt`)."""
        try:
            return self.result(*self.run_periods())
        except BaseException as exc:

            def partial(interrupt: KeyboardInterrupt) -> EpisodeResult:
                why = f"interrupted by {getattr(interrupt, 'signal_name', 'SIGINT')} during the run"
                return self.result("interrupted", f"{why}, {self.reached()}")

            raise_interrupt(exc, partial)

    def run_periods(self) -> tuple[str, str]:
        """Feed the warm-up estimates and run the periods (`run`); (status, message): "ok", or
        the RCM bound's stop."""
        try:
            self.deliver(self.cfg.warmup_s)
            while self.done < self.n_periods:
                if self.blocks is None:
                    self.period()
                    continue
                if self.done >= self._planned_to:
                    self.plan(self.done)
                self.blocks.run(self, self.done, self._planned_to)
        except RcmBoundError as exc:
            return exc.status, str(exc)
        return "ok", ""

    def reached(self) -> str:
        """How far the episode got: "in the <phase> phase after N of M periods", or in the
        warm-up (how many of its iOCT volumes were fed), before the first period."""
        n = self.recorded()
        if n == 0:
            warm = int(np.searchsorted(self.arrival_s, self.cfg.warmup_s, side="right"))
            return (f"in the warm-up ({min(self._next, warm)} of its {warm} iOCT volumes fed "
                    f"to the predictor), before the first of {self.n_periods} periods")  # fmt: skip
        return f"in the {PHASES[self.phase[n - 1]]} phase after {n} of {self.n_periods} periods"

    def recorded(self) -> int:
        """Periods whose records are both logged and stored (an interrupt can land between the
        log's append and the series' store: the periods of both)."""
        return min(self.done, len(self.log))

    def result(self, status: str, message: str) -> EpisodeResult:
        """The result of the periods recorded so far, with `status` and `message` (the start
        times of the phases they reached)."""
        n = self.recorded()
        series = {k: v[:n].copy() for k, v in self.series.items()}
        log = self.log.finish()
        if len(log) > n:
            log = log.select(np.arange(len(log)) < n)
        # the phases begun by the last period recorded (all of them in a finished episode)
        reached = self.t_s[n - 1] + 0.5 * self.cfg.dt if n else -np.inf
        starts, t0 = {}, self.cfg.warmup_s
        for name, length in self.durations.items():
            if length > 0.0 and t0 < reached:  # a phase of zero length (no withdraw) never starts
                starts[name] = t0
            t0 += length
        return EpisodeResult(self.cfg, self.layers, series, log, self.trace,
                             tuple(self.ioct.received), starts, status, message)  # fmt: skip


def run_episode(cfg: EpisodeSettings) -> EpisodeResult:
    """Build and run one episode."""
    return Episode(cfg).run()
