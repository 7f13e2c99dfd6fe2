"""The robot's links in the view, from the best geometry the robot has: iRAM!S from its MJCF
(MuJoCo, extra `sim`), a shipped arm from its URDF meshes (extra `robots`), any other serial
arm as its joint skeleton. A missing extra falls back to what is installed, and says so.
"""

from __future__ import annotations

from typing import Any, Protocol

from rcmplan._validate import FloatArray
from rcmplan.exceptions import MissingExtraError
from rcmplan.robot.curved import CurvedTipRobot
from rcmplan.robot.iramis import Iramis
from rcmplan.robot.model import RobotModel, SerialArm


class Links(Protocol):
    """A drawing of a robot's links, posed per record."""

    note: str

    def show(self, q: FloatArray, s: FloatArray) -> None:
        """Pose the links at joints q and actuators s of one record."""
        ...


class NoLinks:
    """No drawing (a robot rcmplan cannot model here); `note` says why."""

    def __init__(self, note: str) -> None:
        self.note = note

    def show(self, q: FloatArray, s: FloatArray) -> None:
        """Nothing to pose."""


def robot_links(server: Any, robot: RobotModel | None, root: str = "/robot") -> Links:
    """The links of `robot` (its shaft-holding model for a curved needle) added to the scene."""
    model = robot.base if isinstance(robot, CurvedTipRobot) else robot
    if isinstance(model, Iramis):
        try:
            from rcmplan.view.links_mujoco import MujocoLinks

            return MujocoLinks(server.scene, model, root)
        except MissingExtraError as exc:
            return NoLinks(f"iRAM!S links not drawn: {exc}")
    if isinstance(model, SerialArm):
        return _arm_links(server, model, root)
    name = getattr(robot, "name", "unknown")
    return NoLinks(f"links of robot {name!r} not drawn: no model of it here (needle only)")


def _arm_links(server: Any, arm: SerialArm, root: str) -> Links:
    from rcmplan.robot.library import ROBOT_FILES
    from rcmplan.robot.shipped import flange_frame, robot_file
    from rcmplan.view.links_chain import ChainLinks

    if arm.name in ROBOT_FILES:
        try:
            from rcmplan.view.links_urdf import UrdfLinks

            return UrdfLinks(server, arm, robot_file(arm.name), flange_frame(arm.name), root)
        except MissingExtraError as exc:
            links = ChainLinks(server.scene, arm, root)
            links.note += f" (meshes not drawn: {exc})"
            return links
    return ChainLinks(server.scene, arm, root)
