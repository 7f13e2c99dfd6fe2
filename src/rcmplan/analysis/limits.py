"""Limits and tracking read from a run log: violations per kind over every record, and the
waypoints a run did not reach.

Violations (`violations`), per record, of every limit the QP holds (`QpLimits`):
- travel: an active actuator beyond its travel less `travel_margin` (every phase);
- speed: an active actuator's step above speed * dt (every phase; 0 for the first record);
- lam: lambda outside [0, 1] (RCM phases);
- rcm: RCM deviation |p_rcm - trocar| (`RunLog.rcm_deviation`, as the run's
  `max_rcm_deviation_m` measures it: on a curved needle's shaft, not on the chord to its tip)
  above `rcm_tolerance` (RCM phases);
- retina: the tip closer to the retina than the margin and getting closer, outside the port
  zone and away from a contact target (RCM phases; in free space the tip is outside the eye);
- singular: a singular term of the robot below the QP's singular floor (every phase).
A tip speed bound (`QpLimits.tip_speed`) is not counted: it bounds the step so that its second
order stays small, and is held to first order only (its second order reaches about 2 % of a
10 um step on the UR5).
A violation counts when it exceeds its slack: actuator values are exact by construction (float
rounding only); the retina margin and the RCM tolerance are held to first order, and the eye's
curvature costs at most |tip step|^2 / (2 r) per step (about 5 nm for a 10 um step).

Waypoints (`waypoints`): a waypoint is one target of a phase (its records share phase and step);
its tip error is |tip - target tip| at its last record. It is reached when that error is within
the bound the loop tolerance implies (`reach_bound`); otherwise it is limited (the QP stops at
the feasible point closest to it) and named with the limits active at its last record.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rcmplan.analysis.units import fmt
from rcmplan.control.eye_model import EyeModel
from rcmplan.control.log import RunLog
from rcmplan.control.qp_limits import QpLimits
from rcmplan.control.solvers import Tolerance
from rcmplan.exceptions import RcmplanError
from rcmplan.robot.model import RobotModel
from rcmplan.scene.scenario import Scenario

KINDS = ("travel", "speed", "lam", "rcm", "retina", "singular")
SLACK = {"travel": 1e-12, "speed": 1e-12, "lam": 0.0, "rcm": 1e-8, "retina": 1e-8,
         "singular": 1e-9}  # fmt: skip
# A limit is named active at a limited waypoint when its gap is below this fraction of the
# waypoint's miss (the QP stops where a limit's gap closes, up to its damper's convergence).
ACTIVE_FRACTION = 0.05


@dataclass(frozen=True)
class Violations:
    """Records that break a limit, per kind (see KINDS), and the worst excess of each in the
    limit's unit (metres; the singular term is dimensionless); -inf where none was checked."""

    counts: dict[str, int]
    worst: dict[str, float]

    @property
    def total(self) -> int:
        """Number of violations of any kind."""
        return sum(self.counts.values())

    def __getattr__(self, kind: str) -> int:
        if kind in KINDS:
            return self.counts[kind]
        raise AttributeError(kind)

    def as_dict(self) -> dict[str, int]:
        """Counts per kind (the summary's `limit_violations`)."""
        return dict(self.counts)


def excess(
    log: RunLog, robot: RobotModel, eye: EyeModel | None, limits: QpLimits, dt: float
) -> dict[str, NDArray[np.float64]]:
    """Per record and kind, how far the record is beyond the limit (> 0: broken; -inf: not
    checked there)."""
    n = len(log)
    rcm = ~np.isnan(log.trocar[:, 0])
    rcm_distance = np.linalg.norm(log.rcm_deviation(), axis=1)
    active = list(robot.active)
    s = log.sliders[:, active]
    lo = robot.lower[active] + limits.travel_margin
    hi = robot.upper[active] - limits.travel_margin
    out: dict[str, NDArray[np.float64]] = {
        "travel": np.max(np.maximum(lo - s, s - hi), axis=1, initial=-math.inf),
        "speed": speed_excess(log, robot, dt),
        "lam": np.where(rcm, np.maximum(-log.lam, log.lam - 1.0), -math.inf),
        "rcm": np.where(rcm, rcm_distance - limits.rcm_tolerance, -math.inf),
        "retina": np.full(n, -math.inf),
        "singular": limits.singular_floor(robot) - singular_values(log, robot),
    }
    if eye is not None:
        out["retina"] = np.where(rcm, retina_excess(log, eye, limits), -math.inf)
    return out


def violations(
    log: RunLog,
    robot: RobotModel,
    eye: EyeModel | None,
    limits: QpLimits | None = None,
    dt: float = 1e-3,
) -> Violations:
    """Count the records of the whole log that break a limit the QP holds (see module)."""
    ex = excess(log, robot, eye, limits or QpLimits(), dt)
    counts = {k: int(np.sum(ex[k] > SLACK[k])) for k in KINDS}
    worst = {k: float(np.max(ex[k], initial=-math.inf)) for k in KINDS}
    return Violations(counts, worst)


def speed_excess(log: RunLog, robot: RobotModel, dt: float) -> NDArray[np.float64]:
    """Per record, the largest |actuator step| - speed * dt (-inf for the first record)."""
    active = list(robot.active)
    if len(log) == 0:
        return np.zeros(0)
    ds = np.abs(np.diff(log.sliders[:, active], axis=0)) - robot.speed[active] * dt
    return np.concatenate([[-math.inf], np.max(ds, axis=1, initial=-math.inf)])


def retina_excess(log: RunLog, eye: EyeModel, lim: QpLimits) -> NDArray[np.float64]:
    """Per record, margin minus the tip's retina distance in [m]; -inf where exempt: tip in the
    port zone, target a contact, or the tip moving away from the retina (leaving a contact)."""
    d = eye.retina_radius - np.linalg.norm(log.tip - eye.center, axis=1)
    d_target = eye.retina_radius - np.linalg.norm(log.target_tip - eye.center, axis=1)
    in_port = np.linalg.norm(log.tip - eye.port, axis=1) <= lim.port_zone
    contact = np.abs(d_target) <= lim.contact_tolerance
    for c in lim.contacts:
        contact |= np.linalg.norm(log.target_tip - np.asarray(c), axis=1) <= lim.contact_tolerance
    receding = np.concatenate([[False], np.diff(d) >= 0.0])[: len(d)]
    return np.where(in_port | contact | receding, -math.inf, lim.retina_margin - d)


def singular_values(log: RunLog, robot: RobotModel) -> NDArray[np.float64]:
    """Per record, the smallest of the robot's singular terms (iRAM!S: cos q1, cos q3): one
    call for a model with `smallest_singular_values`, else one per record."""
    batch = _batch_of(robot)
    values = batch(log.joints) if batch is not None and len(log) else None
    if values is not None:
        return np.asarray(values, dtype=np.float64)
    out = np.full(len(log), math.inf)
    # The values alone where the model offers them (an arm's gradient costs an SVD's worth).
    only = getattr(robot, "singular_values", None)
    for i, q in enumerate(log.joints):
        values = only(q) if only is not None else robot.singular_terms(q)[0]
        if len(values):
            out[i] = float(np.min(values))
    return out


def _batch_of(robot: RobotModel) -> Any:
    """The robot's `smallest_singular_values`, or None: also when a subclass redefines the
    per-record singular terms, which the batch of the class it inherits would not follow."""
    cls = type(robot)
    owner = next((c for c in cls.__mro__ if "smallest_singular_values" in vars(c)), None)
    if owner is None:
        return None
    for name in ("singular_terms", "singular_values"):
        if getattr(cls, name, None) is not getattr(owner, name, None):
            return None
    return robot.smallest_singular_values  # type: ignore[attr-defined]


def reach_bound(tol: Tolerance, robot: RobotModel) -> float:
    """The tip error in [m] a waypoint converged within `tol` can have: the tip row and the
    three RCM rows within the position tolerance, the two needle angles within the angle
    tolerance over at most the needle's length (to first order)."""
    return 3.0 * tol.position + 2.0 * tol.angle * robot.needle_length


@dataclass(frozen=True)
class Waypoints:
    """What the run made of its waypoints (targets), tip errors in [m].

    Attributes:
        count: Waypoints with at least one record.
        max_tip_error_m: Worst tip error at the last record of a waypoint, over all of them.
        bound_m: The reach bound (see `reach_bound`).
        limited: The waypoints not reached: phase, step, tip error and the active limits.
    """

    count: int
    max_tip_error_m: float | None
    bound_m: float
    limited: tuple[dict[str, Any], ...]

    def as_dict(self) -> dict[str, Any]:
        """The summary's fields."""
        return {
            "max_waypoint_tip_error_m": self.max_tip_error_m,
            "limited_waypoints": len(self.limited),
            "limited_waypoint_list": list(self.limited),
        }


def waypoint_ends(log: RunLog) -> NDArray[np.int64]:
    """Index of the last record of each waypoint, in order."""
    if len(log) == 0:
        return np.zeros(0, dtype=np.int64)
    change = (np.diff(log.phase) != 0) | (np.diff(log.step) != 0)
    return np.flatnonzero(np.concatenate([change, [True]])).astype(np.int64)


def waypoints(
    log: RunLog,
    robot: RobotModel,
    eye: EyeModel | None,
    tol: Tolerance,
    limits: QpLimits | None = None,
    dt: float = 1e-3,
) -> Waypoints:
    """Tip error at every waypoint; the limited ones named with their active limits."""
    bound = reach_bound(tol, robot)
    ends = waypoint_ends(log)
    if ends.size == 0:
        return Waypoints(0, None, bound, ())
    err = np.linalg.norm(log.tip[ends] - log.target_tip[ends], axis=1)
    lim = limits or QpLimits()
    gaps = limit_gaps(log, robot, eye, lim, dt)
    limited = []
    for k in np.flatnonzero(err > bound):
        i = int(ends[k])
        near = ACTIVE_FRACTION * float(err[k])
        active = [kind for kind, gap in gaps.items() if gap[i] <= near]
        limited.append({
            "phase": log.phase_names[int(log.phase[i])] if log.phase_names else int(log.phase[i]),
            "step": int(log.step[i]),
            "tip_error_m": float(err[k]),
            "active_limits": active or ["none found"],
        })  # fmt: skip
    return Waypoints(int(ends.size), float(err.max()), bound, tuple(limited))


def limit_gaps(
    log: RunLog, robot: RobotModel, eye: EyeModel | None, lim: QpLimits, dt: float
) -> dict[str, NDArray[np.float64]]:
    """Per record, how far each limit is from binding, in [m] (singular: over the needle
    length); +inf where the limit is off."""
    n = len(log)
    active = list(robot.active)
    s = log.sliders[:, active]
    lo = robot.lower[active] + lim.travel_margin
    hi = robot.upper[active] - lim.travel_margin
    travel = np.min(np.minimum(s - lo, hi - s), axis=1, initial=math.inf)
    step = np.abs(np.diff(log.sliders[:, active], axis=0, prepend=log.sliders[:1, active]))
    speed = np.min(robot.speed[active] * dt - step, axis=1, initial=math.inf)
    singular = (singular_values(log, robot) - lim.singular_floor(robot)) * robot.needle_length
    retina = np.full(n, math.inf)
    if eye is not None:
        d = eye.retina_radius - np.linalg.norm(log.tip - eye.center, axis=1)
        in_port = np.linalg.norm(log.tip - eye.port, axis=1) <= lim.port_zone
        retina = np.where(in_port, math.inf, np.abs(d - lim.retina_margin))
    return {"travel": travel, "speed": speed, "retina": retina, "singular": singular}


MAX_LISTED = 20  # limited waypoints listed by name in a summary (all are counted)
LOOP_SLACK = 1e-12  # [m]: the loop's RCM tolerance is checked on the true kinematics (rounding)


def broken_bounds(scenario: Scenario, figures: dict[str, Any], max_rcm: float | None) -> str:
    """What the measured run breaks of the bounds it states, on one line ("" for nothing): with
    the QP, its limits (`limit_violations`, every kind: the QP holds each); with any method,
    the loop's RCM tolerance (`LoopSettings.rcm_tolerance`, the needle's largest distance from
    the trocar a step may leave) against `max_rcm` [m], the run's max RCM deviation inside the
    eye. On the kinematic plant the bounds hold on every shipped scenario; on a plant with
    dynamics they hold on the commands, and the measured needle lags them."""
    parts = []
    counts = figures.get("limit_violations") or {}
    broken = [f"{kind} {n:,}" for kind, n in counts.items() if n]
    if scenario.method == "qp" and broken:
        parts.append(f"records beyond the QP's limits: {', '.join(broken)}")
    tol = scenario.loop.rcm_tolerance
    if tol is not None and max_rcm is not None and max_rcm > tol + LOOP_SLACK:
        parts.append(f"max RCM deviation {fmt(max_rcm, 'um', with_unit=True)} above the loop's "
                     f"RCM tolerance {fmt(tol, 'um', with_unit=True)}")  # fmt: skip
    if not parts:
        return ""
    return "; ".join(parts) + f" (measured on the {scenario.plant} plant)"


def limit_figures(scenario: Scenario, robot: RobotModel, log: RunLog) -> dict[str, Any]:
    """The summary's `limit_violations` (per kind, every record), `max_waypoint_tip_error_m`,
    `limited_waypoints` (count) and `limited_waypoint_list` (the first MAX_LISTED), measured
    against the scenario's QP limits (its `[qp]` settings, the defaults for other methods) and
    loop tolerance."""
    cfg = scenario.method_settings
    try:
        eye = scenario.eye(robot)
        options = {k: v for k, v in cfg.extra.items() if k != "solver"}
        limits = QpLimits.from_extra(options) if scenario.method == "qp" else QpLimits()
    except RcmplanError:  # the run stopped on the same settings; its status says why
        return {}
    v = violations(log, robot, eye, limits, scenario.dt)
    w = waypoints(log, robot, eye, cfg.tolerance, limits, scenario.dt)
    out = {"limit_violations": v.as_dict(), **w.as_dict()}
    out["limited_waypoint_list"] = out["limited_waypoint_list"][:MAX_LISTED]
    return out
