"""The kinematic plant: sliders go exactly where they are commanded (V-REP's FK mode)."""

from __future__ import annotations

from rcmplan._validate import FloatArray, scalar, vector
from rcmplan.robot.checks import robot_model
from rcmplan.robot.iramis import Iramis
from rcmplan.robot.model import RobotModel


class KinematicPlant:
    """Exact forward kinematics, no dynamics: a command is reached within one period.

    Args:
        robot: The robot model (default: thesis iRAM!S).
        dt: Control period in [s] (default 1 ms), in (0, 1].
    """

    name = "kinematic"
    exact_commands = True  # capability: advance() puts the actuators exactly at the command
    actuator_resolution = None  # commands are taken as they are, not rounded

    def __init__(self, robot: RobotModel | None = None, dt: float = 1e-3) -> None:
        self.robot: RobotModel = Iramis() if robot is None else robot_model("robot", robot)
        self.dt = scalar("dt", dt, 0.0, 1.0, low_open=True)
        self.time = 0.0
        self._s = self.robot.home_actuators.copy()
        self._cmd = self._s.copy()

    def reset(self, s: FloatArray) -> None:
        """Place the sliders at s (checked against travel) and zero the time."""
        self._s = self.robot.check_actuators(vector("s", s, len(self.robot.lower))).copy()
        self._cmd = self._s.copy()
        self.time = 0.0

    def read_actuators(self) -> FloatArray:
        """The slider positions (6,)."""
        return self._s.copy()

    def command_actuators(self, s: FloatArray) -> None:
        """Command sliders; SliderLimitError beyond travel, InvalidInputError if not finite."""
        self._cmd = self.robot.check_actuators(vector("s", s, len(self.robot.lower))).copy()

    def advance(self) -> None:
        """The sliders reach the command; time moves on by dt."""
        self._s = self._cmd.copy()
        self.time += self.dt
