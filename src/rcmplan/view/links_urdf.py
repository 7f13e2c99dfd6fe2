"""A shipped arm's links in the view: its URDF's visual meshes, drawn by viser's URDF helper
(`viser.extras.ViserUrdf`, meshes read by yourdfpy and trimesh).

Only the links from the URDF's root to the flange the needle is mounted on are drawn (the
Panda's hand and fingers are not on rcmplan's arm). rcmplan places an arm in the world by
turning its URDF root about the vertical (`rcmplan.robot.arms.place_arm`): the meshes hang under
a frame at the chain's `base` pose, and the URDF's joints take the record's joints by name.
"""

from __future__ import annotations

from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.exceptions import MissingExtraError, require_extra
from rcmplan.robot.model import SerialArm


def arm_urdf(path: Path, flange: str) -> Any:
    """The URDF at `path` cut after `flange` (links on the root-to-flange path only), with its
    visual meshes loaded (a yourdfpy URDF)."""
    yourdfpy = require_extra("yourdfpy", "robots")
    full = yourdfpy.URDF.load(path, build_scene_graph=False, load_meshes=False)
    parent = {j.child: j.parent for j in full.robot.joints}
    keep, link = {flange}, flange
    while link in parent:
        link = parent[link]
        keep.add(link)
    robot = replace(
        full.robot,
        links=[lk for lk in full.robot.links if lk.name in keep],
        joints=[j for j in full.robot.joints if j.parent in keep and j.child in keep],
    )
    handler = partial(yourdfpy.filename_handler_magic, dir=path.parent)
    try:
        return yourdfpy.URDF(robot=robot, filename_handler=handler)
    except ImportError as exc:  # trimesh's reader of a mesh format (pycollada for .dae)
        raise MissingExtraError(getattr(exc, "name", None) or "a mesh reader", "view") from exc


class UrdfLinks:
    """An arm drawn from its URDF file.

    Args:
        server: The viser server. arm: The arm (its chain placed in the world).
        urdf_path: The URDF file the arm's chain was loaded from; flange: its end link.
        root: Scene-tree name.
    """

    def __init__(
        self, server: Any, arm: SerialArm, urdf_path: Path, flange: str, root: str = "/robot"
    ) -> None:
        extras = require_extra("viser.extras", "view")
        from viser import transforms as tf

        base = arm.chain.base
        server.scene.add_frame(
            root, show_axes=False, wxyz=tf.SO3.from_matrix(base[:3, :3]).wxyz,
            position=base[:3, 3],
        )  # fmt: skip
        self.urdf = extras.ViserUrdf(server, arm_urdf(urdf_path, flange), root_node_name=root)
        names = self.urdf.get_actuated_joint_names()
        chain_names = arm.chain.joint_names
        self._from = np.array([chain_names.index(n) if n in chain_names else -1 for n in names])
        self.note = f"{arm.name} links: visual meshes of {urdf_path.name} up to {flange}"

    def show(self, q: FloatArray, s: FloatArray) -> None:
        """Pose the meshes at joints q (n,) of the arm's chain."""
        cfg = np.where(self._from >= 0, np.asarray(q)[np.maximum(self._from, 0)], 0.0)
        self.urdf.update_cfg(cfg)
