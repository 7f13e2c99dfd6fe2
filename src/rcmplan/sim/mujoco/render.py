"""Offscreen rendering of the MuJoCo scene: PNG snapshots, GIF/MP4 animations with a tip trace.

Headless machines render through EGL (MUJOCO_GL=egl with Mesa; Debian packages libegl1,
libegl-mesa0, libgl1-mesa-dri, libgles2). `project` maps a base-frame point to pixel
coordinates of a named scene camera, so a rendered needle tip can be checked against the
forward kinematics.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray, matrix, vector
from rcmplan.exceptions import InvalidInputError, RcmplanError, require_extra
from rcmplan.sim.mujoco.files import mujoco_module

Image = NDArray[np.uint8]
GL_PACKAGES = "libegl1 libegl-mesa0 libgl1-mesa-dri libgles2"
TRACE_RGBA = (1.0, 0.55, 0.0, 1.0)


class RenderingUnavailableError(RcmplanError):
    """No OpenGL context could be made; the message names MUJOCO_GL and the system packages."""


class SceneRenderer:
    """Render a compiled scene offscreen.

    Args:
        model: An `mujoco.MjModel` with cameras (for example `MujocoPlant.scene()[0]`).
        width, height: Image size in pixels (at most the model's offscreen buffer).
    """

    def __init__(self, model: Any, width: int = 640, height: int = 480) -> None:
        self.mj = mujoco_module()
        self.model = model
        self.width, self.height = int(width), int(height)
        try:
            self._renderer = self.mj.Renderer(model, self.height, self.width)
        except Exception as exc:  # MuJoCo raises FatalError or RuntimeError without GL
            raise RenderingUnavailableError(
                f"offscreen rendering failed ({exc}); set MUJOCO_GL=egl and install the "
                f"system packages: apt-get install {GL_PACKAGES}"
            ) from exc

    def camera_id(self, camera: str) -> int:
        """Id of a named camera; raises InvalidInputError listing the cameras."""
        cid = int(self.mj.mj_name2id(self.model, self.mj.mjtObj.mjOBJ_CAMERA, camera))
        if cid < 0:
            names = [self.model.camera(i).name for i in range(self.model.ncam)]
            raise InvalidInputError("camera", camera, f"one of {names}")
        return cid

    def render(self, data: Any, camera: str = "closeup", trace: FloatArray | None = None) -> Image:
        """An RGB image (height, width, 3); `trace` (n, 3) [m] is drawn as a polyline."""
        self._renderer.update_scene(data, camera=self.camera_id(camera))
        if trace is not None and len(trace) > 1:
            self._add_polyline(np.asarray(trace, dtype=float))
        return np.asarray(self._renderer.render(), dtype=np.uint8)

    def segment(self, data: Any, camera: str = "closeup") -> NDArray[np.int32]:
        """Geom id seen at each pixel (height, width); -1 where no geom is seen."""
        self._renderer.update_scene(data, camera=self.camera_id(camera))
        self._renderer.enable_segmentation_rendering()
        try:
            seg = np.asarray(self._renderer.render())
        finally:
            self._renderer.disable_segmentation_rendering()
        geom = int(self.mj.mjtObj.mjOBJ_GEOM)
        return np.where(seg[..., 1] == geom, seg[..., 0], -1).astype(np.int32)

    def _add_polyline(self, points: FloatArray, width: float = 3.0, segments: int = 300) -> None:
        """Draw points as line segments `width` pixels wide, at most `segments` of them."""
        scene = self._renderer.scene
        free = min(segments, scene.maxgeom - scene.ngeom)
        stride = max(1, math.ceil((len(points) - 1) / max(free, 1)))
        pts = np.vstack([points[::stride], points[-1:]])
        for a, b in itertools.pairwise(pts):
            if scene.ngeom >= scene.maxgeom or np.allclose(a, b):
                continue
            geom = scene.geoms[scene.ngeom]
            self.mj.mjv_initGeom(
                geom, self.mj.mjtGeom.mjGEOM_LINE, np.zeros(3), np.zeros(3), np.eye(3).ravel(),
                np.array(TRACE_RGBA, dtype=np.float32),
            )  # fmt: skip
            self.mj.mjv_connector(geom, self.mj.mjtGeom.mjGEOM_LINE, width, a, b)
            scene.ngeom += 1

    def project(self, data: Any, point: FloatArray, camera: str = "closeup") -> FloatArray:
        """Pixel coordinates (u right, v down) of a world point [m] seen by `camera`."""
        return project(self.model, data, self.camera_id(camera), point, self.width, self.height)

    def close(self) -> None:
        """Free the GL context."""
        self._renderer.close()


def project(
    model: Any, data: Any, cam: int, point: FloatArray, width: int, height: int
) -> FloatArray:
    """Pinhole projection of a world point [m] into pixels (u, v) of camera `cam`.

    MuJoCo cameras look along their -z axis with y up; the vertical field of view is
    `cam_fovy` in degrees and pixels are square.
    """
    p = vector("point", point, 3)
    R = np.asarray(data.cam_xmat[cam]).reshape(3, 3)
    x = R.T @ (p - np.asarray(data.cam_xpos[cam]))
    if x[2] >= 0.0:
        raise InvalidInputError("point", point, "a point in front of the camera")
    f = 0.5 * height / math.tan(math.radians(float(model.cam_fovy[cam])) / 2.0)
    return np.array([0.5 * width + f * x[0] / -x[2], 0.5 * height - f * x[1] / -x[2]])


def save_png(path: Path, image: Image) -> Path:
    """Write an RGB image as PNG."""
    iio = require_extra("imageio.v2", "sim")
    path.parent.mkdir(parents=True, exist_ok=True)
    iio.imwrite(path, image)
    return path


def save_animation(path: Path, frames: list[Image], fps: float = 20.0) -> Path:
    """Write frames as GIF (Pillow) or MP4 (H.264 through imageio-ffmpeg: the `video` extra).

    MP4 frames are padded to a multiple of 16 pixels by the encoder."""
    iio = require_extra("imageio.v2", "sim")
    if not frames:
        raise InvalidInputError("frames", frames, "at least one frame")
    path.parent.mkdir(parents=True, exist_ok=True)
    suffix = path.suffix.lower()
    if suffix == ".gif":
        iio.mimsave(path, frames, duration=1000.0 / fps, loop=0)
    elif suffix == ".mp4":
        require_extra("imageio_ffmpeg", "video")
        iio.mimsave(path, frames, fps=fps)
    else:
        raise InvalidInputError("path", str(path), "a file name ending in .gif or .mp4")
    return path


def animate(
    plant: Any,
    sliders: FloatArray,
    renderer: SceneRenderer,
    camera: str = "closeup",
    frames: int = 60,
) -> list[Image]:
    """Drive a MuJoCo plant (`MujocoPlant`, `ArmPlant`) through actuator rows (N, the robot's
    count) and render `frames` images with the tip trace so far (a curved needle's: its arc's
    tip); the plant is reset to the first row."""
    n = len(plant.robot.home_actuators)
    s = np.asarray(sliders, dtype=float)
    s = matrix("sliders", s, (s.shape[0], n)) if s.ndim == 2 else matrix("sliders", s, (0, n))
    if len(s) == 0:
        raise InvalidInputError("sliders", sliders, f"at least one row of {n} actuator values")
    plant.reset(s[0])
    keep = set(np.linspace(0, len(s) - 1, max(1, frames)).round().astype(int).tolist())
    model = plant.scene()[0]
    arc = int(renderer.mj.mj_name2id(model, renderer.mj.mjtObj.mjOBJ_SITE, "needle_arc_tip"))
    trace, images = [], []
    for i, row in enumerate(s):
        if i > 0:
            plant.command_actuators(row)
            plant.advance()
        if arc >= 0:  # the arc's tip: a site of the scene only (posed on each call)
            trace.append(np.array(plant.scene()[1].site_xpos[arc]))
        else:
            trace.append(plant.tip_position())
        if i in keep:
            images.append(renderer.render(plant.scene()[1], camera, np.array(trace)))
    return images
