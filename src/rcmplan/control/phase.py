"""Phases of targets, loop settings and Algorithm 2's split (thesis section 3.4).

A phase is a named sequence of targets that Algorithm 1 runs one after another; Algorithm 2
splits a far target into equal steps (metres and radians apart, see `split_steps`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from rcmplan._validate import FloatArray, array, flag, integer, scalar, text, vector
from rcmplan.exceptions import InvalidInputError, PlanTooLargeError

TargetPlanner = Callable[[FloatArray], FloatArray]

# The most targets one run may plan (all phases together), and so one split. The default
# injection plans about 700 targets; the compiled loop runs about 25,000 targets per second
# with about 4 iterations each, so 200,000 targets already run for about 10 s and log about
# 800,000 records (200 MB of CSV). Step sizes that would plan more (`angle_mrad = 0.001`
# plans about 10^6) are refused before motion and before the targets are allocated.
MAX_TARGETS = 200_000
# Algorithm 1's iteration cap per target may not exceed this (the scenario schema's bound):
# a target that needs more is not converging.
MAX_ITERATIONS = 100_000


def check_plan_size(n: int, what: str = "targets") -> int:
    """n, or PlanTooLargeError when a run would plan more than MAX_TARGETS targets."""
    if n > MAX_TARGETS:
        valid = f"at most {MAX_TARGETS:,} targets per run (coarser step sizes)"
        raise PlanTooLargeError(what, n, valid)
    return n


def step_count(ratio: float, what: str = "steps") -> int:
    """Algorithm 2's number of equal steps, ceil(ratio) (at least 1), for ratio = the largest
    distance to go over its step size; PlanTooLargeError beyond MAX_TARGETS, InvalidInputError
    when ratio is not a finite number."""
    if not (isinstance(ratio, int | float) and math.isfinite(ratio)):
        raise InvalidInputError(what, ratio, "a finite ratio of distance to step size")
    if ratio > MAX_TARGETS:
        valid = f"at most {MAX_TARGETS:,} targets per run (coarser step sizes)"
        raise PlanTooLargeError(what, ratio, valid)
    return max(1, math.ceil(ratio))


KINDS = ("rcm", "free")
# Target widths: X_ext (6,) and tip points (3,); a curved needle's X_c and whole-needle poses (7,)
WIDTHS = {"rcm": (6, 7), "free": (3, 7)}


class _PhaseFields(NamedTuple):
    name: str
    targets: FloatArray | TargetPlanner
    kind: str = "rcm"


class Phase(_PhaseFields):
    """A named sequence of targets run with Algorithm 1 one after another.

    Attributes:
        name: Phase name for the log ("approach", "insert", ...).
        targets: (N, 6) X_ext targets for an RCM phase, (N, 3) tip points for free space ((N, 7)
            for a curved needle, `rcmplan.control.curved`), N >= 1, finite; or a planner called
            with the joints at the start of the phase that returns them (for phases whose start
            depends on where the previous one ended, such as a pivot). A single target may be
            given as a vector.
        kind: "rcm" or "free".

    Raises InvalidInputError when made with any other values (and `plan` when a planner
    returns other targets).
    """

    __slots__ = ()

    def __new__(cls, name: str, targets: FloatArray | TargetPlanner, kind: str = "rcm") -> Phase:
        text("phase name", name)
        text("phase kind", kind, KINDS)
        if not callable(targets):
            targets = checked_targets(f"targets of phase {name!r}", targets, kind)
        return super().__new__(cls, name, targets, kind)

    def plan(self, q: FloatArray) -> FloatArray:
        """The targets as an array, planned from joints q if the phase has a planner."""
        if not callable(self.targets):
            return np.atleast_2d(self.targets)
        return checked_targets(
            f"targets planned for phase {self.name!r}", self.targets(q), self.kind
        )


def checked_targets(name: str, targets: Any, kind: str) -> FloatArray:
    """targets as a finite (N, width) array, N >= 1, a width of `kind` (a vector: one target);
    InvalidInputError naming them otherwise."""
    t = np.atleast_2d(array(name, targets, (1, 2)))
    if t.shape[0] < 1 or t.shape[1] not in WIDTHS[kind]:
        widths = " or ".join(f"(N, {w})" for w in WIDTHS[kind])
        raise InvalidInputError(name, targets, f"{kind} targets of shape {widths}, N >= 1")
    return t


def check_phases(phases: Any) -> list[Phase]:
    """phases as a list of Phase, or InvalidInputError naming them."""
    if not isinstance(phases, list | tuple) or not all(isinstance(p, Phase) for p in phases):
        raise InvalidInputError("phases", phases, "a list of Phase (rcmplan.Phase)")
    return list(phases)


@dataclass(frozen=True)
class LoopSettings:
    """Loop settings.

    Attributes:
        max_iterations: Iteration cap of Algorithm 1 per target. Default 200, what every shipped
            scenario gives: on the dynamic MuJoCo plant a target 0.2 mm away takes the QP more
            than 100 periods (the servos' ramp and settling, docs/mujoco.md).
        drift_correction: Re-declare the RCM as the needle point closest to the trocar.
        singular_threshold: Smallest accepted singularity measure; None: the robot's.
        rcm_bound: Largest distance in [m] the RCM may move from the trocar in an RCM phase;
            a phase that exceeds it ends the run with RcmBoundError (its records kept). Default
            45 um, a tenth of the thesis's 0.45 mm trocar radius; None: unbounded (the thesis
            reproduction, whose drift is the quantity measured).
        max_target_step: Largest distance in [m] between the tip of an RCM phase's target and
            the next one's, and between the needle's tip and the phase's first target: a
            larger jump is refused before the phase moves (it is not subdivided: the plan is
            the user's, and `split_steps` or the procedures make the steps). Default 1 mm,
            five of the default 0.2 mm steps; None: unchecked.
        rcm_tolerance: Largest distance in [m] one step of an RCM phase may leave between
            the needle and the trocar: a longer step is shortened before it is taken
            (`rcmplan.control.rcm_step`). Default 0.8 um, under the 1 um accuracy asked of
            vitreoretinal tools; None: steps as the solver gives them (the thesis
            reproduction).
    """

    max_iterations: int = 200
    drift_correction: bool = True
    singular_threshold: float | None = None
    rcm_bound: float | None = 45e-6
    max_target_step: float | None = 1e-3
    rcm_tolerance: float | None = 0.8e-6

    def __post_init__(self) -> None:
        checked: dict[str, Any] = {
            "max_iterations": integer("max_iterations", self.max_iterations, 1, MAX_ITERATIONS),
            "drift_correction": flag("drift_correction", self.drift_correction),
        }
        ranges = {"singular_threshold": (0.0, 1.0), "rcm_bound": (0.0, 0.01),
                  "max_target_step": (0.0, 0.1), "rcm_tolerance": (0.0, 1e-3)}  # fmt: skip
        for name, (low, high) in ranges.items():
            value = getattr(self, name)
            if value is not None:
                opens = {"high_open": True} if name == "singular_threshold" else {"low_open": True}
                checked[name] = scalar(name, value, low, high, **opens)
        for name, value in checked.items():
            object.__setattr__(self, name, value)


def interpolate(start: FloatArray, goal: FloatArray, n: int) -> FloatArray:
    """n equal steps from start to goal: rows start + k/n (goal - start), k = 1..n.

    Raises InvalidInputError for start and goal of other shapes or not finite, and for n not
    an integer in [1, MAX_TARGETS] (PlanTooLargeError above it)."""
    start = vector("start", start)
    goal = vector("goal", goal, start.shape[0])
    if not isinstance(n, int | np.integer) or isinstance(n, bool) or n < 1:
        raise InvalidInputError("n", n, f"an integer in [1, {MAX_TARGETS:,}]")
    if n > MAX_TARGETS:
        raise PlanTooLargeError("n", n, f"an integer in [1, {MAX_TARGETS:,}]")
    k = np.arange(1, n + 1)[:, None] / n
    return start[None, :] + k * (goal - start)[None, :]


def split_steps(
    start: FloatArray, goal: FloatArray, step_position: float, step_angle: float | None = None
) -> FloatArray:
    """Algorithm 2's split: equal steps no larger than the step sizes (m and rad apart).

    For X_ext (6,) components 1 and 2 are angles; for tip points (3,) all are positions.
    Raises if the step is larger than the distance to go.
    """
    start = vector("start", start)
    if start.shape[0] not in (3, 6):
        raise InvalidInputError("start", start, "X_ext (6,) or a tip point (3,)")
    goal = vector("goal", goal, start.shape[0])
    sp = scalar("step_position", step_position, 0.0, np.inf, low_open=True)
    sa = math.inf if step_angle is None else scalar("step_angle", step_angle, 0.0, low_open=True)
    delta = np.abs(goal - start)
    scale = np.full(start.shape[0], sp)
    if start.shape[0] == 6:
        scale[1:3] = sa
    with np.errstate(over="ignore"):  # a distance beyond float range is refused below
        ratio = float(np.max(delta / scale))
    if ratio < 1.0:
        raise InvalidInputError(
            "step size",
            (step_position, step_angle),
            f"at most the distance to go (|delta| = {delta.tolist()})",
        )
    return interpolate(start, goal, step_count(ratio, "split steps"))
