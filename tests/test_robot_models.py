"""The control core over any robot model: tasks, solvers and runs on iRAM!S, UR5 and Panda."""

from __future__ import annotations

import numpy as np
import pytest

from rcmplan import Iramis, IramisParameters, JointChain, SerialArm, StraightNeedle
from rcmplan.compiled.runner import kernel_params
from rcmplan.control import PinvSolver
from rcmplan.control.augmented import augmented_jacobian, extended_task
from rcmplan.control.targets import rcm_target, solve_pose
from rcmplan.control.tasks import (
    NeedleAngles,
    NeedleBase,
    Posture,
    RcmPoint,
    TipPosition,
)
from rcmplan.controller import Controller
from rcmplan.exceptions import InvalidInputError, UnreachableTargetError
from rcmplan.job import run_scenario
from rcmplan.robot.arms import needle_arm
from rcmplan.robot.registry import ROBOTS, make_robot
from rcmplan.robot.shipped import shipped_arm
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.scene.procedures import injection
from rcmplan.scene.scenario import load_scenario
from rcmplan.sim.kinematic import KinematicPlant

from chain_oracle import jacobian_derivatives
from chain_oracle import singular_terms as singular_terms_oracle
from fd import fd_jacobian

TASKS = (TipPosition(), NeedleAngles(), RcmPoint(), NeedleBase(), Posture())


@pytest.fixture(scope="module", params=["iramis", "ur5", "panda"])
def model(request: pytest.FixtureRequest):
    return make_robot(request.param)


def _near_home(model, rng: np.random.Generator) -> np.ndarray:
    q = model.home.copy()
    q[list(model.active)] += rng.uniform(-0.05, 0.05, len(model.active)) * (
        0.1 if model.name == "iramis" else 1.0
    )
    return q


@pytest.mark.parametrize("task", TASKS, ids=lambda t: type(t).__name__)
def test_every_task_jacobian_equals_finite_differences(model, task, rng) -> None:
    active = list(model.active)
    for _ in range(3):
        q0, lam0 = _near_home(model, rng), 0.6

        def f(x: np.ndarray, q0: np.ndarray = q0) -> np.ndarray:
            q = q0.copy()
            q[active] = x[:-1]
            return task.value(model, q, float(x[-1]))

        x = np.append(q0[active], lam0)
        J = task.jacobian(model, q0, lam0)
        assert pytest.approx(fd_jacobian(f, x), abs=2e-7) == J


def test_the_thesis_angle_rows_are_the_geometric_angular_velocities(model, rng) -> None:
    q = _near_home(model, rng)
    J = augmented_jacobian(model, q, 0.5, "thesis")[1:3]
    assert pytest.approx(model.needle_angular_jacobian(q)[1:3], abs=1e-15) == J


def test_a_satisfied_task_gives_zero_motion(model) -> None:
    q, lam = model.home, 0.5
    d_q, d_lam = PinvSolver().step(model, q, lam, extended_task(model, q, lam), np.zeros(6))
    assert np.abs(d_q).max() == 0.0
    assert d_lam == 0.0


def test_solve_pose_realises_reachable_targets(model) -> None:
    eye = default_eye(model)
    pts = default_points(eye)
    for name in ("p3", "p4", "p5", "p6", "p7"):
        target = rcm_target(getattr(pts, name), eye.port)
        pose = solve_pose(model, target)
        assert extended_task(model, pose.q, pose.lam) == pytest.approx(target, abs=1e-9)


@pytest.mark.parametrize("name", ["iramis", "ur5", "panda"])
def test_the_default_injection_holds_the_rcm_within_a_micrometre(name: str) -> None:
    scenario = load_scenario("default" if name == "iramis" else name)
    result = run_scenario(scenario)
    summary = result.summary()
    assert summary["status"] == "ok"
    assert summary["robot"] == name
    assert summary["max_rcm_deviation_m"] <= 1e-6
    assert summary["max_tip_error_m"] <= 1e-6


def test_the_redundant_arm_moves_in_the_null_space_towards_home() -> None:
    panda = make_robot("panda")
    q = panda.home.copy()
    q[2] += 0.2  # joint 3 away from home: the task is unchanged by a null-space motion
    target = extended_task(panda, q, 0.5)
    d_q, _ = PinvSolver(posture_gain=0.5).step(panda, q, 0.5, target, np.zeros(6))
    J = augmented_jacobian(panda, q, 0.5)
    assert np.abs(J[:, :-1] @ d_q).max() < 1e-12  # no task motion
    assert d_q[2] < 0.0  # joint 3 moves back towards home


def test_an_iramis_subclass_with_other_kinematics_runs_on_the_reference_path() -> None:
    class Tilted(Iramis):
        def needle_point(self, q, lam):  # type: ignore[no-untyped-def]
            return super().needle_point(q, lam) + np.array([0.0, 0.0, 1e-3 * lam])

    assert kernel_params(Iramis()) is not None
    assert kernel_params(Tilted()) is None
    assert kernel_params(Iramis(IramisParameters(l6=0.08))) is not None


def test_the_subclass_run_matches_its_own_reference_loop() -> None:
    class Tilted(Iramis):
        def needle_point(self, q, lam):  # type: ignore[no-untyped-def]
            return super().needle_point(q, lam) + np.array([0.0, 0.0, 1e-3 * lam])

    robot = Tilted()
    eye = default_eye(robot)
    phases = injection(robot, eye, default_points(eye))[:1]
    log = Controller(KinematicPlant(robot), PinvSolver()).run(phases)
    tips = np.array([robot.tip(q) for q in log.joints])
    assert tips == pytest.approx(log.tip, abs=1e-15)  # the log used the subclass's geometry


def test_a_robot_with_too_few_joints_is_refused_naming_the_count() -> None:
    chain = JointChain.from_dh(Iramis().chain)
    four = JointChain(chain.joints[:4], tip=np.eye(4))
    with pytest.raises(InvalidInputError, match="4 moving joints"):
        SerialArm(four, StraightNeedle(0.05), np.zeros(4))


def test_a_roll_joint_that_moves_the_needle_is_refused() -> None:
    arm = shipped_arm("ur5")
    with pytest.raises(InvalidInputError, match="roll_joint"):
        SerialArm(arm.chain, arm.needle, arm.home, roll_joint=0)


def test_a_target_no_joints_reach_is_refused_before_motion() -> None:
    ur5 = make_robot("ur5")
    far = ur5.tip(ur5.home) + np.array([-2.0, 0.0, 0.0])  # 2 m beyond the arm
    with pytest.raises(UnreachableTargetError, match=r"no joints of ur5.*lies 2\.\d+ m from"):
        solve_pose(ur5, rcm_target(far, far + np.array([0.05, 0.0, 0.0])))
    assert ur5.reach < 2.0


def test_an_eye_beyond_the_arm_is_refused_before_motion_naming_the_distance() -> None:
    ur5 = make_robot("ur5")
    eye = default_eye(ur5, trocar_offset=(-1.5, 0.0, 0.0))  # 1.5 m in front of the tip
    with pytest.raises(UnreachableTargetError, match=r"m from the arm's base, which reaches"):
        injection(ur5, eye, default_points(eye))


def test_unknown_robot_names_list_the_registered_ones() -> None:
    with pytest.raises(InvalidInputError, match="iramis, panda, ur5"):
        make_robot("kuka")
    assert set(ROBOTS) == {"iramis", "ur5", "panda"}


def test_a_needle_arm_points_its_needle_along_minus_x_at_home() -> None:
    arm = shipped_arm("panda")
    placed = needle_arm(arm.chain, arm.home, "again")
    axis = placed.needle_axis(placed.home)
    assert axis[0] < -0.99
    assert abs(axis[1]) < 1e-12


def test_robot_list_names_every_robot(capsys: pytest.CaptureFixture[str]) -> None:
    from rcmplan.cli import main

    assert main(["robot", "--list", "--json"]) == 0
    import json

    names = [r["name"] for r in json.loads(capsys.readouterr().out)["robots"]]
    assert names == ["iramis", "panda", "ur5"]


def test_inject_with_robot_writes_the_robot_into_the_summary(tmp_path, capsys) -> None:
    import json

    from rcmplan.cli import main

    code = main(["inject", "--robot", "ur5", "--scenario", "ur5", "--no-plots", "--json",
                 "--out", str(tmp_path)])  # fmt: skip
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert code == 0
    assert summary["robot"] == "ur5"
    assert json.loads(capsys.readouterr().out)["robot"] == "ur5"


@pytest.mark.parametrize("bad_q", [np.zeros(3), np.full(6, np.nan), "abc", np.zeros((2, 6))])
def test_an_arm_refuses_malformed_joints_naming_q(bad_q) -> None:
    ur5 = make_robot("ur5")
    with pytest.raises(InvalidInputError, match=r"^q = "):
        ur5.needle_point(bad_q, 0.5)
    with pytest.raises(InvalidInputError, match=r"^q = "):
        ur5.needle_point_jacobian(bad_q, 0.5)


@pytest.mark.parametrize("bad_lam", [np.nan, np.inf, "x"])
def test_an_arm_refuses_a_non_finite_lambda(bad_lam) -> None:
    ur5 = make_robot("ur5")
    with pytest.raises(InvalidInputError, match=r"^lam = "):
        ur5.needle_point(ur5.home, bad_lam)


@pytest.mark.parametrize("name", ["ur5", "panda"])
def test_an_arms_singular_gradient_equals_finite_differences_of_its_measure(name: str) -> None:
    arm = make_robot(name)
    rng = np.random.default_rng(3)
    for _ in range(10):
        q = arm.home + rng.normal(scale=0.3, size=arm.home.shape)
        value, grad = arm.singular_terms(q)
        assert value[0] == pytest.approx(arm.singularity_measure(q), rel=1e-12)
        fd = fd_jacobian(lambda x: np.array([arm.singularity_measure(x)]), q)
        np.testing.assert_allclose(grad, fd, rtol=0, atol=1e-6 * np.abs(fd).max())


def test_chain_jacobian_derivatives_equal_finite_differences_with_prismatic_joints() -> None:
    chain = JointChain.from_dh(Iramis().chain)  # revolute and prismatic joints
    assert chain.prismatic.any() and not chain.prismatic.all()
    rng = np.random.default_rng(4)
    point = np.array([0.01, -0.02, 0.03])

    def jac(q: np.ndarray) -> np.ndarray:
        return chain.jacobian(q, point)

    for _ in range(5):
        q = rng.uniform(-0.3, 0.3, chain.n)
        T = chain.frames(q)
        d = jacobian_derivatives(chain, T, jac(q))
        for j in range(chain.n):
            fd = fd_jacobian(lambda x, j=j: jac(x).ravel(), q)[:, j].reshape(6, chain.n)
            np.testing.assert_allclose(d[j], fd, rtol=0, atol=1e-7)


@pytest.mark.parametrize("name", ["ur5", "panda"])
def test_an_arms_singular_terms_equal_the_svd_oracle_at_random_poses(name: str) -> None:
    """Anywhere within the joint limits: the kernel's measure and gradient equal numpy's SVD
    formulation, and the gradient the measure's finite differences, where both extreme
    singular values are simple (the gradient exists) and the pose is not singular."""
    arm = make_robot(name)
    rng = np.random.default_rng(11)
    lower, upper = np.maximum(arm.lower, -np.pi), np.minimum(arm.upper, np.pi)
    checked = 0
    for _ in range(200):
        q = rng.uniform(lower, upper)
        value, grad = arm.singular_terms(q)
        ref_value, ref_grad = singular_terms_oracle(arm, q)
        assert value[0] == arm.singularity_measure(q)
        assert value[0] == pytest.approx(ref_value[0], rel=1e-10)
        s = np.linalg.svd(_measure_matrix(arm, q), compute_uv=False)
        if s[-1] / s[0] < 1e-3 or min(s[0] - s[1], s[-2] - s[-1]) < 1e-3 * s[0]:
            continue
        scale = np.abs(ref_grad).max()
        np.testing.assert_allclose(grad, ref_grad, rtol=0, atol=1e-9 * scale)
        fd = fd_jacobian(lambda x: np.array([arm.singularity_measure(x)]), q)
        np.testing.assert_allclose(grad, fd, rtol=0, atol=1e-6 * scale)
        checked += 1
    assert checked >= 100


def _measure_matrix(arm: SerialArm, q: np.ndarray) -> np.ndarray:
    """M = [J_tip / l; N J_omega] over the active joints (the measure's matrix)."""
    a = arm.needle_axis(q)
    helper = np.zeros(3)
    helper[int(np.argmin(np.abs(a)))] = 1.0
    n1 = np.cross(a, helper)
    n1 /= np.linalg.norm(n1)
    N = np.array([n1, np.cross(a, n1)])
    J_tip = arm.tip_jacobian(q)[:, :-1] / arm.needle_length
    return np.vstack([J_tip, N @ arm.needle_angular_jacobian(q)[:, :-1]])
