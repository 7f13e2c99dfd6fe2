"""Pipeline stages: the clutch re-indexes without a jump and holds while released, the scaling
divides and rotates, the pipeline chains them, and targets are rcm_target's."""

from __future__ import annotations

import numpy as np
import pytest

from rcmplan.control.targets import rcm_target
from rcmplan.exceptions import InvalidInputError
from rcmplan.scene.eye import default_eye, eye_frame
from rcmplan.teleop import MasterSample, NoFilter
from rcmplan.teleop.clutch import Clutch
from rcmplan.teleop.fixtures import Fixtures
from rcmplan.teleop.pipeline import Pipeline, TargetMaker
from rcmplan.teleop.scaling import MotionScaling

TIP = (0.1, 0.2, 0.3)


def test_engaging_re_indexes_so_the_first_displacement_is_zero() -> None:
    clutch = Clutch(TIP)
    assert clutch.step(0.0, True, (5.0, 6.0, 7.0), TIP) == (0.0, 0.0, 0.0)
    assert clutch.step(0.001, True, (5.5, 6.0, 7.0), TIP) == (0.5, 0.0, 0.0)
    assert clutch.tip_anchor == TIP


def test_released_the_clutch_holds_the_tip_where_it_was_at_the_release() -> None:
    clutch = Clutch(TIP)
    clutch.step(0.0, True, (0.0, 0.0, 0.0), TIP)
    at_release = (0.11, 0.2, 0.3)
    assert clutch.step(1.0, False, (9.0, 9.0, 9.0), at_release) is None
    assert clutch.hold == at_release
    assert clutch.step(1.5, False, (-9.0, 9.0, 9.0), (0.5, 0.5, 0.5)) is None
    assert clutch.hold == at_release  # the tip measured later does not move the hold point
    assert [e.kind for e in clutch.events] == ["engaged", "released"]


def test_re_engaging_after_the_hand_moved_does_not_jump_the_needle() -> None:
    scaling = MotionScaling(20.0, np.eye(3))
    pipe = Pipeline(NoFilter(), scaling)
    pipe.reset((0.0, 0.0, 0.0), TIP)

    def step(t: float, master: tuple[float, float, float], engaged: bool, tip=TIP):
        return pipe.step(t, MasterSample(t, np.array(master), engaged), tip)

    assert step(0.0, (0.0, 0.0, 0.0), False) == TIP
    assert step(0.1, (0.0, 0.0, 0.0), True) == TIP
    moved = step(0.2, (0.02, 0.0, 0.0), True)
    assert moved == pytest.approx((TIP[0] + 0.001, TIP[1], TIP[2]))
    step(0.3, (0.02, 0.0, 0.0), False, tip=moved)
    step(0.4, (-0.5, 0.3, 0.1), False, tip=moved)  # the hand repositions, released
    assert step(0.5, (-0.5, 0.3, 0.1), True, tip=moved) == pytest.approx(moved, abs=0.0)
    after = step(0.6, (-0.48, 0.3, 0.1), True, tip=moved)
    assert after == pytest.approx((moved[0] + 0.001, moved[1], moved[2]))


def test_scaling_divides_by_the_scale_in_the_base_frame() -> None:
    R = eye_frame(default_eye())
    scaling = MotionScaling(25.0, R)
    d = (0.01, -0.02, 0.005)
    assert np.array(scaling.apply(d)) == pytest.approx(R @ np.array(d) / 25.0, abs=1e-18)
    assert scaling.to_master(np.array(scaling.apply(d))) == pytest.approx(np.array([d]), abs=1e-15)


@pytest.mark.parametrize("scale", [0.5, 51.0, float("nan")])
def test_a_scale_outside_1_to_50_is_refused(scale: float) -> None:
    with pytest.raises(InvalidInputError, match="scale"):
        MotionScaling(scale, np.eye(3))


def test_a_reflection_is_not_a_master_frame() -> None:
    with pytest.raises(InvalidInputError, match="rotation"):
        MotionScaling(10.0, np.diag([1.0, 1.0, -1.0]))


def test_targets_are_rcm_targets_of_the_closest_allowed_tip() -> None:
    eye = default_eye()
    box = Fixtures().workspace(eye)
    maker = TargetMaker(eye.port, box, eye.center, eye.retina_radius - 0.25e-3)
    R = eye_frame(eye)
    inside = eye.center + R @ np.array([1e-3, -2e-3, 5e-3])
    assert maker.target(tuple(inside)) == pytest.approx(rcm_target(inside, eye.port), abs=1e-15)
    outside = eye.center + R @ np.array([9e-3, 0.0, 5e-3])  # beyond the +x face at 6 mm
    clamped = eye.center + R @ np.array([6e-3, 0.0, 5e-3])
    assert maker.target(tuple(outside)) == pytest.approx(rcm_target(clamped, eye.port), abs=1e-12)
    deep = eye.center + R @ np.array([1e-3, 0.0, 11.5e-3])  # past the retina
    radial = (deep - eye.center) / np.linalg.norm(deep - eye.center)
    on_margin = eye.center + (eye.retina_radius - 0.25e-3) * radial  # the closest allowed tip
    assert maker.target(tuple(deep)) == pytest.approx(rcm_target(on_margin, eye.port), abs=1e-12)
    assert eye.distance_to_retina(maker.allowed(tuple(deep))) == pytest.approx(0.25e-3, abs=1e-15)
