"""The run report's singular figures: one call per log (`smallest_singular_values`) gives what
the per-record singular terms give, on iRAM!S, an arm and a curved needle, and refuses joints
of the wrong shape."""

from __future__ import annotations

import numpy as np
import pytest

import rcmplan as rp
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.curved import CurvedTipRobot
from rcmplan.robot.curved_needle import CurvedNeedle


def joints_near_home(robot: rp.RobotModel, n: int, seed: int) -> np.ndarray:
    """n joint vectors about the home pose (0.3 rad / 3 mm), some towards a singular pose."""
    rng = np.random.default_rng(seed)
    return robot.home + 0.3 * rng.standard_normal((n, len(robot.home)))


@pytest.mark.parametrize("name", ["iramis", "ur5", "panda"])
def test_batch_equals_the_per_record_terms(name: str) -> None:
    robot = rp.make_robot(name)
    Q = joints_near_home(robot, 200, 1)
    Q[0, :] = robot.home
    batch = robot.smallest_singular_values(Q)
    each = np.array([np.min(robot.singular_terms(q)[0]) for q in Q])
    assert batch.shape == (200,)
    np.testing.assert_allclose(batch, each, rtol=0, atol=1e-13)
    assert np.ptp(batch) > 1e-3  # the poses differ in the measure, so the test can fail


def test_a_curved_needle_reports_its_base_robot_s_values() -> None:
    base = rp.make_robot("ur5")
    robot = CurvedTipRobot(base, CurvedNeedle(base.needle_length))
    Q = joints_near_home(base, 20, 2)
    np.testing.assert_array_equal(
        robot.smallest_singular_values(Q), base.smallest_singular_values(Q)
    )


@pytest.mark.parametrize("name", ["iramis", "ur5"])
def test_joints_of_the_wrong_shape_are_refused(name: str) -> None:
    robot = rp.make_robot(name)
    with pytest.raises(InvalidInputError, match="shape"):
        robot.smallest_singular_values(np.zeros((3, len(robot.home) + 1)))
    with pytest.raises(InvalidInputError, match="2-D"):
        robot.smallest_singular_values(robot.home)


def test_a_subclass_with_its_own_singular_terms_is_reported_by_them() -> None:
    from rcmplan.analysis.limits import singular_values

    class Halved(rp.Iramis):
        def singular_terms(self, q):  # type: ignore[no-untyped-def]
            values, grad = super().singular_terms(q)
            return 0.5 * values, 0.5 * grad

    plain = rp.Iramis()
    Q = joints_near_home(plain, 5, 3)

    class Log:  # the one field singular_values reads
        joints = Q

        def __len__(self) -> int:
            return len(Q)

    full = np.array([np.min(plain.singular_terms(q)[0]) for q in Q])
    np.testing.assert_allclose(singular_values(Log(), plain), full, rtol=0, atol=1e-15)  # type: ignore[arg-type]
    np.testing.assert_allclose(singular_values(Log(), Halved()), 0.5 * full, rtol=0, atol=1e-15)  # type: ignore[arg-type]
