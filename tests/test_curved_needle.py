"""The curved needle and the third rotation: geometry, validation, exact Jacobians."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.curved import CurvedTipRobot, curved_robot
from rcmplan.robot.curved_needle import CurvedNeedle
from rcmplan.robot.needle import angles_from_axis
from rcmplan.robot.registry import make_robot

from fd import fd_jacobian


@pytest.fixture(scope="module", params=["iramis", "ur5"])
def curved(request: pytest.FixtureRequest) -> CurvedTipRobot:
    base = make_robot(request.param)
    return curved_robot(base, CurvedNeedle(base.needle_length, 12e-3, 0.4))


def _near_home(robot: CurvedTipRobot, rng: np.random.Generator) -> np.ndarray:
    q = robot.home.copy()
    act = list(robot.active)
    q[act] += rng.uniform(-0.05, 0.05, len(act)) * (0.1 if robot.name == "iramis" else 1.0)
    q[robot.roll_joint] += rng.uniform(-1.0, 1.0)
    return q


def test_the_arc_ends_at_the_tip_with_its_tangent_turned_by_alpha() -> None:
    n = CurvedNeedle(0.05, 0.01, 0.5)
    assert n.tip_local() == pytest.approx(
        [0.01 * (1 - math.cos(0.5)), 0.0, 0.05 + 0.01 * math.sin(0.5)]
    )
    assert math.acos(n.tip_direction_local() @ [0, 0, 1]) == pytest.approx(0.5)
    assert n.arc_length == pytest.approx(0.005)


@pytest.mark.parametrize(
    "kwargs, name",
    [({"radius": 0.5e-3}, "needle.radius"), ({"arc_angle": 2.0}, "needle.arc_angle"),
     ({"arc_angle": -0.1}, "needle.arc_angle"), ({"shaft_length": 0.0}, "needle.shaft_length")],
)  # fmt: skip
def test_a_needle_out_of_range_raises_naming_the_value_and_range(kwargs, name) -> None:
    args = {"shaft_length": 0.05, "radius": 0.01, "arc_angle": 0.3, **kwargs}
    with pytest.raises(InvalidInputError, match=name) as info:
        CurvedNeedle(**args)
    assert "valid: a finite number in" in str(info.value)


def test_a_shaft_of_another_length_than_the_robot_holds_raises() -> None:
    with pytest.raises(InvalidInputError, match="shaft_length"):
        CurvedTipRobot(make_robot("iramis"), CurvedNeedle(0.05))


def test_the_roll_joins_the_active_joints_only_when_the_needle_bends() -> None:
    base = make_robot("iramis")
    assert curved_robot(base, CurvedNeedle(base.needle_length)).active == (0, 1, 2, 3, 4, 5)
    straight = curved_robot(base, CurvedNeedle(base.needle_length, arc_angle=0.0))
    assert straight.active == base.active
    assert straight.needle_kind == "straight"


def test_alpha_zero_gives_the_straight_needle_exactly(rng) -> None:
    for name in ("iramis", "ur5"):
        base = make_robot(name)
        r = curved_robot(base, CurvedNeedle(base.needle_length, arc_angle=0.0))
        q = base.home + 0.01 * rng.standard_normal(len(base.home))
        assert np.array_equal(r.tip(q), base.tip(q))
        assert np.array_equal(r.tip_jacobian(q), base.tip_jacobian(q))
        assert np.array_equal(r.needle_point_jacobian(q, 0.3), base.needle_point_jacobian(q, 0.3))
        assert np.array_equal(r.needle_angles_jacobian(q), base.needle_angles_jacobian(q))


def test_the_roll_is_q5_on_iramis(rng) -> None:
    base = make_robot("iramis")
    r = curved_robot(base, CurvedNeedle(base.needle_length))
    for _ in range(5):
        q = 0.2 * rng.standard_normal(6)
        assert r.roll(q) == pytest.approx(q[5], abs=1e-12)


def test_the_roll_turns_the_tip_about_the_shaft(curved, rng) -> None:
    q = _near_home(curved, rng)
    q2 = q.copy()
    q2[curved.roll_joint] += 0.3
    a, p0 = curved.needle_axis(q), curved.needle_point(q, 0.0)
    assert curved.needle_axis(q2) == pytest.approx(a, abs=1e-10)
    r1 = np.linalg.norm(np.cross(curved.tip(q) - p0, a))
    r2 = np.linalg.norm(np.cross(curved.tip(q2) - p0, a))
    assert r1 > 1e-4 and r2 == pytest.approx(r1, abs=1e-10)
    assert np.linalg.norm(curved.tip(q2) - curved.tip(q)) > 1e-5


QUANTITIES = {
    "tip": (lambda r, q, lam: r.tip(q), lambda r, q, lam: r.tip_jacobian(q)),
    "shaft point": (lambda r, q, lam: r.needle_point(q, lam),
                    lambda r, q, lam: r.needle_point_jacobian(q, lam)),
    "needle angles": (lambda r, q, lam: np.array(angles_from_axis(r.needle_axis(q))),
                      lambda r, q, lam: r.needle_angles_jacobian(q)),
    "roll": (lambda r, q, lam: np.array([r.roll(q)]), lambda r, q, lam: r.roll_jacobian(q)[None]),
}  # fmt: skip


@pytest.mark.parametrize("quantity", sorted(QUANTITIES))
def test_every_curved_needle_jacobian_equals_finite_differences(curved, quantity, rng) -> None:
    value, jacobian = QUANTITIES[quantity]
    active = list(curved.active)
    for _ in range(3):
        q0, lam0 = _near_home(curved, rng), 0.6

        def f(x: np.ndarray, q0: np.ndarray = q0) -> np.ndarray:
            q = q0.copy()
            q[active] = x[:-1]
            return value(curved, q, float(x[-1]))

        J = jacobian(curved, q0, lam0)
        assert J.shape[1] == len(active) + 1
        assert pytest.approx(fd_jacobian(f, np.append(q0[active], lam0)), abs=2e-7) == J
