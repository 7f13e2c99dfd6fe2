"""The task the QP peers run: the default injection's visits p3 -> p4..p7 -> p3 (rcmplan only)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from rcmplan import Iramis
from rcmplan.control.phase import Phase
from rcmplan.control.targets import rcm_target, solve_pose
from rcmplan.scene.eye import Eye, default_eye, default_points
from rcmplan.scene.procedures import DEFAULT_VISITS, injection


class Visits(NamedTuple):
    """The task both controllers run: the robot, the eye, the start joints q0 (6,) at the
    exact p3 pose (tip at p3, needle through the trocar) and the visit phases of the default
    injection, p3-p4, p4-p3, ..., p7-p3, each with its X_ext targets (N, 6)."""

    robot: Iramis
    eye: Eye
    q0: np.ndarray
    phases: list[Phase]


def visits(names: tuple[str, ...] = DEFAULT_VISITS) -> Visits:
    """The default injection's visits p3 -> p4..p7 -> p3 (`rcmplan.scene.procedures.injection`,
    default eye and points, 0.2 mm target steps), or those of the points `names`."""
    robot = Iramis()
    eye = default_eye(robot)
    points = default_points(eye)
    phases = [
        ph for ph in injection(robot, eye, points, visits=names) if "p3" in ph.name.split("-")
    ]
    q0 = solve_pose(robot, rcm_target(points.p3, eye.port)).q
    return Visits(robot, eye, q0, phases)
