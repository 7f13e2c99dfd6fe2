"""Fixture violations of a session, counted from the run log (periods that break a fixture).

| kind | a period violates it when |
|---|---|
| rcm | the trocar lies farther than `rcm_limit` from the needle line |
| retina | the tip lies closer than `retina_margin` to the retina (by more than SLACK_M) |
| workspace | the tip lies outside the workspace box (by more than SLACK_M) |
| speed | an actuator moved farther than speed x dt since the last period (by more than
  SPEED_SLACK of it) |
| travel | an active actuator lies beyond its travel less `travel_margin` (by more than SLACK_M,
  [rad] for a revolute one) |

The slacks only absorb floating-point rounding: each is a millionth of the bound or a
nanometre.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray
from rcmplan.control.limits import WorkspaceBound
from rcmplan.control.log import RunLog
from rcmplan.robot.model import RobotModel
from rcmplan.scene.eye import Eye
from rcmplan.teleop.fixtures import Fixtures
from rcmplan.teleop.metrics import speed_excess

KINDS = ("rcm", "retina", "workspace", "speed", "travel")
SLACK_M = 1e-9
SPEED_SLACK = 1e-6


def retina_distance(eye: Eye, points: FloatArray) -> FloatArray:
    """Signed distance (N,) [m] of points (N, 3) to the retina, positive inside."""
    return np.asarray(eye.retina_radius - np.linalg.norm(points - eye.center, axis=1))


def violation_masks(
    log: RunLog, eye: Eye, box: WorkspaceBound, fixtures: Fixtures, robot: RobotModel,
    dt: float,
) -> dict[str, NDArray[np.bool_]]:  # fmt: skip
    """Per kind, the periods (N,) that break the fixture (module docstring)."""
    active = list(robot.active)
    s = log.sliders[:, active]
    lo = robot.lower[active] + fixtures.travel_margin - SLACK_M
    hi = robot.upper[active] - fixtures.travel_margin + SLACK_M
    return {
        "rcm": np.linalg.norm(log.rcm - log.trocar, axis=1) > fixtures.rcm_limit,
        "retina": retina_distance(eye, log.tip) < fixtures.retina_margin - SLACK_M,
        "workspace": box.outside(log.tip) > SLACK_M,
        "speed": speed_excess(log.sliders[:, active], robot.speed[active], dt) > SPEED_SLACK,
        "travel": np.any((s < lo) | (s > hi), axis=1),
    }


def count(masks: dict[str, NDArray[np.bool_]]) -> dict[str, int]:
    """Violating periods per kind."""
    return {k: int(np.count_nonzero(masks[k])) for k in KINDS}


def fixture_active(
    desired: FloatArray, eye: Eye, box: WorkspaceBound, margin: float
) -> dict[str, NDArray[np.bool_]]:
    """Per fixture, the periods whose desired tip lies past it (the fixture holds the tip)."""
    return {
        "retina": retina_distance(eye, desired) < margin,
        "workspace": box.outside(desired) > 0.0,
    }
