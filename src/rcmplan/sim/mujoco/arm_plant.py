"""The MuJoCo plant of a serial arm (`SerialArm`: UR5, Panda, any chain) behind `Plant`.

Modes:
    kinematic: a command places the joints exactly (qpos set, `mj_kinematics`); no dynamics.
    dynamic: each `advance` runs dt / physics_dt physics steps (implicitfast, gravity
        compensated). The command is rounded to `robot.resolution` (the encoder count a real
        servo can hold); each joint's servo reference then moves to it within the period at
        constant speed, all joints scaled together so that none exceeds its speed (the
        synchronised motion of `actuators.velocity_into` without its acceleration bound,
        `ServoPlant.advance`), with that speed fed forward.
        Lagging joints lag in proportion (servo gains scaled by inertia, `ServoOptions`), so the
        needle keeps its line; `read_actuators` returns the simulated joint positions.
After every period the plant checks for NaN and MuJoCo warnings and raises SimulationError.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rcmplan._validate import FloatArray, instance, vector
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.model import SerialArm
from rcmplan.scene.eye import Eye, EyePoints, default_points
from rcmplan.scene.eye import default_eye as scene_default_eye
from rcmplan.sim.mujoco.arm_model import ServoOptions, arm_model
from rcmplan.sim.mujoco.files import mujoco_module
from rcmplan.sim.mujoco.plant import cancel_gravity
from rcmplan.sim.mujoco.plant_checks import check_needle_arc, check_scene_args
from rcmplan.sim.mujoco.scene import EyePhantom, phantom_of
from rcmplan.sim.mujoco.servo_plant import ServoIds, ServoPlant


class ArmPlant(ServoPlant):
    """A serial arm in MuJoCo, read and commanded through its joint positions (`ServoPlant`).

    Args:
        robot: The arm; the model is generated from its chain (`arm_model`).
        mode: "dynamic" (servo actuators, physics) or "kinematic" (joints set directly).
        dt: Control period in [s] (default 1 ms, a 1 kHz controller).
        physics_dt: Physics timestep in [s]; dt must be a whole multiple of it.
        eye: The eye in the scene: a phantom, or a scene Eye (with `points` as target sites);
            default: the default scene eye of the arm and its points.
        points: Named eye points shown as sites when `eye` is a scene Eye.
        servo: Servo gains and physics settings (default `ServoOptions()` at physics_dt).
        needle_arc: (R [m], alpha [rad]) of a curved needle's arc after the shaft's end, drawn
            in the scene a camera sees (`scene`) only: the plant moves the shaft's model.
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
        needle_arc: tuple[float, float] | None = None,
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
        physics_dt = self._timing(dt, physics_dt)
        self.eye = _phantom(robot, eye, points)
        self.needle_arc = check_needle_arc(needle_arc)
        self.servo = servo or ServoOptions(physics_dt=physics_dt)
        if abs(self.servo.physics_dt - physics_dt) > 1e-15:
            raise InvalidInputError("servo.physics_dt", self.servo.physics_dt, f"{physics_dt:g}")
        self.model = arm_model(robot, self.servo, self.eye)
        if self.servo.gravity_compensation:
            cancel_gravity(self.mj, self.model)
        self.data = self.mj.MjData(self.model)
        self._n = robot.chain.n
        names = list(robot.chain.joint_names)
        self._ids = ServoIds(self.mj, self.model, names, names)
        self._lower, self._upper, self._speed = robot.lower, robot.upper, robot.speed
        self._steps = np.full(self._n, robot.resolution)
        self._ramp, self._clip = 0.0, (robot.lower, robot.upper)  # speed alone; within travel
        # capability: a dynamic-mode command is rounded to the joint resolution
        self.actuator_resolution = self._steps.copy() if mode == "dynamic" else None
        self._warning_count = self.data.warning.number  # a view: MuJoCo updates it in place
        self.time = 0.0
        self._cmd = robot.home.copy()
        self.reset(robot.home)

    def reset(self, s: FloatArray) -> None:
        """Place the joints at s (checked against travel), at rest, and set the time to zero."""
        s = self.robot.check_actuators(vector("s", s, self._n)).copy()
        self.mj.mj_resetData(self.model, self.data)
        self.data.qpos[self._ids.reads] = s
        self.data.act[self._ids.act] = s
        self.mj.mj_forward(self.model, self.data)
        self._cmd = s
        self.time = 0.0

    def _place(self, s: FloatArray) -> None:
        """Kinematic mode: the joints at s."""
        self.data.qpos[self._ids.reads] = s

    def site_position(self, name: str) -> FloatArray:
        """Position (3,) in [m], world frame, of a site ("needle_tip", "needle_base", ...)."""
        return np.array(self.data.site(name).xpos, dtype=float)

    def tip_position(self) -> FloatArray:
        """Needle tip site position (3,) in [m], world frame."""
        return self.site_position("needle_tip")

    def _scene_model(self) -> Any:
        """The physics model with the links drawn, a floor, a light and the cameras `closeup`
        and `overview` (`arm_model`'s scenery), that `scene` poses."""
        return arm_model(self.robot, self.servo, self.eye, scenery=True, needle_arc=self.needle_arc)


def _phantom(robot: SerialArm, eye: EyePhantom | Eye | None, points: EyePoints | None) -> Any:
    """The eye phantom of the scene: given, from a scene Eye, or the arm's default eye."""
    if isinstance(eye, EyePhantom):
        return eye
    if eye is None:
        eye = scene_default_eye(robot)
        points = default_points(eye)
    return phantom_of(eye, points)
