"""Fundus coordinates of retina targets and the cause of each refusal."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rcmplan.control.targets import rcm_target, solve_pose
from rcmplan.exceptions import SliderLimitError, UnreachableTargetError
from rcmplan.scene.eye import default_eye
from rcmplan.sweep import fundus
from rcmplan.sweep.sampling import REACHABLE, UNREACHABLE, Sample, trocar_frame


def test_the_pole_opposite_the_trocar_is_the_origin(robot) -> None:
    eye = default_eye(robot)
    pole = eye.center + eye.retina_radius * eye.axis
    assert fundus.fundus_mm(pole[None, :], eye)[0] == pytest.approx([0.0, 0.0], abs=1e-9)


def test_distance_from_the_origin_is_the_arc_length_along_the_retina(robot) -> None:
    eye = default_eye(robot)
    n, _e1, e2 = trocar_frame(eye)
    angle = 0.3
    up = -e2  # towards +z_base
    p = eye.center + eye.retina_radius * (math.cos(angle) * n + math.sin(angle) * up)
    xy = fundus.fundus_mm(p[None, :], eye)[0]
    assert xy == pytest.approx([0.0, eye.retina_radius * angle * 1e3])
    assert up[2] > 0.0  # "up" on the map is +z_base


def test_refusals_are_sorted_by_cause_from_the_real_messages(robot) -> None:
    eye = default_eye(robot)
    slider = str(SliderLimitError(0, "L1", 0.05, -0.04, 0.04))
    with pytest.raises(UnreachableTargetError) as deep:
        solve_pose(robot, rcm_target(eye.port + 0.2 * eye.axis, eye.port))
    assert fundus.refusal_cause(slider) == fundus.SLIDER
    assert fundus.refusal_cause(deep.value.reason) == fundus.CONE
    assert fundus.refusal_cause("needle angles (phi, psi) = (1.5, 0) rad leave the reach "
                                "|cos phi|, |cos psi| >= 0.1") == fundus.SINGULAR  # fmt: skip


def test_causes_put_converged_failed_and_refused_targets_apart() -> None:
    status = np.array([REACHABLE, REACHABLE, UNREACHABLE, UNREACHABLE], dtype=np.int8)
    reasons = ("", "", "slider L3 = 0.05 m is beyond its travel", "lambda = 1.2 is outside")
    sample = Sample(np.zeros((4, 2)), np.zeros((4, 3)), np.zeros((4, 3)), status, reasons,
                    np.zeros(3), np.zeros(3))  # fmt: skip
    found = fundus.causes(sample, np.array([1.0, 0.0, np.nan, np.nan]))
    assert found.tolist() == [fundus.CONVERGED, fundus.FAILED, fundus.SLIDER, fundus.CONE]
