"""The MuJoCo plant of a serial arm (`SerialArm`: UR5, Panda, any chain) behind `Plant`.

Modes:
    kinematic: a command places the joints exactly (qpos set, `mj_kinematics`); no dynamics.
    dynamic: each `advance` runs dt / physics_dt physics steps (implicitfast, gravity
        compensated). The command is rounded to `robot.resolution` (the encoder count a real
        servo can hold); each joint's servo reference then moves to it within the period at
        constant speed, all joints scaled together so that none exceeds its speed (the
        synchronised motion of `actuators.synchronised_velocity`), with that speed fed forward.
        Lagging joints lag in proportion (servo gains scaled by inertia, `ServoOptions`), so the
        needle keeps its line; `read_actuators` returns the simulated joint positions.
After every period the plant checks for NaN and MuJoCo warnings and raises SimulationError.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from rcmplan._validate import FloatArray, instance, scalar, vector
from rcmplan.exceptions import InvalidInputError, SimulationError
from rcmplan.robot.model import SerialArm
from rcmplan.scene.eye import Eye, EyePoints, default_points
from rcmplan.scene.eye import default_eye as scene_default_eye
from rcmplan.sim.mujoco.actuators import quantise, synchronised_velocity
from rcmplan.sim.mujoco.arm_model import ServoOptions, arm_model
from rcmplan.sim.mujoco.files import mujoco_module
from rcmplan.sim.mujoco.plant import cancel_gravity
from rcmplan.sim.mujoco.plant_checks import check_scene_args
from rcmplan.sim.mujoco.scene import EyePhantom, phantom_of


class ArmPlant:
    """A serial arm in MuJoCo, read and commanded through its joint positions.

    Args:
        robot: The arm; the model is generated from its chain (`arm_model`).
        mode: "dynamic" (servo actuators, physics) or "kinematic" (joints set directly).
        dt: Control period in [s] (default 1 ms, a 1 kHz controller).
        physics_dt: Physics timestep in [s]; dt must be a whole multiple of it.
        eye: The eye in the scene: a phantom, or a scene Eye (with `points` as target sites);
            default: the default scene eye of the arm and its points.
        points: Named eye points shown as sites when `eye` is a scene Eye.
        servo: Servo gains and physics settings (default `ServoOptions()` at physics_dt).
    """

    def __init__(
        self,
        robot: SerialArm,
        mode: str = "dynamic",
        dt: float = 1e-3,
        physics_dt: float = 1e-4,
        eye: EyePhantom | Eye | None = None,
        points: EyePoints | None = None,
        servo: ServoOptions | None = None,
    ) -> None:
        check_scene_args(mode, eye, points)
        instance("robot", robot, SerialArm, "a SerialArm (make_robot(NAME or FILE.toml))")
        if servo is not None:
            instance("servo", servo, ServoOptions, "ServoOptions or None (the defaults)")
        self.mj = mujoco_module()
        self.robot = robot
        self.mode, self.name = mode, f"mujoco-{mode}"
        self.exact_commands = False  # capabilities: the compiled loop runs its dynamic period
        self.compiled_physics = mode == "dynamic"
        self.dt = scalar("dt", dt, 0.0, 1.0, low_open=True)
        physics_dt = scalar("physics_dt", physics_dt, 0.0, dt, low_open=True)
        self.substeps = round(dt / physics_dt)
        if abs(self.substeps * physics_dt - dt) > 1e-9 * dt:
            raise InvalidInputError("physics_dt", physics_dt, f"a whole fraction of dt = {dt:g} s")
        self.eye = _phantom(robot, eye, points)
        self.servo = servo or ServoOptions(physics_dt=physics_dt)
        if abs(self.servo.physics_dt - physics_dt) > 1e-15:
            raise InvalidInputError("servo.physics_dt", self.servo.physics_dt, f"{physics_dt:g}")
        self.model = arm_model(robot, self.servo, self.eye)
        if self.servo.gravity_compensation:
            cancel_gravity(self.mj, self.model)
        self.data = self.mj.MjData(self.model)
        self._n = robot.chain.n
        self._ids = _Ids(self.mj, self.model, robot)
        self._lower, self._upper, self._speed = robot.lower, robot.upper, robot.speed
        self._steps = np.full(self._n, robot.resolution)
        # capability: a dynamic-mode command is rounded to the joint resolution
        self.actuator_resolution = self._steps.copy() if mode == "dynamic" else None
        self._warnings = self.data.warning.number  # a view: MuJoCo updates it in place
        self.time = 0.0
        self._cmd = robot.home.copy()
        self.reset(robot.home)

    def reset(self, s: FloatArray) -> None:
        """Place the joints at s (checked against travel), at rest, and set the time to zero."""
        s = self.robot.check_actuators(vector("s", s, self._n)).copy()
        self.mj.mj_resetData(self.model, self.data)
        self.data.qpos[self._ids.qpos] = s
        self.data.act[self._ids.act] = s
        self.mj.mj_forward(self.model, self.data)
        self._cmd = s
        self.time = 0.0

    def read_actuators(self) -> FloatArray:
        """The simulated joint positions (n,) in [rad] or [m]."""
        return np.array(self.data.qpos[self._ids.qpos], dtype=float)

    def command_actuators(self, s: FloatArray) -> None:
        """Command joints; SliderLimitError beyond travel, InvalidInputError if not finite."""
        try:
            cmd = np.array(s, dtype=np.float64)
            ok = cmd.shape == (self._n,) and bool(
                ((cmd >= self._lower) & (cmd <= self._upper)).all()
            )
        except (TypeError, ValueError):
            ok = False
        if not ok:  # NaN fails the comparison too; the full check names what is wrong
            cmd = self.robot.check_actuators(vector("s", s, self._n)).copy()
        self._cmd = cmd

    def advance(self) -> None:
        """Move on by one control period dt; raises SimulationError if unstable."""
        d = self.data
        if self.mode == "kinematic":
            d.qpos[self._ids.qpos] = self._cmd
            d.time += self.dt
        else:
            ref = d.act[self._ids.act]
            target = np.clip(quantise(self._cmd, self._steps), self._lower, self._upper)
            v = synchronised_velocity(target, ref, self.dt, self._speed)
            d.ctrl[self._ids.servo] = v
            d.ctrl[self._ids.feedforward] = v
            self.mj.mj_step(self.model, d, nstep=self.substeps)
        self.mj.mj_kinematics(self.model, d)
        self.time += self.dt
        self.check()

    @property
    def command(self) -> FloatArray:
        """The last joint command (n,), a copy."""
        return self._cmd.copy()

    def site_position(self, name: str) -> FloatArray:
        """Position (3,) in [m], world frame, of a site ("needle_tip", "needle_base", ...)."""
        return np.array(self.data.site(name).xpos, dtype=float)

    def warnings(self) -> dict[str, int]:
        """MuJoCo warning counters that are non-zero, by warning name."""
        counts = np.asarray(self._warnings)
        names = {int(w): w.name for w in self.mj.mjtWarning.__members__.values()}
        return {names[int(i)]: int(counts[i]) for i in np.flatnonzero(counts)}

    def check(self) -> None:
        """Raise SimulationError on NaN or inf in the state or on any MuJoCo warning."""
        d = self.data
        if not math.isfinite(float(d.qpos.dot(d.qpos) + d.qvel.dot(d.qvel))):
            raise SimulationError(f"simulation diverged (NaN or inf) at t = {self.time:.6g} s")
        if self._warnings.any():
            raise SimulationError(f"MuJoCo warnings at t = {self.time:.6g} s: {self.warnings()}")


def _phantom(robot: SerialArm, eye: EyePhantom | Eye | None, points: EyePoints | None) -> Any:
    """The eye phantom of the scene: given, from a scene Eye, or the arm's default eye."""
    if isinstance(eye, EyePhantom):
        return eye
    if eye is None:
        eye = scene_default_eye(robot)
        points = default_points(eye)
    return phantom_of(eye, points)


class _Ids:
    """Addresses of the joints' qpos and of the servo states and controls, in joint order."""

    def __init__(self, mj: Any, model: Any, robot: SerialArm) -> None:
        def obj(kind: Any, name: str) -> int:
            return int(mj.mj_name2id(model, kind, name))

        act, jnt = mj.mjtObj.mjOBJ_ACTUATOR, mj.mjtObj.mjOBJ_JOINT
        names = robot.chain.joint_names
        self.qpos = np.array([int(model.jnt_qposadr[obj(jnt, n)]) for n in names])
        self.servo = np.array([obj(act, f"servo_{n}") for n in names])
        self.feedforward = np.array([obj(act, f"feedforward_{n}") for n in names])
        self.act = np.array([int(model.actuator_actadr[i]) for i in self.servo])
