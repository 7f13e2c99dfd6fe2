"""Retina targets reachable through the trocar.

Rays leave the trocar within a cone of half-angle `max_angle` around the insertion axis (the
axis from the trocar to the eye centre). A ray at polar angle theta and azimuth az is
d = cos(theta) n + sin(theta) (cos(az) e1 + sin(az) e2), with n the insertion axis,
e1 = n x z_base (normalised) and e2 = n x e1. The "grid" sampling is the equal-area spiral on the
cone's cap of directions (cos theta evenly spaced, az stepped by the golden angle); the "random"
sampling draws directions uniformly over the same cap from a seeded generator. Each ray's target
is where it meets the retina (less an optional standoff). A target is reachable when the robot
has a closed-form pose with the tip there and the RCM at the trocar (solve_pose): lambda in
[0, 1], needle angles off the singular set, every slider within travel. Reachability is itself a
map: unreachable targets are kept and marked, not dropped.

Angular coordinates on the maps are the tilt (theta cos az, theta sin az) in the (e1, e2) frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray
from rcmplan.control.targets import rcm_target, rcm_targets, solve_pose
from rcmplan.exceptions import UnreachableTargetError
from rcmplan.robot.model import RobotModel
from rcmplan.scene.eye import Eye
from rcmplan.sweep.errors import EmptyRegionError
from rcmplan.sweep.settings import MotionSettings, Region

REACHABLE, MISSES_RETINA, UNREACHABLE = 0, 1, 2
STATUS_NAMES = ("reachable", "misses_retina", "unreachable")
GOLDEN_ANGLE = math.pi * (3.0 - math.sqrt(5.0))


@dataclass(frozen=True)
class Sample:
    """Sampled retina targets, one row per ray, ids 0..N-1 in sampling order.

    Attributes:
        tilt: (N, 2) angular coordinates of each ray in [rad] (see module docstring).
        directions: (N, 3) unit ray directions, base frame.
        points: (N, 3) targets in [m], base frame (NaN where the ray misses the retina).
        status: (N,) REACHABLE, MISSES_RETINA or UNREACHABLE.
        reasons: Why each unreachable target is unreachable ("" when reachable).
        start: The start point p3 (3,) in [m]; trocar (3,) in [m].
    """

    tilt: FloatArray
    directions: FloatArray
    points: FloatArray
    status: NDArray[np.int8]
    reasons: tuple[str, ...]
    start: FloatArray
    trocar: FloatArray

    def __len__(self) -> int:
        return int(self.status.shape[0])

    @property
    def reachable_ids(self) -> NDArray[np.int64]:
        """Ids of the reachable targets, ascending."""
        return np.flatnonzero(self.status == REACHABLE)

    def counts(self) -> dict[str, int]:
        """Number of targets per status name."""
        return {n: int(np.sum(self.status == i)) for i, n in enumerate(STATUS_NAMES)}


def trocar_frame(eye: Eye) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(n, e1, e2): the insertion axis and two unit vectors normal to it, base frame."""
    n = eye.axis
    e1 = np.cross(n, [0.0, 0.0, 1.0])
    e1 /= np.linalg.norm(e1)
    return n, e1, np.cross(n, e1)


def cone_angles(region: Region) -> tuple[FloatArray, FloatArray]:
    """(theta, az) in [rad] of region.n_targets rays, equal-area over the cone's cap."""
    n = region.n_targets
    span = 1.0 - math.cos(region.max_angle)
    if region.sampling == "grid":
        k = np.arange(n, dtype=float)
        cos_theta = 1.0 - (k + 0.5) / n * span
        az = np.mod(k * GOLDEN_ANGLE, 2.0 * math.pi)
    else:
        rng = np.random.default_rng(region.seed)
        cos_theta = 1.0 - rng.random(n) * span
        az = 2.0 * math.pi * rng.random(n)
    return np.arccos(np.clip(cos_theta, -1.0, 1.0)), az


def ray_directions(eye: Eye, theta: FloatArray, az: FloatArray) -> FloatArray:
    """Unit directions (N, 3) at polar angle theta and azimuth az around the insertion axis."""
    n, e1, e2 = trocar_frame(eye)
    radial = np.cos(az)[:, None] * e1 + np.sin(az)[:, None] * e2
    return np.asarray(np.cos(theta)[:, None] * n + np.sin(theta)[:, None] * radial)


def start_point(eye: Eye, motion: MotionSettings) -> FloatArray:
    """The start point p3 on the insertion axis, start_depth inside the trocar, in [m]."""
    return np.asarray(eye.port + motion.start_depth * eye.axis)


def classify(
    robot: RobotModel, eye: Eye, dirs: FloatArray, standoff: float
) -> tuple[NDArray[np.int8], FloatArray, tuple[str, ...]]:
    """(status (N,), target points (N, 3), reasons) of the rays `dirs` (N, 3). A target is
    reachable if `solve_pose` finds its pose; on iRAM!S the compiled screen of its closed forms
    (`compiled.runner.screen_flags`) clears in one call the targets it certainly finds, and only
    the others go through `solve_pose`, whose error gives the reason."""
    from rcmplan.compiled.runner import screen_flags

    n = len(dirs)
    status = np.full(n, REACHABLE, dtype=np.int8)
    points = np.full((n, 3), np.nan)
    reasons = [""] * n
    for i, d in enumerate(dirs):
        try:
            points[i] = eye.retina_point(d) - standoff * d
        except UnreachableTargetError as exc:
            status[i], reasons[i] = MISSES_RETINA, exc.reason
    hit = np.flatnonzero(status == REACHABLE)
    targets = rcm_targets(points[hit], eye.port)
    flags = screen_flags(robot, targets) if hit.size else None
    for k, row in enumerate(hit.tolist()):
        if flags is not None and not flags[k]:
            continue
        try:
            solve_pose(robot, targets[k])
        except UnreachableTargetError as exc:
            status[row], reasons[row] = UNREACHABLE, exc.reason
    return status, points, tuple(reasons)


def sample_region(
    region: Region, motion: MotionSettings, robot: RobotModel | None = None
) -> Sample:
    """Sample the region's rays, mark each target's reachability, or raise if none is reachable.

    Raises:
        UnreachableTargetError: The start point p3 itself is unreachable.
        EmptyRegionError: No sampled target is reachable.
    """
    robot = robot or motion.model()
    eye = motion.eye(robot)
    start = start_point(eye, motion)
    solve_pose(robot, rcm_target(start, eye.port))
    theta, az = cone_angles(region)
    dirs = ray_directions(eye, theta, az)
    status, points, reasons = classify(robot, eye, dirs, region.standoff)
    sample = Sample(
        tilt=np.column_stack([theta * np.cos(az), theta * np.sin(az)]),
        directions=dirs,
        points=points,
        status=status,
        reasons=reasons,
        start=start,
        trocar=np.asarray(eye.port),
    )
    if sample.reachable_ids.size == 0:
        raise EmptyRegionError(
            f"none of the {len(sample)} retina targets within {math.degrees(region.max_angle):.3g}"
            f" deg of the insertion axis is reachable ({sample.counts()}); first reason: "
            f"{sample.reasons[0]}",
            sample.counts(),
        )
    return sample
