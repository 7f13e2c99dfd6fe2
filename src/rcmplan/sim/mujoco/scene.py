"""The MuJoCo scene: `scene.xml` includes `robot.xml` and adds an eye phantom, floor, cameras.

All points are in the robot base frame in [m]; the robot base sits at the world origin, so
world and base coordinates coincide. The eye is passed in (centre, radius, trocar, targets) so
that a scenario can place its own eye; `default_eye` puts one in front of the needle at home.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import numpy as np

from rcmplan._validate import FloatArray, scalar, vector
from rcmplan.robot.iramis import Iramis
from rcmplan.scene.eye import Eye, EyePoints, default_points
from rcmplan.scene.eye import default_eye as scene_default_eye
from rcmplan.sim.mujoco.frames import fmt

TROCAR_RADIUS = 0.45e-3  # thesis trocar radius
EYE_RGBA = "0.95 0.93 0.88 0.3"


@dataclass(frozen=True)
class EyePhantom:
    """A spherical eye with a trocar on its wall and targets inside, robot base frame.

    Attributes:
        centre: Eye centre (3,) in [m].
        radius: Eye radius in [m] (adult eye: about 12 mm).
        trocar: Trocar point (3,) in [m], on or near the eye wall.
        targets: Target points (n, 3) in [m].
    """

    centre: FloatArray
    radius: float
    trocar: FloatArray
    targets: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))

    def __post_init__(self) -> None:
        object.__setattr__(self, "centre", vector("centre", self.centre, 3))
        object.__setattr__(self, "trocar", vector("trocar", self.trocar, 3))
        scalar("radius", self.radius, 0.0, 0.1, low_open=True)
        t = np.asarray(self.targets, dtype=float).reshape(-1, 3)
        if not np.all(np.isfinite(t)):
            from rcmplan.exceptions import InvalidInputError

            raise InvalidInputError("targets", self.targets, "finite points, shape (n, 3)")
        object.__setattr__(self, "targets", t)


def phantom_of(eye: Eye, points: EyePoints | None = None) -> EyePhantom:
    """The phantom of a scene eye, with p3..p7 as target sites when points are given."""
    targets = (
        np.zeros((0, 3))
        if points is None
        else np.array([points.p3, points.p4, points.p5, points.p6, points.p7])
    )
    return EyePhantom(eye.center, eye.radius, eye.port, targets)


def default_eye(robot: Iramis) -> EyePhantom:
    """The phantom of the default scene eye (`rcmplan.scene.eye.default_eye`) and its points."""
    eye = scene_default_eye(robot)
    return phantom_of(eye, default_points(eye))


def camera_axes(eye: FloatArray, target: FloatArray) -> FloatArray:
    """The rotation (3, 3) of a camera at `eye` looking at `target`, world z up: columns x
    (right), y (up) and z (backwards: MuJoCo cameras look along their -z)."""
    forward = target - eye
    forward = forward / np.linalg.norm(forward)
    x = np.cross(forward, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(x, forward), -forward])


def look_at(eye: FloatArray, target: FloatArray) -> str:
    """MJCF `xyaxes` of a camera at `eye` looking at `target`, world z up."""
    R = camera_axes(eye, target)
    return fmt(np.concatenate([R[:, 0], R[:, 1]]))


CLOSEUP_OFFSET = np.array([0.006, -0.07, 0.03])  # [m] from the middle of the tip and trocar
CLOSEUP_FOVY = 35.0  # [deg]


OFFSCREEN = (1280, 960)  # the largest image the scene renders, (width, height) in pixels


def scene_xml(robot: Iramis, eye: EyePhantom, robot_file: str = "robot.xml") -> str:
    """The scene MJCF as a string; it includes `robot_file`."""
    root = ET.Element("mujoco", model="iramis scene")
    ET.SubElement(root, "include", file=robot_file)
    vis = ET.SubElement(root, "visual")
    ET.SubElement(vis, "global", offwidth=str(OFFSCREEN[0]), offheight=str(OFFSCREEN[1]),
                  azimuth="120", elevation="-25")  # fmt: skip
    ET.SubElement(vis, "headlight", diffuse="0.5 0.5 0.5", ambient="0.3 0.3 0.3")
    assets = ET.SubElement(root, "asset")
    ET.SubElement(
        assets, "texture", type="skybox", builtin="gradient", rgb1="0.35 0.45 0.55",
        rgb2="0.05 0.05 0.08", width="64", height="384",
    )  # fmt: skip
    ET.SubElement(
        assets, "texture", name="grid", type="2d", builtin="checker", rgb1="0.2 0.22 0.25",
        rgb2="0.15 0.16 0.18", width="64", height="64",
    )  # fmt: skip
    ET.SubElement(assets, "material", name="grid", texture="grid", texrepeat="20 20")
    world = ET.SubElement(root, "worldbody")
    ET.SubElement(world, "light", pos="0 0 0.6", dir="0 0 -1", castshadow="false")
    ET.SubElement(
        world, "geom", name="floor", type="plane", size="0.3 0.3 0.01", pos="0 0 -0.002",
        material="grid", contype="0", conaffinity="1",
    )  # fmt: skip
    _cameras(world, robot, eye)
    _eye(world, eye)
    ET.indent(root)
    return ET.tostring(root, encoding="unicode") + "\n"


def _cameras(world: ET.Element, robot: Iramis, eye: EyePhantom) -> None:
    tip = robot.tip(robot.home)
    mid = 0.5 * (tip + eye.trocar)
    over = np.array([0.02, 0.03, 0.06])
    wide = over + np.array([0.12, -0.25, 0.17])
    close = mid + CLOSEUP_OFFSET
    for name, pos, target, fovy in (
        ("overview", wide, over, 45),
        ("closeup", close, mid, CLOSEUP_FOVY),
    ):
        ET.SubElement(
            world, "camera", name=name, pos=fmt(pos), xyaxes=look_at(pos, target), fovy=f"{fovy:g}"
        )


def _eye(world: ET.Element, eye: EyePhantom) -> None:
    body = ET.SubElement(world, "body", name="eye", pos=fmt(eye.centre))
    ET.SubElement(
        body, "geom", name="eyeball", type="sphere", size=f"{eye.radius:.17g}", rgba=EYE_RGBA,
        contype="0", conaffinity="0", group="1",
    )  # fmt: skip
    ET.SubElement(
        body, "site", name="trocar", pos=fmt(eye.trocar - eye.centre),
        size=f"{TROCAR_RADIUS:.17g}", rgba="0.1 0.8 0.2 1", group="1",
    )  # fmt: skip
    for i, p in enumerate(eye.targets):
        ET.SubElement(
            body, "site", name=f"target_{i}", pos=fmt(p - eye.centre), size="0.0003",
            rgba="0.9 0.2 0.2 1", group="1",
        )  # fmt: skip
