"""The iRAM!S model: eq. 2.7, eq. 2.12, sliders, needle points, singular set, limits."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rcmplan import Iramis, IramisParameters
from rcmplan.exceptions import InvalidInputError, SingularPoseError, SliderLimitError
from rcmplan.robot.dh import DHChain

from conftest import random_joints


def eq_2_7(
    q: np.ndarray, l1=0.071, l2=0.0335, l3=-0.023, l4=0.071, l5=0.028, l6=0.097
) -> np.ndarray:
    """Thesis eq. 2.7 typed in as printed."""
    q0, q1, q2, q3, q4, q5 = q
    c1, s1, c3, s3, c5, s5 = (math.cos(q1), math.sin(q1), math.cos(q3), math.sin(q3),
                              math.cos(q5), math.sin(q5))  # fmt: skip
    return np.array(
        [
            [-s1 * s5 - c1 * c5 * s3, c1 * s3 * s5 - c5 * s1, -c1 * c3,
             l2 * s1 - c1 * c3 * (q4 + l6) - l5 * c1 * s3],
            [c3 * c5, -c3 * s5, -s3, l3 + l4 + q2 - s3 * (q4 + l6) + l5 * c3],
            [c5 * s1 * s3 - c1 * s5, -c1 * c5 - s1 * s3 * s5, c3 * s1,
             l1 + q0 + l2 * c1 + c3 * s1 * (q4 + l6) + l5 * s1 * s3],
            [0, 0, 0, 1],
        ]
    )  # fmt: skip


def eq_2_12(q: np.ndarray, l2=0.0335, l5=0.028, l6=0.097) -> np.ndarray:
    """Thesis eq. 2.12 typed in as printed."""
    q4 = q[4]
    c1, s1, c3, s3 = math.cos(q[1]), math.sin(q[1]), math.cos(q[3]), math.sin(q[3])
    return np.array(
        [
            [0, l2*c1 + l6*c3*s1 + l5*s1*s3 + q4*c3*s1, 0, c1*(l6*s3 - l5*c3 + q4*s3), -c1*c3, 0],
            [0, 0, 1, -l6*c3 - l5*s3 - q4*c3, -s3, 0],
            [1, l6*c1*c3 - l2*s1 + l5*c1*s3 + q4*c1*c3, 0, -s1*(l6*s3 - l5*c3 + q4*s3), c3*s1, 0],
            [0, 0, 0, s1, 0, -c1*c3],
            [0, 1, 0, 0, 0, -s3],
            [0, 0, 0, c1, 0, c3*s1],
        ]
    )  # fmt: skip


def test_forward_kinematics_equals_eq_2_7_at_random_poses(robot: Iramis, rng) -> None:
    for q in random_joints(rng, 1000):
        np.testing.assert_allclose(robot.forward_kinematics(q), eq_2_7(q), rtol=0, atol=1e-12)


def test_forward_kinematics_equals_the_dh_product(robot: Iramis, rng) -> None:
    chain = robot.chain
    for q in random_joints(rng, 200):
        np.testing.assert_allclose(
            robot.forward_kinematics(q), chain.forward_kinematics(q), atol=1e-12
        )


def test_home_tip_and_axis_match_notes(robot: Iramis) -> None:
    T = robot.forward_kinematics(robot.home)
    np.testing.assert_allclose(T[:3, 3], [-0.097, 0.076, 0.1045], atol=1e-15)
    np.testing.assert_allclose(T[:3, 2], [-1, 0, 0], atol=1e-15)


def test_jacobian_equals_eq_2_12_and_the_dh_jacobian(robot: Iramis, rng) -> None:
    chain = robot.chain
    for q in random_joints(rng, 300):
        J = robot.jacobian(q)
        np.testing.assert_allclose(J, eq_2_12(q), atol=1e-12)
        np.testing.assert_allclose(J, chain.jacobian(q), atol=1e-12)


def test_jacobian_linear_rows_match_central_differences(robot: Iramis, rng) -> None:
    h = 1e-6
    for q in random_joints(rng, 50):
        num = np.column_stack(
            [(robot.tip(q + h * e) - robot.tip(q - h * e)) / (2 * h) for e in np.eye(6)]
        )
        np.testing.assert_allclose(robot.jacobian(q)[:3], num, atol=1e-9)


def test_jacobian_angular_rows_match_rotation_differences(robot: Iramis, rng) -> None:
    h = 1e-6
    for q in random_joints(rng, 50):
        R = robot.forward_kinematics(q)[:3, :3]
        for i, e in enumerate(np.eye(6)):
            dR = (
                robot.forward_kinematics(q + h * e)[:3, :3]
                - robot.forward_kinematics(q - h * e)[:3, :3]
            ) / (2 * h)
            W = dR @ R.T
            omega = np.array([W[2, 1], W[0, 2], W[1, 0]])
            np.testing.assert_allclose(robot.jacobian(q)[3:, i], omega, atol=1e-8)


def test_needle_point_jacobian_matches_finite_differences(robot: Iramis, rng) -> None:
    h = 1e-7
    for q in random_joints(rng, 50):
        lam = rng.uniform(0, 1)
        x = np.r_[q[:5], lam]

        def point(x: np.ndarray) -> np.ndarray:
            return robot.needle_point(np.r_[x[:5], 0.0], x[5])

        num = np.column_stack([(point(x + h * e) - point(x - h * e)) / (2 * h) for e in np.eye(6)])
        np.testing.assert_allclose(robot.needle_point_jacobian(q, lam), num, atol=1e-9)


def test_needle_base_is_the_chain_with_l6_zero(robot: Iramis, rng) -> None:
    base_chain = DHChain(robot.dh_links(l6=0.0))
    for q in random_joints(rng, 50):
        np.testing.assert_allclose(
            robot.needle_base(q), base_chain.forward_kinematics(q)[:3, 3], atol=1e-12
        )
        np.testing.assert_allclose(
            robot.needle_point_jacobian(q, 0.0)[:, :5], base_chain.jacobian(q)[:3, :5], atol=1e-12
        )
        np.testing.assert_allclose(
            robot.tip(q) - robot.needle_base(q), robot.params.l6 * robot.needle_axis(q), atol=1e-12
        )


def test_slider_joint_round_trips(robot: Iramis, rng) -> None:
    for q in random_joints(rng, 1000):
        np.testing.assert_allclose(
            robot.joints_from_actuators(robot.actuators_from_joints(q)), q, atol=1e-12
        )
    for s in rng.uniform(-0.025, 0.025, (1000, 6)):
        np.testing.assert_allclose(
            robot.actuators_from_joints(robot.joints_from_actuators(s)), s, atol=1e-12
        )


def test_slider_jacobian_matches_finite_differences(robot: Iramis, rng) -> None:
    h = 1e-8
    for s in rng.uniform(-0.02, 0.02, (30, 6)):
        num = np.column_stack(
            [
                (
                    robot.tip(robot.joints_from_actuators(s + h * e))
                    - robot.tip(robot.joints_from_actuators(s - h * e))
                )
                / (2 * h)
                for e in np.eye(6)
            ]
        )
        np.testing.assert_allclose(robot.slider_jacobian(s)[:3], num, atol=1e-7)
        q = robot.joints_from_actuators(s)
        np.testing.assert_allclose(
            robot.actuators_from_joints_jacobian(q) @ robot.joints_from_actuators_jacobian(s),
            np.eye(6),
            atol=1e-10,
        )


def test_j05_minors_vanish_exactly_on_the_singular_set(robot: Iramis, rng) -> None:
    """NOTES.md: the 5x5 minors of J_0^5 are s1 c1 c3 and -c1^2 c3."""
    for q in random_joints(rng, 200):
        J = robot.jacobian_05(q)
        c1, s1, c3 = math.cos(q[1]), math.sin(q[1]), math.cos(q[3])
        assert np.linalg.det(J[[0, 1, 2, 3, 4]]) == pytest.approx(s1 * c1 * c3, abs=1e-12)
        assert np.linalg.det(J[[0, 1, 2, 4, 5]]) == pytest.approx(-(c1**2) * c3, abs=1e-12)
    for q1, q3 in [(math.pi / 2, 0.3), (-0.2, math.pi / 2)]:
        q = np.array([0, q1, 0, q3, 0, 0])
        assert np.linalg.matrix_rank(robot.jacobian_05(q), tol=1e-9) == 4
        assert robot.singularity_measure(q) == pytest.approx(0.0, abs=1e-15)
    assert np.linalg.matrix_rank(robot.jacobian_05(np.array([0, 0.2, 0, 0.3, 0, 0]))) == 5


def test_singular_pose_raises_with_measure_and_threshold(robot: Iramis) -> None:
    with pytest.raises(SingularPoseError, match=r"threshold 0\.1"):
        robot.check_singularity([0, 1.5, 0, 0, 0, 0])
    robot.check_singularity([0, 1.0, 0, -1.0, 0, 0])


def test_sliders_beyond_travel_raise_naming_the_slider_and_range(robot: Iramis) -> None:
    s = np.zeros(6)
    s[4] = 0.06
    with pytest.raises(
        SliderLimitError, match=r"L5 = 0.06 m is beyond its travel \[-0.01, 0.05\] m"
    ):
        robot.check_actuators(s)
    np.testing.assert_allclose(robot.actuator_margin(np.zeros(6))[:4], 0.04)


@pytest.mark.parametrize("bad", [np.zeros(5), np.full(6, np.nan), "abc", np.zeros((2, 6))])
def test_bad_vectors_raise_invalid_input(robot: Iramis, bad) -> None:
    with pytest.raises(InvalidInputError):
        robot.forward_kinematics(bad)
    with pytest.raises(InvalidInputError):
        robot.joints_from_actuators(bad)


def test_parameters_are_validated_through_the_pcjm() -> None:
    with pytest.raises(InvalidInputError, match="spacing"):
        Iramis(IramisParameters(pcjm_spacing=0.0))
