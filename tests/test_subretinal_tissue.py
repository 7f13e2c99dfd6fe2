"""ILM tenting and puncture: the state machine of one episode."""

from __future__ import annotations

import numpy as np
import pytest

from rcmplan.exceptions import InvalidInputError
from rcmplan.subretinal.tissue import TissueContact, TissueModel, TissueState


def advance(contact: TissueContact, depths: np.ndarray) -> list:
    return [contact.update(float(z)) for z in depths]


def test_an_advancing_tip_approaches_then_tents_then_punctures_at_the_threshold() -> None:
    model = TissueModel(stiffness_n_per_m=40.0, puncture_force_n=4e-3)
    assert model.puncture_tent_m == pytest.approx(100e-6)
    depths = np.arange(-50e-6, 200e-6, 0.7e-6)
    readings = advance(TissueContact(model), depths)
    states = [r.state for r in readings]
    first_tent = states.index(TissueState.TENTING)
    first_hole = states.index(TissueState.PUNCTURED)
    assert depths[first_tent - 1] <= 0.0 < depths[first_tent]  # the first depth past the ILM
    assert depths[first_hole - 1] < 100e-6 <= depths[first_hole]  # F = k z reaches F_p
    assert set(states[:first_tent]) == {TissueState.APPROACH}
    assert set(states[first_tent:first_hole]) == {TissueState.TENTING}
    assert set(states[first_hole:]) == {TissueState.PUNCTURED}
    assert [r.punctured_now for r in readings].count(True) == 1
    for r in readings[first_tent:first_hole]:
        assert r.tent_m == r.depth_vs_undeformed_m  # the ILM moves with the tip
        assert r.force_n == pytest.approx(40.0 * r.tent_m)
        assert r.depth_in_tissue_m == 0.0  # the tip has not entered the retina
    hole = readings[first_hole]
    assert hole.depth_in_tissue_m == depths[first_hole]  # the tent gives way at once
    assert hole.tent_m == 0.0 and hole.force_n == 0.0


def test_retreating_while_tenting_releases_the_ilm_and_a_puncture_stays() -> None:
    contact = TissueContact(TissueModel())
    assert contact.update(50e-6).state == TissueState.TENTING
    back = contact.update(-5e-6)
    assert back.state == TissueState.APPROACH and back.depth_in_tissue_m == -5e-6
    assert contact.update(200e-6).punctured_now
    after = contact.update(-20e-6)
    assert after.state == TissueState.PUNCTURED and after.depth_in_tissue_m == -20e-6


def test_the_exponential_law_stiffens_and_inverts_exactly() -> None:
    linear = TissueModel(stiffness_n_per_m=50.0)
    stiff = TissueModel(stiffness_n_per_m=50.0, stiffening_length_m=40e-6)
    for force in (1e-4, 1e-3, 5e-3):
        assert stiff.force_n(stiff.tent_for_force_m(force)) == pytest.approx(force)
    assert stiff.force_n(5e-6) == pytest.approx(linear.force_n(5e-6), rel=0.07)
    assert stiff.force_n(80e-6) > 3 * linear.force_n(80e-6)
    assert stiff.puncture_tent_m < linear.puncture_tent_m
    big = TissueModel(stiffness_n_per_m=50.0, stiffening_length_m=1e-2)
    # delta_p = l ln(1 + F_p / (k l)) = F_p / k (1 - delta_p / (2 l) + ...)
    assert big.puncture_tent_m == pytest.approx(linear.puncture_tent_m * (1 - 0.005), rel=1e-4)


@pytest.mark.parametrize(
    ("field", "value"),
    [("stiffness_n_per_m", 0.0), ("puncture_force_n", -1e-3), ("stiffening_length_m", 0.0),
     ("rpe_coupling", 1.5)],
)  # fmt: skip
def test_bad_tissue_parameters_raise_naming_them(field: str, value: float) -> None:
    with pytest.raises(InvalidInputError) as err:
        TissueModel(**{field: value})
    assert err.value.name == field


def test_a_non_finite_tip_depth_raises() -> None:
    with pytest.raises(InvalidInputError):
        TissueContact().update(float("nan"))
