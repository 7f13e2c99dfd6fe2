"""The generic standard-DH chain: frames, Jacobians, and a second published robot."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rcmplan import DHChain, DHLink
from rcmplan.exceptions import InvalidInputError, UnknownJointTypeError

# Puma 560, standard DH as in roboticstoolbox-python 1.5.0 (models.DH.Puma560, after Corke).
PUMA = DHChain(
    [
        DHLink("revolute", 0.0, 0.67183, 0.0, math.pi / 2),
        DHLink("revolute", 0.0, 0.0, 0.4318, 0.0),
        DHLink("revolute", 0.0, 0.15005, 0.0203, -math.pi / 2),
        DHLink("revolute", 0.0, 0.4318, 0.0, math.pi / 2),
        DHLink("revolute", 0.0, 0.0, 0.0, -math.pi / 2),
        DHLink("revolute", 0.0, 0.0, 0.0, 0.0),
    ]
)
Q_PUMA = np.array([0.1, -0.2, 0.3, -0.4, 0.5, -0.6])
# fkine(Q_PUMA).A and jacob0(Q_PUMA) printed by roboticstoolbox-python 1.5.0.
T_PUMA = np.array(
    [
        [0.4835584756186441, 0.6865353920257893, -0.5429920405985423, 0.41326351870003564],
        [-0.7576356466601042, 0.6389509809729744, 0.13315356106240506, -0.1093387291723408],
        [0.43835992924456385, 0.34700259279963547, 0.8291138480468356, 1.0177139998876745],
        [0.0, 0.0, 0.0, 1.0],
    ]
)
J_PUMA = np.array(
    [
        [0.10933872917234083, -0.34415602059126049, -0.42951286786349391, 0, 0, 0],
        [0.41326351870003564, -0.034530781472257598, -0.043095032753565049, 0, 0, 0],
        [0.0, 0.40028326355889166, -0.022909484752956438, 0, 0, 0],
        [0.0, 0.099833416646828071, 0.099833416646828071, -0.099334665397530553,
         -0.29358445623041785, -0.54299204059854234],
        [0.0, -0.99500416527802582, -0.99500416527802582, -0.0099667110793791504,
         -0.95514226624088039, 0.13315356106240506],
        [1.0, 0.0, 0.0, 0.99500416527802582, -0.038876963617616590, 0.82911384804683563],
    ]
)  # fmt: skip


def test_puma_forward_kinematics_matches_roboticstoolbox() -> None:
    np.testing.assert_allclose(PUMA.forward_kinematics(Q_PUMA), T_PUMA, atol=1e-12)


def test_puma_jacobian_matches_roboticstoolbox() -> None:
    np.testing.assert_allclose(PUMA.jacobian(Q_PUMA), J_PUMA, atol=1e-12)


def test_puma_zero_pose_is_the_textbook_pose() -> None:
    T = PUMA.forward_kinematics(np.zeros(6))
    np.testing.assert_allclose(T[:3, 3], [0.4521, -0.15005, 0.4318 + 0.67183], atol=1e-12)


def numeric_point_jacobian(
    chain: DHChain, q: np.ndarray, link: int, point: np.ndarray
) -> np.ndarray:
    h = 1e-6
    J = np.zeros((3, chain.n))
    for i in range(chain.n):
        dq = np.zeros(chain.n)
        dq[i] = h
        Tp, Tm = chain.frames(q + dq)[link], chain.frames(q - dq)[link]
        J[:, i] = (Tp[:3, :3] @ point + Tp[:3, 3] - Tm[:3, :3] @ point - Tm[:3, 3]) / (2 * h)
    return J


def test_jacobian_of_a_point_on_a_link_matches_finite_differences(rng: np.random.Generator) -> None:
    for _ in range(20):
        q = rng.uniform(-1, 1, 6)
        link = int(rng.integers(1, 7))
        point = rng.uniform(-0.1, 0.1, 3)
        J = PUMA.jacobian(q, link=link, point=point)
        np.testing.assert_allclose(J[:3], numeric_point_jacobian(PUMA, q, link, point), atol=1e-8)
        assert np.all(J[:, link:] == 0.0)


def test_prismatic_columns_are_the_joint_axis() -> None:
    chain = DHChain([DHLink("prismatic", 0.0, 0.1, 0.0, math.pi / 2), DHLink("revolute")])
    J = chain.jacobian([0.05, 0.3])
    np.testing.assert_allclose(J[:, 0], [0, 0, 1, 0, 0, 0], atol=1e-15)


def test_unknown_joint_type_raises_and_names_the_choices() -> None:
    with pytest.raises(UnknownJointTypeError, match="revolute"):
        DHChain([("helical", 0.0, 0.0, 0.0, 0.0)])


@pytest.mark.parametrize("q", [[0.1] * 5, [np.nan] * 6, [[0.0] * 6], [np.inf, 0, 0, 0, 0, 0]])
def test_bad_joint_vectors_raise(q: list) -> None:
    with pytest.raises(InvalidInputError, match="q ="):
        PUMA.forward_kinematics(q)


def test_empty_chain_and_bad_link_index_raise() -> None:
    with pytest.raises(InvalidInputError):
        DHChain([])
    with pytest.raises(InvalidInputError, match=r"\[0, 6\]"):
        PUMA.jacobian(np.zeros(6), link=7)
