"""Gain and step-size search over the workspace (thesis chapter 5: "a better K can be determined
by systematically computing accuracy and convergence during movements within the whole
workspace").

Parameters: K = (k_task, k_task, k_task, k_rcm, k_rcm, k_rcm), one gain for the tip task (x, phi,
psi) and one for the RCM task, each in (0, 2); the step size `step_position` in [m], with
`step_angle` scaled with it (their ratio kept from the base settings, 10 rad/m by default).
Grid: every combination of DEFAULT_GRID. Optimiser: bounded Nelder-Mead over (k_task, k_rcm,
log10 step) started from the base settings.

Objective, evaluated on a fixed subsample of the reachable targets:
    minimise   mean control iterations per target (both phases)
    subject to every target converges, and
               max RCM deviation over the subsample <= rcm_bound (10 um by default).
Fewer iterations is both less computing and, at a fixed control period, a faster motion. The
optimiser sees the penalised cost mean_iterations + penalty * (failed fraction +
max(0, deviation / bound - 1)); the reported best is the lowest-cost candidate that meets every
constraint (None when no candidate does).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize

from rcmplan._validate import scalar
from rcmplan.sweep.checkpoint import Checkpoint
from rcmplan.sweep.executors import Executor
from rcmplan.sweep.runner import ChunkCallback, run_targets
from rcmplan.sweep.sampling import Sample
from rcmplan.sweep.settings import MotionSettings, SweepSettings
from rcmplan.sweep.task import TargetResult

MM = 1e-3
DEFAULT_GRID: dict[str, tuple[float, ...]] = {
    "k_task": (0.7, 1.0, 1.3),
    "k_rcm": (0.7, 1.0, 1.3),
    "step_position": (0.2 * MM, 0.5 * MM, 1.0 * MM),
}
GAIN_BOUNDS = (0.05, 1.95)
STEP_BOUNDS = (0.05 * MM, 2.0 * MM)
RCM_BOUND_MAX_M = 1e-2  # the largest RCM-deviation bound a gain search accepts [m]


@dataclass(frozen=True)
class Objective:
    """Mean iterations subject to convergence and an RCM-deviation bound.

    Attributes:
        rcm_bound_m: Largest accepted RCM deviation over the subsample in [m].
        penalty: Weight of a constraint violation in the optimiser's cost [iterations].
    """

    rcm_bound_m: float = 10e-6
    penalty: float = 1e4

    def __post_init__(self) -> None:
        scalar("rcm_bound_m", self.rcm_bound_m, 0.0, RCM_BOUND_MAX_M, low_open=True)
        scalar("penalty", self.penalty, 0.0, math.inf, low_open=True)


@dataclass(frozen=True)
class Candidate:
    """One setting tried: gains (dimensionless) and step size in [m]."""

    k_task: float
    k_rcm: float
    step_position: float

    def motion(self, base: MotionSettings) -> MotionSettings:
        """The base motion settings with these gains and step sizes."""
        ratio = base.step_angle / base.step_position
        K = (self.k_task,) * 3 + (self.k_rcm,) * 3
        return replace(base, K=K, step_position=self.step_position,
                       step_angle=ratio * self.step_position)  # fmt: skip


@dataclass(frozen=True)
class Evaluation:
    """A candidate's figures on the subsample; lengths in [m], time in [s]."""

    candidate: Candidate
    mean_iterations: float
    max_rcm_deviation_m: float
    converged_fraction: float
    feasible: bool
    cost: float
    compute_time_s: float


@dataclass(frozen=True)
class GainSearchResult:
    """Every evaluation in the order tried, and the best feasible one (None if none is)."""

    mode: str
    objective: Objective
    subsample_ids: tuple[int, ...]
    evaluations: tuple[Evaluation, ...]
    best: Evaluation | None
    message: str = ""


def evaluate(candidate: Candidate, results: Sequence[TargetResult], obj: Objective) -> Evaluation:
    """Objective and constraints of one candidate from its results on the subsample."""
    iters = np.array([r.iterations for r in results], dtype=float)
    devs = [r.max_rcm_deviation_m for r in results if r.max_rcm_deviation_m is not None]
    dev = max(devs) if devs else math.inf
    conv = float(np.mean([r.converged for r in results]))
    feasible = conv == 1.0 and dev <= obj.rcm_bound_m
    violation = (1.0 - conv) + max(0.0, min(dev / obj.rcm_bound_m, 1e3) - 1.0)
    mean = float(iters.mean())
    return Evaluation(
        candidate, mean, dev, conv, feasible, mean + obj.penalty * violation,
        float(sum(r.wall_time_s for r in results)),
    )  # fmt: skip


def subsample(sample: Sample, n: int) -> NDArray[np.int64]:
    """About n reachable target ids spread evenly through the sample's (equal-area) order."""
    ids = sample.reachable_ids
    if n >= ids.size:
        return ids
    picks = np.unique(np.round(np.linspace(0, ids.size - 1, max(1, n))).astype(int))
    return ids[picks]


@dataclass
class Search:
    """Evaluates candidates on a subsample through an executor, caching by candidate."""

    base: SweepSettings
    sample: Sample
    ids: NDArray[np.int64]
    executor: Executor
    objective: Objective = field(default_factory=Objective)
    checkpoint_root: str | None = None
    on_chunk: ChunkCallback | None = None
    on_evaluation: Callable[[Evaluation], None] | None = None
    tried: dict[Candidate, Evaluation] = field(default_factory=dict)

    def __call__(self, c: Candidate) -> Evaluation:
        """The candidate's evaluation (run once, then cached)."""
        if c not in self.tried:
            motion = c.motion(self.base.motion)
            cp = self._checkpoint(motion)
            results, _ = run_targets(motion, self.sample, self.ids.tolist(), self.executor, cp,
                                     self.on_chunk)  # fmt: skip
            self.tried[c] = evaluate(c, list(results.values()), self.objective)
            if self.on_evaluation is not None:
                self.on_evaluation(self.tried[c])
        return self.tried[c]

    def _checkpoint(self, motion: MotionSettings) -> Checkpoint | None:
        if self.checkpoint_root is None:
            return None
        settings = SweepSettings(self.base.region, motion)
        path = f"{self.checkpoint_root}/{settings.digest()[:16]}"
        return Checkpoint.open(path, settings, resume=True)

    def result(self, mode: str, message: str = "") -> GainSearchResult:
        """Every evaluation so far and the best feasible one."""
        evals = tuple(self.tried.values())
        feasible = [e for e in evals if e.feasible]
        best = min(feasible, key=lambda e: e.cost) if feasible else None
        ids = tuple(int(i) for i in self.ids)
        return GainSearchResult(mode, self.objective, ids, evals, best, message)


def grid_search(search: Search, grid: dict[str, Sequence[float]] | None = None) -> GainSearchResult:
    """Evaluate every combination of the grid's k_task, k_rcm and step_position values."""
    g = grid or DEFAULT_GRID
    for kt, kr, st in itertools.product(g["k_task"], g["k_rcm"], g["step_position"]):
        search(Candidate(float(kt), float(kr), float(st)))
    return search.result("grid", f"{len(search.tried)} grid points")


def _candidate(x: NDArray[np.float64]) -> Candidate:
    """(k_task, k_rcm, log10 of the step in [mm]) to a candidate, rounded to 4 digits."""
    kt, kr, st = float(x[0]), float(x[1]), 10.0 ** float(x[2]) * MM
    return Candidate(float(f"{kt:.4g}"), float(f"{kr:.4g}"), float(f"{st:.4g}"))


def optimize_search(search: Search, max_evaluations: int = 30) -> GainSearchResult:
    """Bounded Nelder-Mead (scipy) over (k_task, k_rcm, log10 step) from the base settings.

    The initial simplex moves each gain by 0.1 and the step by a factor of 2; the gains are
    searched linearly because the cost rises steeply on both sides of k = 1 (a full Newton step).
    """
    m = search.base.motion
    lo = np.array([GAIN_BOUNDS[0], GAIN_BOUNDS[0], math.log10(STEP_BOUNDS[0] / MM)])
    hi = np.array([GAIN_BOUNDS[1], GAIN_BOUNDS[1], math.log10(STEP_BOUNDS[1] / MM)])
    x0 = np.clip([m.K[0], m.K[3], math.log10(m.step_position / MM)], lo, hi)
    res = minimize(
        lambda x: search(_candidate(x)).cost, x0, method="Nelder-Mead",
        bounds=list(zip(lo, hi, strict=True)),
        options={"maxfev": max_evaluations, "xatol": 0.005, "fatol": 0.5,
                 "initial_simplex": initial_simplex(x0, lo, hi, np.array([0.1, 0.1, 0.3]))},
    )  # fmt: skip
    return search.result("optimize", f"Nelder-Mead: {res.message} ({res.nfev} evaluations)")


def initial_simplex(x0: NDArray[np.float64], lo: NDArray[np.float64], hi: NDArray[np.float64],
                    size: NDArray[np.float64]) -> NDArray[np.float64]:  # fmt: skip
    """x0 and one vertex per axis, size[i] away along axis i, towards the interior of [lo, hi]."""
    rows = [x0]
    for i in range(x0.size):
        v = x0.copy()
        v[i] += size[i] if x0[i] + size[i] <= hi[i] else -size[i]
        rows.append(np.clip(v, lo, hi))
    return np.array(rows)
