"""The eye, its named points, and the procedures' phases."""

from __future__ import annotations

import numpy as np
import pytest

from rcmplan import Iramis
from rcmplan.control import PinvSolver
from rcmplan.controller import Controller
from rcmplan.exceptions import InvalidInputError, UnreachableTargetError
from rcmplan.scene.eye import Eye, EyePoints, default_eye, default_points
from rcmplan.scene.procedures import Spiral, Steps, injection, spiral
from rcmplan.sim import KinematicPlant


def test_default_points_are_consistent(robot: Iramis) -> None:
    eye = default_eye(robot)
    pts = default_points(eye)
    assert np.linalg.norm(eye.port - eye.center) == pytest.approx(eye.radius, abs=1e-15)
    assert eye.distance_to_retina(pts.p1) < 0  # outside
    assert eye.distance_to_retina(pts.p3) > 0  # in the vitreous
    for p in (pts.p4, pts.p5, pts.p6, pts.p7):
        assert eye.distance_to_retina(p) == pytest.approx(0.0, abs=1e-12)
    # p1, p2, p3 lie on the trocar axis
    for p in (pts.p1, pts.p3):
        d = p - eye.port
        assert np.linalg.norm(np.cross(d, eye.axis)) < 1e-15


def test_injection_phases_are_named_in_order(robot: Iramis) -> None:
    eye = default_eye(robot)
    names = [p.name for p in injection(robot, eye, default_points(eye))]
    assert names[:3] == ["approach", "align", "insert"]
    assert names[3:11] == ["p3-p4", "p4-p3", "p3-p5", "p5-p3", "p3-p6", "p6-p3", "p3-p7", "p7-p3"]
    assert names[11:] == ["retract", "withdraw"]


def test_spiral_path_has_its_radius_turns_and_pitch(robot: Iramis) -> None:
    eye = default_eye(robot)
    pts = default_points(eye)
    shape = Spiral(offset=(0.0, 0.0), radius=2e-3, turns=2.0, pitch=0.5e-3)
    path = shape.path(eye, pts.p3)
    rel = path - pts.p3
    along = rel @ eye.axis
    radial = np.linalg.norm(rel - along[:, None] * eye.axis, axis=1)
    assert radial[-1] == pytest.approx(2e-3, abs=1e-12)
    assert along[-1] == pytest.approx(1e-3, abs=1e-12)
    assert len(path) == 2 * shape.points_per_turn + 1


def test_a_target_outside_the_eye_is_refused_before_motion(robot: Iramis) -> None:
    eye = default_eye(robot)
    pts = default_points(eye).as_dict()
    pts["p5"] = eye.center + 1.2 * eye.retina_radius * (pts["p5"] - eye.center) / eye.retina_radius
    with pytest.raises(UnreachableTargetError, match="outside the retina"):
        injection(robot, eye, EyePoints(**pts))


def test_a_target_behind_the_trocar_is_refused(robot: Iramis) -> None:
    eye = default_eye(robot)
    pts = default_points(eye).as_dict()
    pts["p3"] = eye.port - 1e-3 * eye.axis
    with pytest.raises(UnreachableTargetError):
        injection(robot, eye, EyePoints(**pts))


def test_eye_rejects_a_trocar_off_its_sphere_and_bad_sizes() -> None:
    with pytest.raises(InvalidInputError, match="outer sphere"):
        Eye(center=np.zeros(3), radius=0.012, trocar=np.array([0.011, 0, 0]))
    with pytest.raises(InvalidInputError, match=r"eye\.radius"):
        Eye(center=np.zeros(3), radius=-0.012, trocar=np.array([0.012, 0, 0]))


def test_bad_step_sizes_raise() -> None:
    with pytest.raises(InvalidInputError, match=r"steps\.position"):
        Steps(position=0.0)


def test_spiral_procedure_runs_with_the_rcm_held(robot: Iramis) -> None:
    eye = default_eye(robot)
    log = Controller(KinematicPlant(robot), PinvSolver()).run(
        spiral(robot, eye, default_points(eye))
    )
    inside = np.all(np.isfinite(log.trocar), axis=1)
    assert np.linalg.norm(log.rcm_deviation()[inside], axis=1).max() <= 1e-6
    assert "spiral" in log.phase_names
