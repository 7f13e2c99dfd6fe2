"""The compiled target screen of a serial arm accepts what `solve_pose` accepts along a path and
raises its exceptions, messages and all, for what it refuses."""

from __future__ import annotations

from collections.abc import Iterator

import numba  # noqa: F401  (the `fast` extra: without it these tests fail, they do not skip)
import numpy as np
import pytest

from rcmplan.compiled import arm
from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.arm import arm_arrays, check_arm_targets
from rcmplan.compiled.runner import fast_check_targets
from rcmplan.control import PinvSolver
from rcmplan.control.targets import rcm_target, solve_pose
from rcmplan.controller import Controller
from rcmplan.exceptions import InvalidInputError, UnreachableTargetError
from rcmplan.robot.model import IK_ITERATIONS, IK_TOLERANCE, SerialArm
from rcmplan.robot.shipped import shipped_arm
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.scene.procedures import injection
from rcmplan.sim import KinematicPlant

from paths import use_path


@pytest.fixture(autouse=True)
def mode_restored() -> Iterator[None]:
    yield
    use_path(None)


@pytest.fixture(scope="module", params=["ur5", "panda"])
def robot(request: pytest.FixtureRequest) -> SerialArm:
    return shipped_arm(request.param)


def injection_targets(robot: SerialArm) -> list[np.ndarray]:
    """The X_ext targets of every RCM phase of the default injection checked before motion
    (those with fixed targets, as `Controller.run` checks them)."""
    eye = default_eye(robot)
    phases = injection(robot, eye, default_points(eye))
    return [ph.plan(robot.home) for ph in phases if ph.kind == "rcm" and not callable(ph.targets)]


def reference_check(robot: SerialArm, targets: np.ndarray) -> None:
    use_path("off")
    try:
        Controller(KinematicPlant(robot), PinvSolver()).check_targets(targets)
    finally:
        use_path(None)


def same_error(robot: SerialArm, targets: np.ndarray, error: type[Exception]) -> None:
    """The screen raises what the reference check raises, with the same message."""
    with pytest.raises(error) as ref:
        reference_check(robot, targets)
    with pytest.raises(error) as fast:
        check_arm_targets(robot, targets)
    assert str(fast.value) == str(ref.value)


def test_the_newton_kernel_finds_the_joints_needle_pose_finds(robot: SerialArm) -> None:
    k = fast_cache.chain_kernels()
    A, ix = arm_arrays(robot)  # type: ignore[misc]
    W = np.empty(k.work_shape(int(ix[0]), int(ix[1])))
    seed = None
    for x in injection_targets(robot)[1]:
        tip = robot.tip(solve_pose(robot, x, seed).q)
        ref = robot.needle_pose(tip, x[1], x[2], seed)
        q = (robot.home if seed is None else seed).copy()
        steps = k.needle_pose(A, ix, W, tip, x[1], x[2], q, IK_ITERATIONS, IK_TOLERANCE)
        assert 0 <= steps <= 5
        np.testing.assert_allclose(q, ref, rtol=0, atol=1e-9)
        seed = ref


def test_the_injection_targets_pass_without_the_python_check(robot: SerialArm, monkeypatch) -> None:
    calls = []
    monkeypatch.setattr(arm, "solve_pose", lambda *a: calls.append(a))
    for targets in injection_targets(robot):
        assert check_arm_targets(robot, targets)
    assert calls == []


def test_the_runner_screens_arm_targets(robot: SerialArm, monkeypatch) -> None:
    calls = []
    monkeypatch.setattr(arm, "check_arm_targets", lambda *a: calls.append(a) or True)
    monkeypatch.setattr("rcmplan.compiled.runner.check_arm_targets", arm.check_arm_targets)
    use_path("on")
    assert fast_check_targets(robot, injection_targets(robot)[1])
    assert len(calls) == 1


def test_a_target_beyond_the_arm_raises_the_reference_error(robot: SerialArm) -> None:
    targets = injection_targets(robot)[1].copy()
    far = robot.tip(robot.home) + np.array([-2.0, 0.0, 0.0])  # 2 m beyond the arm
    targets[20] = rcm_target(far, far + np.array([0.05, 0.0, 0.0]))
    same_error(robot, targets, UnreachableTargetError)


def test_a_target_the_rcm_cannot_reach_raises_the_reference_error(robot: SerialArm) -> None:
    targets = injection_targets(robot)[1].copy()
    targets[7, 0] += 0.2  # the tip 20 cm further along x: lambda far outside [0, 1]
    same_error(robot, targets, UnreachableTargetError)


def test_a_target_beyond_a_joint_travel_raises_the_reference_error(robot: SerialArm) -> None:
    narrow = shipped_arm(robot.name)  # a fresh model: its travel is narrowed below
    targets = injection_targets(narrow)[1]
    seed, poses = None, []
    for x in targets:
        seed = solve_pose(narrow, x, seed).q
        poses.append(seed)
    j = int(np.argmax(np.ptp(poses, axis=0)))
    narrow.upper[j] = float(np.median(np.array(poses)[:, j]))  # half the path beyond travel
    same_error(narrow, targets, UnreachableTargetError)


def test_a_target_that_fixes_no_tip_raises_the_reference_error(robot: SerialArm) -> None:
    targets = injection_targets(robot)[1].copy()
    targets[3, 1:3] = 0.0, 0.5 * np.pi  # needle along -y: tip x fixes no tip
    same_error(robot, targets, UnreachableTargetError)


def test_a_target_with_nan_raises_the_reference_error(robot: SerialArm) -> None:
    targets = injection_targets(robot)[1].copy()
    targets[5, 4] = np.nan
    same_error(robot, targets, InvalidInputError)


def test_a_subclass_of_serial_arm_is_not_screened(robot: SerialArm) -> None:
    class Other(SerialArm):
        pass

    other = Other(robot.chain, robot.needle, robot.home, "other", roll_joint=robot.chain.n - 1)
    assert not check_arm_targets(other, injection_targets(robot)[1])
