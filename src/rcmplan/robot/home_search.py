"""A home pose for an arm whose robot file gives none: within the joint limits, the needle
horizontal, the arm as far from its singular set as the search finds.

The search maximises the arm's singularity measure kappa (`SerialArm.singularity_measure`, the
inverse condition number of the needle's Jacobian: 1 isotropic, 0 singular) subject to

- a_z = 0: the needle direction a has no vertical part in the model's root frame (whose z is
  taken as vertical, as URDF and MJCF models state it);
- a . u >= `outward` (cos 30 deg by default), u the horizontal unit vector from the root's
  vertical axis to the tip, and the tip at least `distance` times the arm's reach bound
  (`SerialArm.reach`) from that axis, and not below the root: the needle points away from the
  arm, so the eye, placed in front of the tip (`rcmplan.scene.eye.default_eye`), lies outside
  it and above the surface the arm stands on;
- every joint `margin` of its travel away from its limits.

1. `samples` joint vectors drawn uniformly in the narrowed box (numpy, fixed `seed`);
2. the `starts` best of them by kappa sqrt(1 - a_z^2) max(0, a . u) refined by SLSQP (scipy)
   with exact gradients (kappa: `SerialArm.singular_terms`; a: d a / d q_j = omega_j x a; the
   tip: `SerialArm.tip_jacobian`), then made horizontal to `HORIZONTAL_TOLERANCE` by
   minimum-norm Newton steps on a_z;
3. the refined pose that meets every condition with the largest kappa, if that kappa is at
   least `min_measure`.

The roll joint (if any) sits at the middle of its travel: it moves no point of the needle.
Angles in rad, lengths in m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.chain import JointChain
from rcmplan.robot.model import SerialArm
from rcmplan.robot.needle import StraightNeedle

HORIZONTAL_TOLERANCE = 1e-9  # largest |a_z| of a home's unit needle axis


@dataclass(frozen=True)
class HomeSearch:
    """Settings of the home search.

    Attributes:
        samples: Joint vectors sampled uniformly in the narrowed box.
        starts: Best samples refined by SLSQP.
        seed: Seed of the sampling (the search is deterministic).
        margin: Fraction of each joint's travel kept clear at both ends, in [0, 0.45].
        min_measure: Smallest accepted singularity measure at home (dimensionless).
        outward: Smallest cosine between the needle and the horizontal direction from the
            root's vertical axis to the tip, in [-1, 1].
        distance: Smallest horizontal distance from that axis to the tip, as a fraction of
            the arm's reach bound, in [0, 1).
    """

    samples: int = 512
    starts: int = 8
    seed: int = 0
    margin: float = 0.1
    min_measure: float = 0.05
    outward: float = math.cos(math.pi / 6)
    distance: float = 0.25

    def __post_init__(self) -> None:
        if self.samples < 1 or not 1 <= self.starts <= self.samples:
            raise InvalidInputError("HomeSearch", (self.samples, self.starts),
                                    "samples >= 1 and 1 <= starts <= samples")  # fmt: skip
        if not 0.0 <= self.margin <= 0.45:
            raise InvalidInputError("HomeSearch.margin", self.margin, "a fraction in [0, 0.45]")
        if not -1.0 <= self.outward <= 1.0:
            raise InvalidInputError("HomeSearch.outward", self.outward, "a cosine in [-1, 1]")
        if not 0.0 <= self.distance < 1.0:
            raise InvalidInputError("HomeSearch.distance", self.distance, "a fraction in [0, 1)")


@dataclass(frozen=True)
class FoundHome:
    """The outcome of a search.

    Attributes:
        q: The home joints (n,), or None if no pose met every condition.
        measure: kappa at q (the best refined kappa when q is None; 0 if none was horizontal).
        tried: Samples drawn and poses refined, for messages.
    """

    q: FloatArray | None
    measure: float
    tried: tuple[int, int]


def search_home(
    chain: JointChain,
    needle: StraightNeedle,
    roll_joint: int | None,
    settings: HomeSearch | None = None,
) -> FoundHome:
    """The home of `chain` holding `needle` (see module docstring); never raises for a pose
    it cannot find, it returns `FoundHome(None, ...)`."""
    s = settings or HomeSearch()
    lo, hi = _box(chain, s.margin)
    rng = np.random.default_rng(s.seed)
    samples = lo + rng.random((s.samples, chain.n)) * (hi - lo)
    if roll_joint is not None:
        samples[:, roll_joint] = 0.5 * (chain.lower[roll_joint] + chain.upper[roll_joint])
    arm = _probe(chain, needle, roll_joint, samples)
    if arm is None:
        return FoundHome(None, 0.0, (s.samples, 0))
    scores = [_score(arm, q) for q in samples]
    order = np.argsort(scores)[::-1][: s.starts]
    r_min = s.distance * arm.reach
    best_kappa, best_q = 0.0, None
    for i in order:
        q = _refine(arm, samples[i], lo, hi, s.outward, r_min)
        kappa = arm.singularity_measure(q)
        if kappa > best_kappa and _meets(arm, q, lo, hi, s.outward, r_min):
            best_kappa, best_q = kappa, np.clip(q, chain.lower, chain.upper)
    found = best_q if best_kappa >= s.min_measure else None
    return FoundHome(found, best_kappa, (s.samples, len(order)))


def _meets(
    arm: SerialArm, q: FloatArray, lo: FloatArray, hi: FloatArray, outward: float, r_min: float
) -> bool:
    """q in the box, the needle horizontal and away from the arm, the tip above the root."""
    inside = bool(np.all(q >= lo - 1e-12) and np.all(q <= hi + 1e-12))
    ahead = min(_outward(arm, q) - outward, _radius(arm, q) - r_min, _height(arm, q)) >= -1e-9
    return inside and ahead and abs(_a_z(arm, q)) <= HORIZONTAL_TOLERANCE


def _box(chain: JointChain, margin: float) -> tuple[FloatArray, FloatArray]:
    """Joint limits narrowed by `margin` of the travel at both ends."""
    pad = margin * (chain.upper - chain.lower)
    return chain.lower + pad, chain.upper - pad


def _probe(
    chain: JointChain, needle: StraightNeedle, roll_joint: int | None, samples: FloatArray
) -> SerialArm | None:
    """An unplaced SerialArm to evaluate kappa with: its home is the first sample at which it
    has full task rank (any sample serves; kappa does not depend on the home)."""
    for q in samples[:32]:
        try:
            return SerialArm(chain, needle, q, "search", roll_joint, singular_threshold=0.0)
        except InvalidInputError:
            continue
    return None


def _a_z(arm: SerialArm, q: FloatArray) -> float:
    """The vertical part of the unit needle axis at q."""
    return float(arm.needle_axis(q)[2])


def _a_z_gradient(arm: SerialArm, q: FloatArray) -> FloatArray:
    """d a_z / d q[active]: (omega_j x a)_z for each active joint j."""
    a = arm.needle_axis(q)
    w = arm.needle_angular_jacobian(q)[:, :-1]
    out: FloatArray = w[0] * a[1] - w[1] * a[0]
    return out


def _tip_xy(arm: SerialArm, q: FloatArray) -> FloatArray:
    """The tip's horizontal offset (2,) from the root's vertical axis."""
    out: FloatArray = arm.tip(q)[:2] - arm.chain.base[:2, 3]
    return out


def _radius(arm: SerialArm, q: FloatArray) -> float:
    """The tip's horizontal distance from the root's vertical axis."""
    return float(np.linalg.norm(_tip_xy(arm, q)))


def _radius_gradient(arm: SerialArm, q: FloatArray) -> FloatArray:
    """d r / d q[active] = u . d p_xy."""
    p = _tip_xy(arm, q)
    u = p / max(float(np.linalg.norm(p)), 1e-9)
    out: FloatArray = u @ arm.tip_jacobian(q)[:2, :-1]
    return out


def _height(arm: SerialArm, q: FloatArray) -> float:
    """The tip's height above the root."""
    return float(arm.tip(q)[2] - arm.chain.base[2, 3])


def _outward(arm: SerialArm, q: FloatArray) -> float:
    """a . u: the needle against the horizontal direction u from the root's axis to the tip."""
    p = _tip_xy(arm, q)
    r = float(np.linalg.norm(p))
    return float(arm.needle_axis(q)[:2] @ p) / r if r > 1e-9 else -1.0


def _outward_gradient(arm: SerialArm, q: FloatArray) -> FloatArray:
    """d(a . u) / d q[active] = (d a_xy) . u + a_xy . (I - u u') d p_xy / r."""
    a = arm.needle_axis(q)
    w = arm.needle_angular_jacobian(q)[:, :-1]
    da = np.cross(w.T, a).T[:2]  # (2, m): omega_j x a, horizontal part
    p = _tip_xy(arm, q)
    r = max(float(np.linalg.norm(p)), 1e-9)
    u = p / r
    dp = arm.tip_jacobian(q)[:2, :-1]
    out: FloatArray = u @ da + (a[:2] - (a[:2] @ u) * u) @ dp / r
    return out


def _score(arm: SerialArm, q: FloatArray) -> float:
    """kappa times the horizontal part of the needle axis times how far it points away from
    the arm: how good a start q is."""
    a_z = _a_z(arm, q)
    horizontal = math.sqrt(max(0.0, 1.0 - a_z * a_z))
    return arm.singularity_measure(q) * horizontal * max(0.0, _outward(arm, q))


def _refine(
    arm: SerialArm, start: FloatArray, lo: FloatArray, hi: FloatArray, outward: float,
    r_min: float,
) -> FloatArray:  # fmt: skip
    """SLSQP from `start`: the largest kappa with a_z = 0, the needle pointing away from the
    arm, in the box; then a_z polished."""
    from scipy.optimize import minimize  # scipy.optimize takes a second to import

    act = list(arm.active)
    q = start.copy()

    def full(x: FloatArray) -> FloatArray:
        q[act] = x
        return q

    def cost(x: FloatArray) -> tuple[float, FloatArray]:
        kappa, grad = arm.singular_terms(full(x))
        return -float(kappa[0]), -grad[0, act]

    constraints = [
        {"type": "eq", "fun": lambda x: _a_z(arm, full(x)),
         "jac": lambda x: _a_z_gradient(arm, full(x))},
        {"type": "ineq", "fun": lambda x: _outward(arm, full(x)) - outward,
         "jac": lambda x: _outward_gradient(arm, full(x))},
        {"type": "ineq", "fun": lambda x: _radius(arm, full(x)) - r_min,
         "jac": lambda x: _radius_gradient(arm, full(x))},
        {"type": "ineq", "fun": lambda x: _height(arm, full(x)),
         "jac": lambda x: arm.tip_jacobian(full(x))[2, :-1]},
    ]  # fmt: skip
    bounds = list(zip(lo[act], hi[act], strict=True))
    res = minimize(cost, start[act], jac=True, method="SLSQP", bounds=bounds,
                   constraints=constraints, options={"maxiter": 200, "ftol": 1e-10})  # fmt: skip
    q = full(np.asarray(res.x, dtype=float)).copy()
    for _ in range(5):  # minimum-norm Newton steps on a_z alone
        a_z = _a_z(arm, q)
        if abs(a_z) <= HORIZONTAL_TOLERANCE:
            break
        g = _a_z_gradient(arm, q)
        q[act] -= g * a_z / max(float(g @ g), 1e-12)
    return q
