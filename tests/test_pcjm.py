"""PCJM slider <-> joint maps (eqs. 2.1-2.4) and their derivatives."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rcmplan import Pcjm
from rcmplan.exceptions import InvalidInputError, PcjmAngleError


def test_equal_sliders_translate_without_rotation() -> None:
    assert Pcjm(0.03).joints(0.004, 0.004) == (0.004, 0.0)


def test_slider_difference_gives_eq_2_2_angle() -> None:
    q_lin, q_rot = Pcjm(0.03).joints(-0.001, 0.002)
    assert q_lin == pytest.approx(0.0005, abs=1e-15)
    assert q_rot == pytest.approx(math.atan(0.003 / 0.03), abs=1e-15)


def test_round_trips_are_exact(rng: np.random.Generator) -> None:
    pcjm = Pcjm(0.03)
    for L1, L2 in rng.uniform(-0.025, 0.025, (1000, 2)):
        back = pcjm.sliders(*pcjm.joints(L1, L2))
        np.testing.assert_allclose(back, (L1, L2), atol=1e-12)
    for q_lin, q_rot in rng.uniform(-1.2, 1.2, (1000, 2)) * [0.02, 1]:
        np.testing.assert_allclose(
            pcjm.joints(*pcjm.sliders(q_lin, q_rot)), (q_lin, q_rot), atol=1e-12
        )


def test_derivatives_match_finite_differences_and_invert_each_other(
    rng: np.random.Generator,
) -> None:
    pcjm, h = Pcjm(0.03), 1e-7
    for L1, L2 in rng.uniform(-0.02, 0.02, (50, 2)):
        J = pcjm.joints_jacobian(L1, L2)
        num = np.column_stack(
            [
                (np.array(pcjm.joints(L1 + h, L2)) - pcjm.joints(L1 - h, L2)) / (2 * h),
                (np.array(pcjm.joints(L1, L2 + h)) - pcjm.joints(L1, L2 - h)) / (2 * h),
            ]
        )
        np.testing.assert_allclose(J, num, rtol=1e-6, atol=1e-9)
        q_rot = pcjm.joints(L1, L2)[1]
        np.testing.assert_allclose(pcjm.sliders_jacobian(q_rot) @ J, np.eye(2), atol=1e-10)


def test_angle_at_or_beyond_ninety_degrees_has_no_slider_difference() -> None:
    with pytest.raises(PcjmAngleError, match="pi/2"):
        Pcjm(0.03).sliders(0.0, math.pi / 2)


def test_non_finite_sliders_have_no_angle() -> None:
    with pytest.raises(PcjmAngleError, match="finite"):
        Pcjm(0.03).joints(math.inf, 0.0)


@pytest.mark.parametrize("d", [0.0, -0.01, math.nan])
def test_spacing_must_be_positive(d: float) -> None:
    with pytest.raises(InvalidInputError, match="spacing"):
        Pcjm(d)
