"""Where the view looks from: a close-up of the eye (the needle pivoting at the trocar) and the
whole robot, as buttons; new browser tabs start on the close-up."""

from __future__ import annotations

from typing import Any

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.robot.model import RobotModel
from rcmplan.scene.record import SceneRecord


def side_direction(record: SceneRecord) -> FloatArray:
    """Unit direction to look from: beside the insertion axis, above it and back from the eye
    towards the trocar, so the needle outside the eye is not hidden behind the robot."""
    a = record.axis
    side = np.cross(a, [0.0, 0.0, 1.0])
    side = side / np.linalg.norm(side) if np.linalg.norm(side) > 1e-9 else np.array([0, 1.0, 0])
    direction = side + 0.5 * np.array([0.0, 0.0, 1.0]) - 0.5 * a
    return np.asarray(direction / np.linalg.norm(direction))


def eye_view(record: SceneRecord, needle_length: float) -> tuple[FloatArray, FloatArray]:
    """(camera position, look-at point) [m] of the close-up: the eye and the trocar."""
    distance = 4.0 * record.eye_radius + 0.1 * needle_length
    look = record.eye_center - 0.6 * record.eye_radius * record.axis
    return look + distance * side_direction(record), look


def robot_view(record: SceneRecord, robot: RobotModel | None) -> tuple[FloatArray, FloatArray]:
    """(camera position, look-at point) [m] showing the robot at home and the eye."""
    pts = [record.eye_center]
    if robot is not None:
        pts += [robot.needle_point(robot.home, 0.0), np.zeros(3)]
    pts_a = np.array(pts)
    look = pts_a.mean(axis=0)
    extent = max(float(np.ptp(pts_a, axis=0).max()), 6 * record.eye_radius)
    return look + 1.6 * extent * side_direction(record), look


class CameraViews:
    """Camera buttons and the initial camera of new clients.

    Args:
        server: The viser server. record: The scene. robot: The robot model, or None.
    """

    def __init__(self, server: Any, record: SceneRecord, robot: RobotModel | None) -> None:
        self.server = server
        needle = robot.needle_length if robot is not None else 4 * record.eye_radius
        self.views = {"eye close-up": eye_view(record, needle), "robot": robot_view(record, robot)}
        cam = server.initial_camera
        cam.position, cam.look_at = self.views["eye close-up"]
        cam.near, cam.far = record.eye_radius / 100.0, 20.0
        with server.gui.add_folder("Camera"):
            for name in self.views:
                button = server.gui.add_button(name)
                button.on_click(lambda _e, n=name: self.look(n))

    def look(self, name: str) -> None:
        """Move every connected client's camera to the named view."""
        position, look = self.views[name]
        for client in self.server.get_clients().values():
            with client.atomic():
                client.camera.position = position
                client.camera.look_at = look
