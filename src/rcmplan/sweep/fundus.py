"""Where a sweep's targets lie on the retina, and why the unreachable ones are out of reach.

Fundus coordinates unroll the retina about its pole, the retina point opposite the trocar (on
the insertion axis n beyond the eye centre): an azimuthal equidistant view, so the distance
of a dot from the origin is the arc length along the retina from the pole in [mm], and its
direction is the azimuth around n. The horizontal axis is e1 = n x z_base (horizontal in the
robot base frame), the vertical axis is -e2 = e1 x n, which points to +z_base ("up" when the
robot's base z axis points up). Which side is nasal or temporal depends on which eye is
operated and how the robot stands; a scenario does not say, so the maps do not either.

Causes of unreachability come from the reason each target was refused (`sampling.classify`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray
from rcmplan.scene.eye import Eye
from rcmplan.sweep.sampling import MISSES_RETINA, REACHABLE, Sample, trocar_frame

# Cause of each category index; converged and failed motions first, then the refusals
# (key in summary.json's `targets.by_cause`, label on the map and in the table)
CAUSE_NAMES = (
    ("converged", "converged"),
    ("motion_failed", "motion failed"),
    ("actuator_travel", "actuator travel"),
    ("singular_margin", "singular margin"),
    ("rcm_cone", "RCM cone (RCM off the needle)"),
    ("other_limit", "other robot limit"),
    ("misses_retina", "eye wall (ray misses the retina)"),
)
CAUSE_KEYS = tuple(key for key, _ in CAUSE_NAMES)
CAUSES = tuple(label for _, label in CAUSE_NAMES)
CONVERGED, FAILED, SLIDER, SINGULAR, CONE, OTHER, WALL = range(len(CAUSES))


def refusal_cause(reason: str) -> int:
    """The cause index of an unreachable target from its refusal message."""
    if reason.startswith(("slider ", "joint ")):
        return SLIDER
    if "leave the reach |cos" in reason or "singular" in reason:
        return SINGULAR
    if reason.startswith("lambda ="):
        return CONE
    return OTHER


def causes(sample: Sample, converged: FloatArray) -> NDArray[np.int64]:
    """Cause index per sampled target (converged (N,): 1.0 where the motion converged)."""
    out = np.array([refusal_cause(r) for r in sample.reasons], dtype=np.int64)
    out[sample.status == MISSES_RETINA] = WALL
    reach = sample.status == REACHABLE
    out[reach & (converged == 1.0)] = CONVERGED
    out[reach & (converged != 1.0)] = FAILED
    return out


def fundus_mm(points: FloatArray, eye: Eye) -> FloatArray:
    """(N, 2) fundus coordinates in [mm] of points (N, 3) on or near the retina, base frame
    (NaN rows stay NaN)."""
    n, e1, e2 = trocar_frame(eye)
    v = np.asarray(points) - eye.center
    v = v / np.linalg.norm(v, axis=1, keepdims=True)
    polar = np.arctan2(np.linalg.norm(np.cross(v, n), axis=1), v @ n)  # exact near the pole
    az = np.arctan2(v @ -e2, v @ e1)
    arc_mm = eye.retina_radius * polar * 1e3
    return np.column_stack([arc_mm * np.cos(az), arc_mm * np.sin(az)])


def cone_edge_mm(eye: Eye, max_angle: float, n: int = 200) -> FloatArray:
    """(n, 2) fundus coordinates in [mm] of the sampled cone's edge on the retina."""
    from rcmplan.sweep.sampling import ray_directions

    dirs = ray_directions(eye, np.full(n, max_angle), np.linspace(0.0, 2.0 * np.pi, n))
    return fundus_mm(np.array([eye.retina_point(d) for d in dirs]), eye)
