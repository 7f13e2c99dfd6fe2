"""X_ext, the needle angles and J_a (eqs. 3.14, 3.15, 6.1)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rcmplan import Iramis
from rcmplan.control.augmented import augmented_jacobian, extended_task
from rcmplan.control.tasks import NeedleAngles
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.needle import angle_between, angles_from_axis, axes_angles, axis_from_angles

from conftest import random_joints


def eq_6_1(q: np.ndarray, lam: float, l2=0.0335, l5=0.028, l6=0.097) -> np.ndarray:
    """Thesis eq. 6.1 typed in as printed."""
    q4 = q[4]
    c1, s1, c3, s3 = math.cos(q[1]), math.sin(q[1]), math.cos(q[3]), math.sin(q[3])
    return np.array(
        [
            [0, l2*c1 + l6*c3*s1 + l5*s1*s3 + q4*c3*s1, 0, c1*(l6*s3 - l5*c3 + q4*s3), -c1*c3, 0],
            [0, 1, 0, 0, 0, 0],
            [0, 0, 0, c1, 0, 0],
            [0, l2*c1 + l5*s1*s3 + q4*c3*s1 + l6*lam*c3*s1, 0, c1*(q4*s3 - l5*c3 + l6*lam*s3), -c1*c3, -l6*c1*c3],
            [0, 0, 1, -l5*s3 - q4*c3 - l6*lam*c3, -s3, -l6*s3],
            [1, l5*c1*s3 - l2*s1 + q4*c1*c3 + l6*lam*c1*c3, 0, -s1*(q4*s3 - l5*c3 + l6*lam*s3), c3*s1, l6*c3*s1],
        ]
    )  # fmt: skip


def test_angles_and_axis_invert_each_other(rng) -> None:
    for phi, psi in rng.uniform(-1.4, 1.4, (200, 2)):
        assert angles_from_axis(axis_from_angles(phi, psi)) == pytest.approx((phi, psi), abs=1e-12)


def test_the_angles_of_many_axes_are_those_of_each_axis(rng) -> None:
    axes = rng.normal(size=(50, 3))
    axes[7] = np.nan  # a tip on the trocar: no axis
    out = np.empty((50, 2))
    axes_angles(axes, out)
    for axis, angles in zip(axes[:7], out[:7], strict=True):
        assert tuple(angles) == angles_from_axis(axis)
    assert np.isnan(out[7]).all()
    assert out[8:].tolist() == [list(angles_from_axis(a)) for a in axes[8:]]


def test_angle_between_matches_the_cross_and_dot_formula(rng) -> None:
    for a, b in rng.normal(size=(200, 2, 3)):
        expected = math.atan2(float(np.linalg.norm(np.cross(a, b))), float(a @ b))
        assert angle_between(a, b) == pytest.approx(expected, abs=1e-12)
    x, y = np.array([2.0, 0.0, 0.0]), np.array([0.0, 0.5, 0.0])
    assert (angle_between(x, x), angle_between(x, -x)) == (0.0, pytest.approx(math.pi))
    assert angle_between(x, y) == pytest.approx(math.pi / 2)
    assert angle_between(x, np.zeros(3)) == 0.0  # no direction: no angle


def test_needle_angles_are_q1_and_q3(robot: Iramis, rng) -> None:
    for q in random_joints(rng, 200, angle=1.4):
        assert tuple(NeedleAngles().value(robot, q, 1.0)) == pytest.approx((q[1], q[3]), abs=1e-12)


def test_thesis_variant_equals_eq_6_1(robot: Iramis, rng) -> None:
    for q in random_joints(rng, 200):
        lam = rng.uniform(0, 1)
        np.testing.assert_allclose(
            augmented_jacobian(robot, q, lam, "thesis"), eq_6_1(q, lam), atol=1e-12
        )


def test_thesis_angle_rows_are_the_geometric_omega_y_and_omega_z(robot: Iramis, rng) -> None:
    for q in random_joints(rng, 50):
        Ja = augmented_jacobian(robot, q, 0.5, "thesis")
        np.testing.assert_allclose(Ja[1:3, :5], robot.jacobian_05(q)[4:6], atol=1e-12)


def test_exact_jacobian_matches_finite_differences(robot: Iramis, rng) -> None:
    h = 1e-7
    for q in random_joints(rng, 100):
        lam = rng.uniform(0, 1)
        x = np.r_[q[:5], lam]

        def f(x: np.ndarray) -> np.ndarray:
            return extended_task(robot, np.r_[x[:5], 0.0], x[5])

        num = np.column_stack([(f(x + h * e) - f(x - h * e)) / (2 * h) for e in np.eye(6)])
        np.testing.assert_allclose(augmented_jacobian(robot, q, lam), num, atol=1e-8)


def test_determinants_match_notes_not_eq_3_16(robot: Iramis, rng) -> None:
    l6 = robot.params.l6
    for q in random_joints(rng, 200):
        lam = rng.uniform(0, 1)
        c1, c3 = math.cos(q[1]), math.cos(q[3])
        assert np.linalg.det(augmented_jacobian(robot, q, lam)) == pytest.approx(
            l6 * c1**2 * c3**2, abs=1e-13
        )
        assert np.linalg.det(augmented_jacobian(robot, q, lam, "thesis")) == pytest.approx(
            l6 * c1**3 * c3**2, abs=1e-13
        )


def test_j_a_is_singular_exactly_on_the_singular_set(robot: Iramis) -> None:
    for q1, q3 in [(math.pi / 2, 0.2), (0.3, -math.pi / 2)]:
        q = np.array([0.0, q1, 0.0, q3, 0.01, 0.0])
        assert abs(np.linalg.det(augmented_jacobian(robot, q, 0.7))) < 1e-18
    # eq. 3.16 claims singularity at q1 = 0 (its sin q1 factor); J_a is regular there.
    assert np.linalg.matrix_rank(augmented_jacobian(robot, np.zeros(6), 0.7)) == 6


def test_unknown_variant_raises_with_choices(robot: Iramis) -> None:
    with pytest.raises(InvalidInputError, match="exact"):
        augmented_jacobian(robot, np.zeros(6), 0.5, "geometric")  # type: ignore[arg-type]
