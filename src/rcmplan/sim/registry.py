"""Plants by name, so commands and scenario files can say `--plant mujoco`.

Optional plants are imported on first use; a missing extra raises MissingExtraError.
A name can stand for another plant on a serial arm: a robot whose `chain` is a `JointChain`
driven joint by joint (`SerialArm`) takes its plant from `SERIAL_PLANTS` where that table names
one; iRAM!S (its `chain` is a method giving its DH table; its actuators are sliders) does not.
"""

from __future__ import annotations

import importlib
import inspect
from typing import Any

from rcmplan.control.plant import Plant
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.chain import JointChain
from rcmplan.robot.checks import robot_model
from rcmplan.robot.iramis import Iramis
from rcmplan.robot.model import RobotModel
from rcmplan.scene.eye import Eye

# name -> (module, factory attribute, keyword arguments)
PLANTS: dict[str, tuple[str, str, dict[str, Any]]] = {
    "kinematic": ("rcmplan.sim.kinematic", "KinematicPlant", {}),
    "mujoco": ("rcmplan.sim.mujoco.plant", "MujocoPlant", {"mode": "dynamic"}),
    "mujoco-kinematic": ("rcmplan.sim.mujoco.plant", "MujocoPlant", {"mode": "kinematic"}),
}
SERIAL_PLANTS: dict[str, tuple[str, str, dict[str, Any]]] = {
    "mujoco": ("rcmplan.sim.mujoco.arm_plant", "ArmPlant", {"mode": "dynamic"}),
    "mujoco-kinematic": ("rcmplan.sim.mujoco.arm_plant", "ArmPlant", {"mode": "kinematic"}),
}


def make_plant(
    name: str,
    robot: RobotModel | None = None,
    scene: Eye | dict[str, Any] | None = None,
    **kwargs: Any,
) -> Plant:
    """Build the plant registered under `name` for `robot`.

    Args:
        scene: The eye, or scene objects by name (`eye`, `points`), handed to plants that take
            them; a plant without a scene (the kinematic one) ignores them.
        kwargs: Plant options (for example `dt`).
    """
    if not isinstance(name, str) or name not in PLANTS:
        raise InvalidInputError("plant", name, f"one of {sorted(PLANTS)}")
    robot = Iramis() if robot is None else robot_model("robot", robot)
    if isinstance(scene, Eye):
        scene = {"eye": scene}
    if scene is not None and not isinstance(scene, dict):
        valid = "an Eye, a dict of scene objects (eye, points), or None"
        raise InvalidInputError("scene", scene, valid)
    serial = isinstance(getattr(robot, "chain", None), JointChain) and name in SERIAL_PLANTS
    module, attr, defaults = SERIAL_PLANTS[name] if serial else PLANTS[name]
    factory = getattr(importlib.import_module(module), attr)
    takes = inspect.signature(factory).parameters
    unknown = sorted(set(kwargs) - set(takes) - {"robot"})
    if unknown:
        raise InvalidInputError(f"plant option {unknown[0]}", kwargs[unknown[0]],
                                f"an option of the {name} plant: {', '.join(takes)}")  # fmt: skip
    extra = {k: v for k, v in (scene or {}).items() if k in takes}
    plant: Plant = factory(robot=robot, **{**defaults, **extra, **kwargs})
    return plant
