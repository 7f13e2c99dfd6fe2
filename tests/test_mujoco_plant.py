"""The MuJoCo plant: the Plant interface, piezo actuation, settling accuracy, faults."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from rcmplan import Iramis
from rcmplan.control.plant import Plant
from rcmplan.exceptions import (
    InvalidInputError,
    MissingExtraError,
    SimulationError,
    SliderLimitError,
)
from rcmplan.sim.mujoco.actuators import PiezoParameters
from rcmplan.sim.mujoco.plant import MujocoPlant
from rcmplan.sim.registry import make_plant

UM = 1e-6


@pytest.fixture(scope="module")
def dynamic() -> MujocoPlant:
    return MujocoPlant(mode="dynamic")


def test_both_modes_implement_the_plant_interface() -> None:
    for name, mode in (("mujoco", "dynamic"), ("mujoco-kinematic", "kinematic")):
        plant = make_plant(name)
        assert isinstance(plant, Plant)
        assert isinstance(plant, MujocoPlant) and plant.mode == mode
        assert plant.name == f"mujoco-{mode}"
        assert plant.dt == 1e-3 and plant.substeps == 10


def test_kinematic_mode_places_the_sliders_exactly(robot: Iramis, rng: np.random.Generator) -> None:
    plant = MujocoPlant(robot, mode="kinematic")
    s = rng.uniform(robot.lower, robot.upper)
    plant.command_actuators(s)
    plant.advance()
    np.testing.assert_allclose(plant.read_actuators(), s, atol=1e-15)
    assert plant.time == pytest.approx(1e-3)


def test_reset_places_sliders_at_rest_and_zeroes_time(dynamic: MujocoPlant, robot: Iramis) -> None:
    s = 0.5 * robot.upper
    dynamic.reset(s)
    np.testing.assert_allclose(dynamic.read_actuators(), s, atol=1e-15)
    assert dynamic.time == 0.0
    assert not dynamic.data.qvel.any()


def test_dynamic_mode_settles_on_forward_kinematics(
    dynamic: MujocoPlant, robot: Iramis, rng: np.random.Generator
) -> None:
    for _ in range(8):
        start = rng.uniform(0.8 * robot.lower, 0.8 * robot.upper)
        goal = start + rng.uniform(-1e-3, 1e-3, size=6)
        dynamic.reset(start)
        dynamic.command_actuators(goal)
        dynamic.settle(0.3)
        s = dynamic.read_actuators()
        np.testing.assert_allclose(s[:5], goal[:5], atol=0.1 * UM)
        T = robot.forward_kinematics(robot.joints_from_actuators(s))
        assert np.linalg.norm(dynamic.tip_position() - T[:3, 3]) < UM
        assert dynamic.loop_gap() < UM


def test_sliders_move_together_and_no_faster_than_their_speed_and_acceleration(
    dynamic: MujocoPlant, robot: Iramis
) -> None:
    dynamic.reset(robot.home_actuators)
    goal = robot.upper.copy()
    dynamic.command_actuators(goal)
    ramp, dt, speed = dynamic.piezo.ramp_time, dynamic.dt, robot.speed
    v = np.zeros((101, 6))  # the servo reference's velocity in each period
    for k in range(1, 101):
        dynamic.advance()
        v[k] = dynamic.data.ctrl[dynamic._ids.servo]
    fraction = dynamic.read_actuators() / goal  # of the way to the goal, per slider
    np.testing.assert_allclose(fraction, fraction[0], rtol=0.02)  # a straight slider path
    used = np.abs(v) / speed  # fraction of each slider's speed
    assert used.max() == pytest.approx(1.0, abs=1e-12)  # full speed once the ramp is over
    assert np.all(np.abs(np.diff(v, axis=0)) / speed <= dt / ramp * (1 + 1e-12))
    ramp_periods = round(ramp / dt)
    assert used[ramp_periods].max() == pytest.approx(1.0, abs=1e-12)
    assert used[ramp_periods - 1].max() < 1.0  # it took the whole ramp to get there


def test_the_reference_stops_at_the_quantised_command_without_overshoot(
    dynamic: MujocoPlant, robot: Iramis
) -> None:
    dynamic.reset(robot.home_actuators)
    goal = robot.home_actuators + np.array([0.3e-3, -0.2e-3, 0.1e-3, 0.0, 0.25e-3, 0.0])
    dynamic.command_actuators(goal)
    ref, distance = [], []
    for _ in range(150):
        dynamic.advance()
        ref.append(dynamic.data.act[dynamic._ids.act].copy())
        distance.append(np.abs(goal - ref[-1]).max())
    np.testing.assert_allclose(ref[-1], dynamic.piezo.quantise(goal), rtol=0.0, atol=1e-15)
    assert np.all(np.diff(distance) <= 0.0)  # always closer, never past the goal
    assert np.abs(dynamic.data.ctrl[dynamic._ids.servo]).max() < 1e-12  # at rest


def test_loop_gap_stays_below_one_micrometre_at_full_speed(
    dynamic: MujocoPlant, robot: Iramis
) -> None:
    dynamic.reset(robot.home_actuators)
    dynamic.command_actuators(np.array([10e-3, -10e-3, -10e-3, 10e-3, 5e-3, 0.5]))
    worst = 0.0
    for _ in range(400):
        dynamic.advance()
        worst = max(worst, dynamic.loop_gap())
    assert worst < UM


def test_commands_are_quantised_to_the_slider_resolution(robot: Iramis) -> None:
    piezo = PiezoParameters.from_robot(robot, rotary_resolution=1e-3)
    s = np.array([1.2e-9 + 0.3e-9, 0.0, 0.0, 0.0, 0.0, 0.0104])
    q = piezo.quantise(s)
    np.testing.assert_allclose(q, [2e-9, 0.0, 0.0, 0.0, 0.0, 0.010], atol=1e-18)
    with pytest.raises(InvalidInputError, match=r"shape \(6,\)"):
        piezo.quantise(s[:5])
    with pytest.raises(InvalidInputError, match="finite"):
        piezo.quantise(np.r_[s[:5], np.nan])


def test_gravity_compensation_removes_the_sag(robot: Iramis) -> None:
    sag = {}
    for on in (True, False):
        plant = MujocoPlant(robot, gravity_compensation=on)
        plant.settle(0.3)
        sag[on] = float(np.abs(plant.read_actuators()[:5]).max())
    assert sag[False] > 1 * UM
    assert sag[True] < 0.01 * sag[False]


def test_command_beyond_travel_raises_slider_limit_error(
    dynamic: MujocoPlant, robot: Iramis
) -> None:
    s = robot.home_actuators.copy()
    s[4] = robot.upper[4] + 1e-3
    with pytest.raises(SliderLimitError, match="L5"):
        dynamic.command_actuators(s)


@pytest.mark.parametrize(
    "bad", [[np.nan, 0, 0, 0, 0, 0], [0, 0, 0, 0, 0, np.inf], [0.0] * 5, "L1", [[0.0] * 6]]
)
def test_malformed_command_raises_invalid_input(dynamic: MujocoPlant, bad: object) -> None:
    before = dynamic._cmd.copy()
    with pytest.raises(InvalidInputError, match="s = "):
        dynamic.command_actuators(bad)  # type: ignore[arg-type]
    np.testing.assert_array_equal(dynamic._cmd, before)  # the last valid command stands


def test_gravity_compensation_is_gravity_off_with_the_same_accelerations(
    robot: Iramis, rng: np.random.Generator
) -> None:
    import mujoco

    from rcmplan.sim.mujoco.files import load_model
    from rcmplan.sim.mujoco.model import ModelOptions

    plant = MujocoPlant(robot)  # compensation on: gravity switched off in the model
    assert plant.model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_GRAVITY
    gravcomp = load_model(robot, plant.eye, plant.piezo, ModelOptions())  # per-body gravcomp
    assert not gravcomp.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_GRAVITY
    for _ in range(20):
        plant.reset(rng.uniform(0.5 * robot.lower, 0.5 * robot.upper))
        plant.data.qvel[:] = rng.normal(0.0, 0.01, plant.model.nv)
        data = mujoco.MjData(gravcomp)
        data.qpos[:], data.qvel[:], data.act[:] = plant.data.qpos, plant.data.qvel, plant.data.act
        mujoco.mj_forward(plant.model, plant.data)
        mujoco.mj_forward(gravcomp, data)
        np.testing.assert_allclose(plant.data.qacc, data.qacc, rtol=1e-9, atol=1e-9)


def test_an_uncompensated_body_keeps_gravity(robot: Iramis) -> None:
    import mujoco

    from rcmplan.sim.mujoco.plant import cancel_gravity

    plant = MujocoPlant(robot, gravity_compensation=False)
    assert not plant.model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_GRAVITY
    model = plant.model.__copy__()
    model.body_gravcomp[:] = 1.0
    needle = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "frame6")
    model.body_gravcomp[needle] = 0.0  # one moving body left uncompensated
    cancel_gravity(mujoco, model)
    assert not model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_GRAVITY
    assert model.body_gravcomp[needle - 1] == 1.0


def test_a_servo_too_stiff_for_the_timestep_raises_simulation_error(robot: Iramis) -> None:
    stiff = PiezoParameters.from_robot(robot, bandwidth=5000.0)  # omega dt = 31 at 1 ms
    plant = MujocoPlant(robot, physics_dt=1e-3, piezo=stiff)
    plant.command_actuators(np.array([1e-3, 0.0, 0.0, 0.0, 0.0, 0.0]))
    with pytest.raises(SimulationError, match=r"loop-closure gap .* exceeds the limit"):
        for _ in range(100):
            plant.advance()


def test_nan_state_raises_simulation_error(robot: Iramis) -> None:
    plant = MujocoPlant(robot)
    plant.data.qpos[0] = np.nan
    with pytest.raises(SimulationError):
        plant.advance()


def test_invalid_settings_raise_with_the_valid_choices() -> None:
    with pytest.raises(InvalidInputError, match="dynamic"):
        MujocoPlant(mode="fast")
    with pytest.raises(InvalidInputError, match="whole fraction"):
        MujocoPlant(physics_dt=3e-4)


def test_missing_mujoco_names_the_sim_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "mujoco", None)
    with pytest.raises(MissingExtraError, match=r"rcmplan\[sim\]"):
        MujocoPlant()
