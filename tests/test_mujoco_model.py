"""The generated MJCF: files match the generator, bodies carry the DH frames, scenes step cleanly."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from rcmplan import Iramis
from rcmplan.sim.mujoco.files import ASSETS_DIR, load_model, model_files
from rcmplan.sim.mujoco.frames import quat_from_matrix
from rcmplan.sim.mujoco.inertia import ASSUMED_INERTIA
from rcmplan.sim.mujoco.plant import MujocoPlant
from rcmplan.sim.mujoco.scene import default_eye

UM = 1e-6
URAD = 1e-6


def rotation_angle(Ra: np.ndarray, Rb: np.ndarray) -> float:
    """Angle in rad of Ra^T Rb, accurate for small angles (from the skew part)."""
    M = Ra.T @ Rb
    w = 0.5 * np.array([M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1]])
    return math.atan2(float(np.linalg.norm(w)), 0.5 * (float(np.trace(M)) - 1.0))


@pytest.fixture(scope="module")
def kinematic() -> MujocoPlant:
    return MujocoPlant(mode="kinematic")


def test_committed_model_files_equal_the_generated_ones() -> None:
    for name, text in model_files(Iramis()).items():
        assert (ASSETS_DIR / name).read_text(encoding="utf-8") == text, name


def test_committed_scene_file_loads_from_disk() -> None:
    model = mujoco.MjModel.from_xml_path(str(ASSETS_DIR / "scene.xml"))
    assert model.nkey == 1 and model.key(0).name == "home"
    assert {model.camera(i).name for i in range(model.ncam)} == {"overview", "closeup"}


def test_quaternion_of_a_rotation_matrix_round_trips(rng: np.random.Generator) -> None:
    for _ in range(50):
        A = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        R = A * np.sign(np.linalg.det(A))
        out = np.zeros(9)
        mujoco.mju_quat2Mat(out, quat_from_matrix(R))
        np.testing.assert_allclose(out.reshape(3, 3), R, atol=1e-14)


def test_tip_pose_equals_forward_kinematics_at_200_random_slider_settings(
    kinematic: MujocoPlant, robot: Iramis, rng: np.random.Generator
) -> None:
    worst_p, worst_r, worst_gap = 0.0, 0.0, 0.0
    for s in rng.uniform(robot.lower, robot.upper, size=(200, 6)):
        kinematic.reset(s)
        T = robot.forward_kinematics(robot.joints_from_actuators(s))
        T_sim = kinematic.tip_pose()
        worst_p = max(worst_p, float(np.linalg.norm(T_sim[:3, 3] - T[:3, 3])))
        worst_r = max(worst_r, rotation_angle(T_sim[:3, :3], T[:3, :3]))
        worst_gap = max(worst_gap, kinematic.loop_gap())
    assert worst_p < UM
    assert worst_r < URAD
    assert worst_gap < UM


def test_bodies_carry_the_dh_frames(
    kinematic: MujocoPlant, robot: Iramis, rng: np.random.Generator
) -> None:
    ids = [kinematic.model.body(f"frame{i}").id for i in range(1, 7)]
    for s in rng.uniform(robot.lower, robot.upper, size=(10, 6)):
        kinematic.reset(s)
        frames = robot.chain.frames(robot.joints_from_actuators(s))
        for i, b in enumerate(ids, start=1):
            np.testing.assert_allclose(kinematic.data.xpos[b], frames[i][:3, 3], atol=1e-12)
            R = kinematic.data.xmat[b].reshape(3, 3)
            np.testing.assert_allclose(R, frames[i][:3, :3], atol=1e-12)


def test_simulated_joints_equal_joints_from_sliders(
    kinematic: MujocoPlant, robot: Iramis, rng: np.random.Generator
) -> None:
    s = rng.uniform(robot.lower, robot.upper)
    kinematic.reset(s)
    np.testing.assert_allclose(kinematic.joints(), robot.joints_from_actuators(s), atol=1e-12)
    np.testing.assert_allclose(
        kinematic.needle_base_position(),
        robot.needle_base(robot.joints_from_actuators(s)),
        atol=1e-12,
    )


def test_coupler_hinges_are_limited_below_ninety_degrees(robot: Iramis) -> None:
    model = load_model(robot)
    for name in ("q1", "q3"):
        j = model.joint(name)
        assert j.limited[0] == 1
        assert 0.9 < j.range[1] < 0.5 * math.pi
        assert j.range[0] == -j.range[1]


def test_moving_bodies_have_the_assumed_masses(robot: Iramis) -> None:
    model = load_model(robot)
    assert model.body("slider_L1").mass[0] == pytest.approx(ASSUMED_INERTIA["slider"].mass)
    assert model.body("frame2").mass[0] == pytest.approx(ASSUMED_INERTIA["stage1"].mass)
    count = {"slider": 4, "follower": 4, "guide": 2, "stage1": 1, "stage2": 1, "holder": 1}
    count["needle"] = 1
    total = sum(n * ASSUMED_INERTIA[kind].mass for kind, n in count.items())
    assert model.body("base").subtreemass[0] == pytest.approx(total)


def test_scene_sites_are_the_eye_points(robot: Iramis) -> None:
    eye = default_eye(robot)
    model = load_model(robot, eye)
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    np.testing.assert_allclose(data.site("trocar").xpos, eye.trocar, atol=1e-15)
    for i, p in enumerate(eye.targets):
        np.testing.assert_allclose(data.site(f"target_{i}").xpos, p, atol=1e-15)
    assert np.linalg.norm(eye.trocar - eye.centre) == pytest.approx(eye.radius)


def test_robot_file_steps_one_second_of_random_commands_without_warnings(
    robot: Iramis, rng: np.random.Generator
) -> None:
    model = load_model(robot, scene=False)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    lo, hi = model.actuator_ctrlrange[:, 0], model.actuator_ctrlrange[:, 1]
    for _ in range(100):  # a new random velocity command every 10 ms
        data.ctrl[:] = rng.uniform(lo, hi)
        mujoco.mj_step(model, data, nstep=100)
    assert data.time == pytest.approx(1.0)
    assert np.isfinite(data.qpos).all()
    assert [int(w.number) for w in data.warning] == [0] * len(data.warning)


def test_scene_steps_one_second_of_random_slider_commands_without_warnings(
    robot: Iramis, rng: np.random.Generator
) -> None:
    plant = MujocoPlant(robot, mode="dynamic")
    for _ in range(100):
        plant.command_actuators(rng.uniform(robot.lower, robot.upper))
        for _ in range(10):
            plant.advance()
    assert plant.data.time == pytest.approx(1.0)
    assert plant.warnings() == {}
    assert plant.loop_gap() < 10 * UM
