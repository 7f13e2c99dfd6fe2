"""Any serial arm's links in the view, from its kinematics alone: a skeleton through the
joint frames' origins (base, joints, flange), a sphere on each joint.

The view draws a shipped arm from its URDF meshes (`links_urdf`); this skeleton serves an arm
without a mesh file (a DH table, an MJCF of capsules) or when the `robots` extra is missing.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.robot.model import SerialArm

LINK_RGB = (140, 150, 165)
JOINT_RGB = (70, 80, 95)


class ChainLinks:
    """A serial arm drawn as its joint skeleton.

    Args:
        scene: A viser SceneApi. arm: The arm. root: Scene-tree name of the drawing.
        thickness: Link thickness in [m]; default a thirtieth of the arm's reach.
    """

    def __init__(
        self, scene: Any, arm: SerialArm, root: str = "/robot", thickness: float | None = None
    ) -> None:
        self.arm = arm
        width = thickness or arm.reach / 30.0
        pts = self._points(arm.home)
        self.lines = scene.add_line_segments(
            f"{root}/links", _segments(pts), LINK_RGB, thickness=width
        )
        self.joints = [
            scene.add_icosphere(f"{root}/joint{k}", radius=0.6 * width, color=JOINT_RGB, position=p)
            for k, p in enumerate(pts[1:-1])
        ]
        self.note = f"{arm.name} links: skeleton of its {arm.chain.n} joints (no mesh file)"

    def _points(self, q: FloatArray) -> FloatArray:
        """Base origin, then the origins of frames 0..n (n + 2, 3) in [m]."""
        T = self.arm.chain.frames(q)
        return np.vstack([self.arm.chain.base[:3, 3], T[:, :3, 3]])

    def show(self, q: FloatArray, s: FloatArray) -> None:
        """Pose the skeleton at joints q (n,) (s is the same for an arm)."""
        pts = self._points(q)
        self.lines.points = _segments(pts)
        for handle, p in zip(self.joints, pts[1:-1], strict=True):
            handle.position = p


def _segments(points: FloatArray) -> FloatArray:
    """A polyline (k, 3) as k - 1 segments (k - 1, 2, 3)."""
    return np.stack([points[:-1], points[1:]], axis=1)
