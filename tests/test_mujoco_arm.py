"""The MuJoCo model and plant of the serial arms (UR5, Panda): loading, kinematic agreement,
both modes against the kinematic plant, RCM accuracy in dynamic mode, typed errors."""

from __future__ import annotations

import numpy as np
import pytest

from rcmplan import Iramis
from rcmplan.analysis.metrics import phase_metrics
from rcmplan.control.methods import make_solver
from rcmplan.controller import Controller
from rcmplan.exceptions import InvalidInputError, SliderLimitError
from rcmplan.robot.chain import JointChain
from rcmplan.robot.model import SerialArm
from rcmplan.robot.needle import StraightNeedle
from rcmplan.robot.shipped import shipped_arm
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.scene.procedures import injection
from rcmplan.sim.kinematic import KinematicPlant
from rcmplan.sim.mujoco.arm_model import DEFAULT_LINK, ServoOptions, arm_model, arm_xml
from rcmplan.sim.mujoco.arm_plant import ArmPlant
from rcmplan.sim.mujoco.files import mujoco_module
from rcmplan.sim.mujoco.plant import MujocoPlant
from rcmplan.sim.registry import make_plant

ARMS = ("ur5", "panda")
UM = 1e-6


@pytest.fixture(scope="module", params=ARMS)
def arm(request: pytest.FixtureRequest) -> SerialArm:
    return shipped_arm(request.param)


@pytest.fixture(scope="module")
def ur5() -> SerialArm:
    return shipped_arm("ur5")


def run_short_injection(plant: ArmPlant | KinematicPlant) -> tuple[list[float], np.ndarray]:
    """Approach, align and insert of the default injection with pinv: the max RCM deviation
    [m] of align and of insert, and the RCM deviation (N, 3) [m] of every record (NaN: free)."""
    robot = plant.robot
    eye = default_eye(robot)
    plant.reset(robot.home_actuators)
    log = Controller(plant, make_solver("pinv", robot=robot)).run(
        injection(robot, eye, default_points(eye))[:3]
    )
    maxima = [m.max_rcm_deviation_m for m in phase_metrics(log) if m.inside_eye]
    return [float(m) for m in maxima if m is not None], log.rcm_deviation()


def test_the_model_loads_and_steps_one_second_of_random_commands_without_warnings(
    arm: SerialArm,
) -> None:
    plant = ArmPlant(arm)
    rng = np.random.default_rng(7)
    for k in range(1000):  # a new random command every 0.1 s, held in between
        if k % 100 == 0:
            plant.command_actuators(rng.uniform(arm.lower, arm.upper))
        plant.advance()  # raises SimulationError on NaN or a MuJoCo warning
    assert plant.warnings() == {}
    assert plant.time == pytest.approx(1.0)
    assert np.all(np.isfinite(plant.data.qpos))


def test_needle_sites_equal_the_arm_kinematics_at_random_joints(arm: SerialArm) -> None:
    mj = mujoco_module()
    model = arm_model(arm)
    data = mj.MjData(model)
    rng = np.random.default_rng(11)
    for _ in range(20):
        q = rng.uniform(arm.lower, arm.upper)
        data.qpos[:] = q
        mj.mj_kinematics(model, data)
        np.testing.assert_allclose(data.site("needle_tip").xpos, arm.tip(q), atol=1e-9)
        np.testing.assert_allclose(data.site("needle_base").xpos, arm.needle_point(q, 0.0),
                                   atol=1e-9)  # fmt: skip


def test_an_arm_from_a_dh_table_with_slides_gets_default_links_and_agrees_and_follows() -> None:
    robot = Iramis()
    mount = np.eye(4)
    mount[2, 3] = -robot.params.l6  # the needle base l6 behind the DH tip frame
    chain = JointChain.from_dh(robot.chain, name="iramis-dh")
    arm = SerialArm(chain, StraightNeedle(robot.params.l6, mount), np.zeros(6),
                    name="iramis-dh", roll_joint=5)  # fmt: skip
    plant = ArmPlant(arm)
    assert plant.model.body_mass[2] == DEFAULT_LINK[0]  # no URDF: the default link
    q = np.array([0.01, 0.2, -0.02, -0.1, 0.015, 0.3])
    plant.data.qpos[:] = q
    mujoco_module().mj_kinematics(plant.model, plant.data)
    np.testing.assert_allclose(plant.site_position("needle_tip"), arm.tip(q), atol=1e-9)
    plant.reset(arm.home)
    plant.command_actuators(arm.home + 1e-3)  # 1 mm on the slides, 1 mrad on the hinges
    for _ in range(4):
        plant.advance()
    np.testing.assert_allclose(plant.read_actuators(), arm.home + 1e-3, atol=1e-8)


def test_the_model_has_a_home_keyframe_joint_limits_and_one_servo_pair_per_joint(
    arm: SerialArm,
) -> None:
    model = arm_model(arm)
    n = arm.chain.n
    np.testing.assert_array_equal(model.key_qpos[0], arm.home)
    np.testing.assert_array_equal(model.jnt_range, np.column_stack([arm.lower, arm.upper]))
    assert model.nu == 2 * n and model.na == n
    assert "needle_tip" in arm_xml(arm) and "servo_" in arm_xml(arm)


def test_the_registry_builds_the_arm_plant_for_arms_and_the_iramis_plant_for_iramis(
    ur5: SerialArm,
) -> None:
    for name, mode in (("mujoco", "dynamic"), ("mujoco-kinematic", "kinematic")):
        plant = make_plant(name, ur5)
        assert isinstance(plant, ArmPlant)
        assert plant.name == f"mujoco-{mode}" and plant.robot is ur5
        assert not plant.exact_commands and plant.compiled_physics == (mode == "dynamic")
    assert isinstance(make_plant("mujoco-kinematic", Iramis()), MujocoPlant)
    eye = default_eye(ur5)
    for scene in (eye, {"eye": eye}):  # the eye alone, or scene objects by name
        model = make_plant("mujoco-kinematic", ur5, scene).model
        assert model.body("eye").pos.tolist() == eye.center.tolist()


def test_kinematic_mode_reproduces_the_kinematic_plant_on_a_short_injection(
    ur5: SerialArm,
) -> None:
    ours, ours_all = run_short_injection(ArmPlant(ur5, mode="kinematic"))
    reference, reference_all = run_short_injection(KinematicPlant(ur5))
    assert len(ours) == 2 and ours_all.shape == reference_all.shape
    np.testing.assert_allclose(ours, reference, rtol=0.0, atol=1e-9)
    np.testing.assert_allclose(ours_all, reference_all, rtol=0.0, atol=1e-9)


def test_dynamic_mode_holds_the_rcm_within_10_um_while_aligning_and_inserting(
    ur5: SerialArm,
) -> None:
    (align, insert), _ = run_short_injection(ArmPlant(ur5, mode="dynamic"))
    assert 0.0 < align <= 10 * UM
    assert 0.0 < insert <= 10 * UM


def run_dynamic(robot: SerialArm, method: str, whole: bool) -> tuple[Controller, np.ndarray]:
    """Approach, align and insert of the default injection on the dynamic plant with `method`
    (the QP planned from the plant's command), the whole loop compiled or (whole False) one
    compiled iteration per period with the plant stepping in Python; returns the controller
    and every logged array stacked."""
    from rcmplan.compiled import arm_phase

    plant = ArmPlant(robot, mode="dynamic")
    plant.reset(robot.home_actuators)
    eye = default_eye(robot)
    solver = make_solver(method, robot=robot, plant=plant, eye=eye, dt=plant.dt)
    ctl = Controller(plant, solver)

    def per_period(*args: object) -> None:
        raise AssertionError("a phase left the whole compiled loop")

    with pytest.MonkeyPatch.context() as m:
        if whole:
            m.setattr(arm_phase, "run_arm_phase", per_period)
        else:
            m.setattr(arm_phase, "whole_loop", lambda *a: False)
        log = ctl.run(injection(robot, eye, default_points(eye))[:3])
    rows = [np.asarray(getattr(log, k), dtype=float).reshape(len(log), -1)
            for k in ("time", "sliders", "joints", "lam", "tip", "rcm", "error")]  # fmt: skip
    return ctl, np.hstack(rows)


@pytest.mark.parametrize("method", ["pinv", "qp"])
def test_the_whole_loop_around_the_dynamic_plant_gives_the_per_period_log(
    ur5: SerialArm, method: str
) -> None:
    """The whole phase compiled around the dynamic plant (`algorithm.run_targets` running
    MuJoCo's period, `sim.mujoco.compiled.advance`) gives the records, joints, lambda and time
    of one compiled iteration per period with the plant stepping in Python, bit for bit."""
    whole, a = run_dynamic(ur5, method, whole=True)
    stepped, b = run_dynamic(ur5, method, whole=False)
    assert a.shape[0] > 300 and a.shape == b.shape
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(whole.plant.read_actuators(), stepped.plant.read_actuators())
    np.testing.assert_array_equal(whole.plant.command, stepped.plant.command)
    assert (whole.lam, whole.plant.time) == (stepped.lam, stepped.plant.time)


def test_a_lower_servo_bandwidth_breaks_the_rcm_bound(ur5: SerialArm) -> None:
    from rcmplan.exceptions import RcmBoundError

    with pytest.raises(RcmBoundError) as info:  # the default bandwidth is what keeps the bound
        run_short_injection(ArmPlant(ur5, servo=ServoOptions(bandwidth=200.0)))
    assert info.value.phase == "align"
    assert info.value.deviation > info.value.bound > 10 * UM


def test_gravity_compensated_servos_hold_home_without_sag(arm: SerialArm) -> None:
    plant = ArmPlant(arm)
    for _ in range(200):
        plant.advance()
    np.testing.assert_allclose(plant.read_actuators(), arm.home, atol=1e-9)


def test_a_one_milliradian_joint_step_lags_under_one_percent_and_settles_in_four_periods(
    ur5: SerialArm,
) -> None:
    plant = ArmPlant(ur5)
    command = ur5.home + 1e-3
    plant.command_actuators(command)
    plant.advance()
    assert np.abs(plant.read_actuators() - command).max() < 1e-5
    for _ in range(3):
        plant.advance()
    assert np.abs(plant.read_actuators() - command).max() < 1e-8
    np.testing.assert_array_equal(plant.command, command)


def test_the_eye_phantom_puts_the_trocar_site_on_the_eye_port(ur5: SerialArm) -> None:
    eye = default_eye(ur5)
    plant = ArmPlant(ur5, mode="kinematic", eye=eye, points=default_points(eye))
    np.testing.assert_allclose(plant.site_position("trocar"), eye.port, atol=1e-12)
    assert plant.model.nsite == 2 + 1 + 5  # needle base and tip, trocar, p3..p7


def test_raises_slider_limit_error_beyond_travel(ur5: SerialArm) -> None:
    plant = ArmPlant(ur5, mode="kinematic")
    bad = ur5.home.copy()
    bad[2] = ur5.upper[2] + 0.01
    with pytest.raises(SliderLimitError, match="elbow_joint"):
        plant.command_actuators(bad)
    with pytest.raises(SliderLimitError):
        plant.reset(bad)


def test_raises_invalid_input_error_on_nan_or_wrong_length_commands(ur5: SerialArm) -> None:
    plant = ArmPlant(ur5, mode="kinematic")
    bad = ur5.home.copy()
    bad[0] = np.nan
    with pytest.raises(InvalidInputError):
        plant.command_actuators(bad)
    with pytest.raises(InvalidInputError):
        plant.command_actuators(ur5.home[:5])


def test_raises_invalid_input_error_on_a_bad_mode_or_physics_step(ur5: SerialArm) -> None:
    with pytest.raises(InvalidInputError, match="dynamic"):
        ArmPlant(ur5, mode="fast")
    with pytest.raises(InvalidInputError, match="whole fraction"):
        ArmPlant(ur5, physics_dt=3e-4)
    with pytest.raises(InvalidInputError, match="bandwidth"):
        ServoOptions(bandwidth=5000.0)
