"""Two scenarios where holding limits matters, and a count of limit violations in a run log.

- `near_slider_limit`: an injection whose one visit lies where slider L4 is 0.25 mm from its
  hard travel end, inside the QP's default 0.5 mm travel margin. The target is within the hard
  travel, so every method accepts it; pseudoinverse and DLS drive L4 into the margin band, the
  QP stops L4 at the margin, at the feasible point closest to the target.
- `grazing_spiral`: a flat spiral deep in the eye whose last turn passes 0.1 mm from the retina,
  inside the QP's default 0.25 mm retina margin, while its start and end keep clear of it.
  Pseudoinverse and DLS follow the path into the margin; the QP slides along the margin and
  rejoins the path.

Both return (eye, points, phases) for the default robot; `rcmplan.analysis.limits.violations`
counts, per record, every limit the QP holds.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from rcmplan.control.phase import Phase
from rcmplan.control.targets import rcm_target, solve_pose
from rcmplan.exceptions import UnreachableTargetError
from rcmplan.robot.iramis import Iramis
from rcmplan.robot.needle import angles_from_axis, axis_from_angles
from rcmplan.scene.eye import Eye, EyePoints, default_eye, default_points
from rcmplan.scene.procedures import Spiral, injection, spiral

LIMIT_SLIDER = 3  # L4
LIMIT_GAP = 0.25e-3  # [m] from L4's hard upper end, inside the 0.5 mm default margin
GRAZE_DEPTH = 0.1e-3  # [m] from the retina at the spiral's closest approach


class Scene(NamedTuple):
    """An eye, its points and the phases of a procedure."""

    eye: Eye
    points: EyePoints
    phases: list[Phase]


def slider_gap(robot: Iramis, eye: Eye, tip: np.ndarray, slider: int) -> float:
    """Distance in [m] of one slider from its upper travel end at the pose that puts the tip at
    `tip` with the RCM at the trocar; -1 where that pose is beyond the travel."""
    try:
        q = solve_pose(robot, rcm_target(tip, eye.port)).q
    except UnreachableTargetError:
        return -1.0
    return float(robot.upper[slider] - robot.actuators_from_joints(q)[slider])


def near_limit_point(robot: Iramis, eye: Eye, depth: float = 8e-3) -> np.ndarray:
    """A point `depth` inside the trocar, tilted in psi until L4 is LIMIT_GAP from its end."""
    phi, psi = angles_from_axis(eye.axis)

    def point(dpsi: float) -> np.ndarray:
        return np.asarray(eye.port + depth * axis_from_angles(phi, psi + dpsi))

    lo, hi = 0.0, 0.3  # L4's gap shrinks as psi grows on the default robot (bisection)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if slider_gap(robot, eye, point(mid), LIMIT_SLIDER) > LIMIT_GAP:
            lo = mid
        else:
            hi = mid
    return point(lo)


def near_slider_limit(robot: Iramis | None = None) -> Scene:
    """Injection from p3 to one point where L4 lies LIMIT_GAP from its hard end, and back."""
    robot = robot or Iramis()
    eye = default_eye(robot)
    pts = default_points(eye).as_dict()
    pts["p4"] = near_limit_point(robot, eye)
    points = EyePoints(**pts)
    return Scene(eye, points, injection(robot, eye, points, visits=("p4",)))


def graze_spiral(eye: Eye, depth: float) -> Spiral:
    """A flat spiral offset along e2 whose p3 lies `depth` inside the trocar."""
    return Spiral(offset=(0.0, 2.0e-3), radius=2.5e-3, turns=3.0, pitch=0.0)


def closest_approach(eye: Eye, depth: float) -> tuple[float, float]:
    """(smallest retina distance along the spiral, retina distance at its end) in [m]."""
    p3 = eye.port + depth * eye.axis
    path = graze_spiral(eye, depth).path(eye, p3)
    d = eye.retina_radius - np.linalg.norm(path - eye.center, axis=1)
    return float(d.min()), float(d[-1])


def graze_depth(eye: Eye) -> float:
    """The p3 depth in [m] at which the spiral passes GRAZE_DEPTH from the retina."""
    lo, hi = eye.radius, eye.radius + eye.retina_radius
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if closest_approach(eye, mid)[0] > GRAZE_DEPTH:
            lo = mid
        else:
            hi = mid
    return lo


def grazing_spiral(robot: Iramis | None = None) -> Scene:
    """A deep flat spiral whose last turn passes GRAZE_DEPTH from the retina."""
    robot = robot or Iramis()
    eye = default_eye(robot)
    depth = graze_depth(eye)
    points = default_points(eye, depth=depth)
    return Scene(eye, points, spiral(robot, eye, points, graze_spiral(eye, depth)))
