"""The plant interface: what a controller may do with a robot, simulated or real.

A plant reads and commands actuator positions s (iRAM!S: its sliders (L1, L2, L3, L4, L5, q5);
an arm: its joints) and advances time by one control period, the way the thesis's MATLAB loop
read and set V-REP joints. Controllers only see this interface, so the same loop drives the
kinematic plant and the MuJoCo plant. A plant states what it can do by attributes, never by
its class name:
    exact_commands: True if `advance` puts the actuators exactly at the command.
    compiled_physics: True if its period can run in compiled code (the dynamic MuJoCo plant).
    command: The last command (n,), which servos follow (a plant without exact commands).
    actuator_resolution: The step (n,) in [m] or [rad] every command is rounded to, or None
        when commands are taken as they are; loop tolerances are raised to what it supports
        (`rcmplan.control.resolution`).
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

from rcmplan._validate import FloatArray
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.checks import robot_model
from rcmplan.robot.model import RobotModel


@runtime_checkable
class Plant(Protocol):
    """A robot that takes actuator commands.

    Attributes:
        robot: The kinematic model the plant realises.
        dt: Control period in [s]: the time one `advance` call moves the plant on.
        time: Plant time in [s] since the last reset.
        name: Short name for logs and reports ("kinematic", "mujoco-dynamic", ...).
    """

    dt: float
    time: float
    name: str

    @property
    def robot(self) -> RobotModel:
        """The robot model the plant realises."""
        ...

    def reset(self, s: FloatArray) -> None:
        """Place the sliders at s and set the time to zero."""
        ...

    def read_actuators(self) -> FloatArray:
        """The current slider positions (6,) in [m] and [rad]."""
        ...

    def command_actuators(self, s: FloatArray) -> None:
        """Command slider positions (6,); raises SliderLimitError beyond travel."""
        ...

    def advance(self) -> None:
        """Move the plant on by one control period dt."""
        ...


def check_plant(name: str, plant: Any) -> Plant:
    """plant if it is a Plant holding a robot model, else InvalidInputError naming `name`."""
    if not isinstance(plant, Plant):
        valid = "a plant (rcmplan.KinematicPlant, rcmplan.MujocoPlant, make_plant(NAME))"
        raise InvalidInputError(name, plant, valid)
    robot_model(f"{name}.robot", plant.robot)
    return plant
