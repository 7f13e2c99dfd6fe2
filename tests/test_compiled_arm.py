"""The compiled kernels of any serial arm equal the Python model: X_ext, J_a, pinv and DLS steps,
the singularity measure."""

from __future__ import annotations

import numba  # noqa: F401  (the `fast` extra: without it these tests fail, they do not skip)
import numpy as np
import pytest

from rcmplan import Iramis
from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.arm import FastArm, arm_supported
from rcmplan.compiled.records import REC_COLUMNS, REC_WIDTH, record_columns, record_width
from rcmplan.control.augmented import augmented_jacobian, extended_task
from rcmplan.control.solvers import DlsSolver, PinvSolver
from rcmplan.exceptions import InvalidInputError, UnreachableTargetError
from rcmplan.robot.chain import JointChain
from rcmplan.robot.model import SerialArm
from rcmplan.robot.needle import StraightNeedle
from rcmplan.robot.shipped import shipped_arm

TOL = 1e-12
N_CONFIGS = 50


def dh_iramis() -> SerialArm:
    """iRAM!S's DH table as a generic chain holding its needle (tip frame z along the needle)."""
    robot = Iramis()
    l6 = robot.params.l6
    mount = np.eye(4)
    mount[2, 3] = -l6  # the needle base l6 behind the tip frame, the needle along its z
    chain = JointChain.from_dh(robot.chain, name="iramis-dh")
    return SerialArm(chain, StraightNeedle(l6, mount), np.zeros(6), name="iramis-dh",
                     roll_joint=5)  # fmt: skip


def make_arm(name: str) -> SerialArm:
    return dh_iramis() if name == "iramis-dh" else shipped_arm(name)


@pytest.fixture(scope="module", params=["ur5", "panda", "iramis-dh"])
def arm(request: pytest.FixtureRequest) -> SerialArm:
    return make_arm(request.param)


@pytest.fixture(scope="module")
def fast(arm: SerialArm) -> FastArm:
    return FastArm(arm, posture_gain=0.05)


def near_home(arm: SerialArm, rng: np.random.Generator) -> tuple[np.ndarray, float, np.ndarray]:
    """Joints within 0.1 of home, lambda in [0.2, 0.8] and an X_ext target nearby."""
    n = arm.chain.n
    q = arm.home + rng.uniform(-0.1, 0.1, n)
    lam = float(rng.uniform(0.2, 0.8))
    target = extended_task(arm, q + rng.uniform(-2e-3, 2e-3, n), lam + 0.01)
    return q, lam, target


def test_the_shipped_arms_and_a_dh_arm_are_supported(arm: SerialArm) -> None:
    assert arm_supported(arm)


def test_task_and_augmented_jacobian_equal_the_model(arm: SerialArm, fast: FastArm) -> None:
    rng = np.random.default_rng(20180507)
    for _ in range(N_CONFIGS):
        q, lam, _ = near_home(arm, rng)
        np.testing.assert_allclose(fast.task(q, lam), extended_task(arm, q, lam), 0, TOL)
        for variant in ("exact", "thesis"):
            ref = augmented_jacobian(arm, q, lam, variant)
            np.testing.assert_allclose(fast.augmented_jacobian(q, lam, variant), ref, 0, TOL)


def test_pinv_step_equals_the_pinv_solver(arm: SerialArm, fast: FastArm) -> None:
    rng = np.random.default_rng(7)
    for _ in range(N_CONFIGS):
        q, lam, target = near_home(arm, rng)
        K = rng.uniform(0.5, 1.5, 6)
        for variant in ("exact", "thesis"):
            solver = PinvSolver(K=tuple(K), variant=variant, posture_gain=0.05)
            dq, dlam = solver.step(arm, q, lam, target, solver.error(arm, q, lam, target))
            got = fast.step(q, lam, target, K, variant=variant)
            np.testing.assert_allclose(got, [*dq, dlam], 0, TOL)


def test_dls_step_equals_the_dls_solver(arm: SerialArm, fast: FastArm) -> None:
    rng = np.random.default_rng(11)
    solver = DlsSolver(damping=1e-3)
    for i in range(N_CONFIGS):
        q, lam, target = near_home(arm, rng)
        if i % 5 == 0:  # a pivot: the target's tip on its trocar
            target[3:] = arm.tip(q + 1e-3)
            target[0] = target[3]
        dq, dlam = solver.step(arm, q, lam, target, solver.error(arm, q, lam, target))
        np.testing.assert_allclose(fast.dls_step(q, lam, target, 1e-3), [*dq, dlam], 0, TOL)


def test_step_fills_and_returns_out(arm: SerialArm, fast: FastArm) -> None:
    q, lam, target = near_home(arm, np.random.default_rng(3))
    out = np.empty(len(arm.active) + 1)
    assert fast.step(q, lam, target, np.ones(6), out) is out


def test_a_satisfied_task_at_home_gives_zero_motion(arm: SerialArm, fast: FastArm) -> None:
    target = extended_task(arm, arm.home, 0.5)
    np.testing.assert_allclose(fast.step(arm.home, 0.5, target, np.ones(6)), 0.0, 0, TOL)


def test_dls_step_raises_when_the_target_fixes_no_tip() -> None:
    fast = FastArm(make_arm("ur5"))
    q = fast.arm.home
    target = np.array([0.1, 0.0, 0.5 * np.pi, 0.3, 0.0, 0.2])  # needle along -y
    with pytest.raises(UnreachableTargetError, match="perpendicular"):
        fast.dls_step(q, 0.5, target, 1e-3)


class ShiftedNeedle(SerialArm):
    """An arm whose needle points are moved 1 mm in z: other geometry than its chain."""

    def needle_point(self, q: np.ndarray, lam: float) -> np.ndarray:
        return super().needle_point(q, lam) + np.array([0.0, 0.0, 1e-3])


def test_a_subclass_overriding_needle_point_is_unsupported() -> None:
    ur5 = make_arm("ur5")
    shifted = ShiftedNeedle(ur5.chain, ur5.needle, ur5.home, "shifted", roll_joint=5)
    assert not arm_supported(shifted)
    with pytest.raises(InvalidInputError, match="shifted"):
        FastArm(shifted)


def test_iramis_in_closed_form_is_not_an_arm_for_these_kernels() -> None:
    assert not arm_supported(Iramis())


def test_singularity_measure_equals_the_model(arm: SerialArm, fast: FastArm) -> None:
    k = fast_cache.chain_kernels()
    rng = np.random.default_rng(13)
    for _ in range(N_CONFIGS):
        q = arm.home + rng.uniform(-0.5, 0.5, arm.chain.n)
        k.frames(fast.A, fast.ix, q, fast.W)
        ref = arm.singularity_measure(q)
        assert k.singularity_measure(fast.A, fast.ix, fast.W) == pytest.approx(ref, rel=1e-9)
        for thr in (0.5 * ref, 0.999 * ref, 1.001 * ref, 2.0 * ref):
            assert k.is_singular(fast.A, fast.ix, fast.W, thr) == (ref < thr)


def test_a_pose_on_a_singularity_is_singular_for_any_positive_threshold() -> None:
    ur5 = make_arm("ur5")
    fast, k = FastArm(ur5), fast_cache.chain_kernels()
    q = ur5.home.copy()
    q[2] = 0.0  # elbow stretched: the tip loses its radial direction
    k.frames(fast.A, fast.ix, q, fast.W)
    assert ur5.singularity_measure(q) < 1e-9
    assert k.is_singular(fast.A, fast.ix, fast.W, 1e-6)


def test_the_record_layout_for_six_joints_is_the_iramis_layout() -> None:
    assert record_columns(6) == REC_COLUMNS
    assert record_width(6) == REC_WIDTH == max(b for _, b in REC_COLUMNS.values())
    assert record_width(7) == max(b for _, b in record_columns(7).values())


def test_a_work_array_says_whose_frames_it_holds(arm: SerialArm, fast: FastArm) -> None:
    """The loop skips the frames only for exactly the joints they were computed at."""
    kin = fast_cache.chain_kernels()
    rng = np.random.default_rng(7)
    q = arm.home + rng.uniform(-0.1, 0.1, arm.chain.n)
    n = arm.chain.n
    W = kin.blank_work(kin.work_shape(n, int(fast.ix[1])), n)
    assert not kin.holds_frames(fast.ix, q, W)
    assert not kin.holds_frames(fast.ix, np.zeros(n), W)  # zeros are not frames of q = 0
    kin.frames(fast.A, fast.ix, q, W)
    assert kin.holds_frames(fast.ix, q.copy(), W)
    for k in range(arm.chain.n):  # one ulp on any joint is another configuration
        moved = q.copy()
        moved[k] = np.nextafter(moved[k], np.inf)
        assert not kin.holds_frames(fast.ix, moved, W)
    frames = W[: 4 * (arm.chain.n + 1)].copy()  # computing them again changes no bit
    kin.frames(fast.A, fast.ix, q, W)
    np.testing.assert_array_equal(W[: 4 * (arm.chain.n + 1)], frames)
