"""iRAM!S's links in the view: the visual geoms of its generated MJCF, posed by MuJoCo.

The MJCF (`rcmplan.sim.mujoco.model`) carries the DH frames exactly and closes each PCJM loop
with sliders and pins; a record's joints q and sliders s pose it: q and s are written into the
joint positions and the loops are closed by MuJoCo's kinematics (`assembly.assemble`), so the
rails, carriages, stages and holder drawn are MuJoCo's own. Each body with visual geoms is one
scene frame; its geoms are children at their fixed local poses, so a record moves only the
frames. The needle is drawn by the view from the log, not from the MJCF.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.exceptions import SimulationError
from rcmplan.robot.iramis import SLIDER_NAMES, Iramis

VISUAL_GROUP = 2  # the MJCF's `visual` default class
SKIPPED = ("needle",)  # drawn by the view from the log
JOINTS = ("q0", "q1", "q2", "q3", "L5", "q5")  # the joints q (thesis numbering) in the MJCF
# MuJoCo geom types
SPHERE, CAPSULE, ELLIPSOID, CYLINDER, BOX = 2, 3, 4, 5, 6


class MujocoLinks:
    """iRAM!S drawn from its MJCF's visual geoms.

    Args:
        scene: A viser SceneApi. robot: The iRAM!S model the MJCF is generated from.
        root: Scene-tree name under which the links are added.
    """

    def __init__(self, scene: Any, robot: Iramis, root: str = "/robot") -> None:
        from rcmplan.sim.mujoco.assembly import LoopIndex
        from rcmplan.sim.mujoco.files import load_model, mujoco_module

        self.mj = mujoco_module()
        self.robot = robot
        self.model = load_model(robot, scene=False)
        self.data = self.mj.MjData(self.model)
        self.index = LoopIndex.of(self.mj, self.model)
        self._qpos_q = self._qpos_of(JOINTS)
        self._qpos_s = self._qpos_of(SLIDER_NAMES)
        self.frames: dict[int, Any] = {}
        self.geoms = 0
        for g in range(self.model.ngeom):
            visual = int(self.model.geom_group[g]) == VISUAL_GROUP
            if visual and self.model.geom(g).name not in SKIPPED:
                self._add_geom(scene, root, g)
        self.note = f"iRAM!S links: {self.geoms} visual geoms of its MJCF, posed by MuJoCo"

    def _qpos_of(self, names: tuple[str, ...]) -> list[int]:
        jnt = self.mj.mjtObj.mjOBJ_JOINT
        ids = [int(self.mj.mj_name2id(self.model, jnt, n)) for n in names]
        return [int(self.model.jnt_qposadr[j]) for j in ids]

    def _add_geom(self, scene: Any, root: str, g: int) -> None:
        m = self.model
        body = int(m.geom_bodyid[g])
        if body not in self.frames:
            self.frames[body] = scene.add_frame(f"{root}/body{body}", show_axes=False)
        name = f"{root}/body{body}/geom{g}"
        pose = {"position": np.array(m.geom_pos[g]), "wxyz": np.array(m.geom_quat[g])}
        rgba = np.array(m.geom_rgba[g])
        look = {"color": tuple(int(c) for c in np.round(255 * rgba[:3])),
                "opacity": None if rgba[3] >= 1.0 else float(rgba[3])}  # fmt: skip
        kind, size = int(m.geom_type[g]), np.array(m.geom_size[g])
        if kind == BOX:
            scene.add_box(name, dimensions=2 * size, **look, **pose)
        elif kind in (CYLINDER, CAPSULE):
            scene.add_cylinder(name, radius=size[0], height=2 * size[1], **look, **pose)
            if kind == CAPSULE:  # the caps, in the cylinder's frame (its axis is z)
                for end in (-1.0, 1.0):
                    scene.add_icosphere(f"{name}/cap{end:+.0f}", radius=size[0], **look,
                                        position=(0.0, 0.0, end * size[1]))  # fmt: skip
        elif kind in (SPHERE, ELLIPSOID):
            scale = 1.0 if kind == SPHERE else tuple(size / size[0])
            scene.add_icosphere(name, radius=size[0], scale=scale, **look, **pose)
        else:
            return
        self.geoms += 1

    def show(self, q: FloatArray, s: FloatArray) -> None:
        """Pose the links at joints q (6,) and sliders s (6,) of one record."""
        from rcmplan.sim.mujoco.assembly import assemble

        d = self.data
        d.qpos[self._qpos_q] = q
        d.qpos[self._qpos_s] = s
        try:
            assemble(self.mj, self.model, d, self.index, tol=1e-9, max_iter=20)
        except SimulationError:
            self.mj.mj_kinematics(self.model, d)  # shown as logged, loops left as they are
        for body, frame in self.frames.items():
            frame.position = np.array(d.xpos[body])
            frame.wxyz = np.array(d.xquat[body])
