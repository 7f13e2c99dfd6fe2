"""A shipped arm's links in the view: its URDF's visual meshes, drawn by viser's URDF helper
(`viser.extras.ViserUrdf`, meshes read by yourdfpy and trimesh).

rcmplan places an arm in the world by turning its URDF root about the vertical
(`rcmplan.robot.arms.place_arm`): the meshes hang under a frame at the chain's `base` pose, and
the URDF's joints take the record's joints by name (joints off the chain, such as the Panda's
fingers, stay at zero).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.exceptions import MissingExtraError, require_extra
from rcmplan.robot.model import SerialArm


class UrdfLinks:
    """An arm drawn from its URDF file.

    Args:
        scene_target: The ViserServer. arm: The arm (its chain placed in the world).
        urdf_path: The URDF file the arm's chain was loaded from. root: Scene-tree name.
    """

    def __init__(self, scene_target: Any, arm: SerialArm, urdf_path: Any, root: str = "/robot"):
        require_extra("yourdfpy", "robots")
        extras = require_extra("viser.extras", "view")
        from viser import transforms as tf

        base = arm.chain.base
        scene_target.scene.add_frame(
            root, show_axes=False, wxyz=tf.SO3.from_matrix(base[:3, :3]).wxyz,
            position=base[:3, 3],
        )  # fmt: skip
        try:
            self.urdf = extras.ViserUrdf(scene_target, urdf_path, root_node_name=root)
        except ImportError as exc:  # trimesh's reader of a mesh format
            raise MissingExtraError(getattr(exc, "name", None) or "a mesh reader", "view") from exc
        names = self.urdf.get_actuated_joint_names()
        chain_names = arm.chain.joint_names
        self._from = np.array([chain_names.index(n) if n in chain_names else -1 for n in names])
        self.note = f"{arm.name} links: visual meshes of {urdf_path.name}"

    def show(self, q: FloatArray, s: FloatArray) -> None:
        """Pose the meshes at joints q (n,) of the arm's chain."""
        cfg = np.where(self._from >= 0, np.asarray(q)[np.maximum(self._from, 0)], 0.0)
        self.urdf.update_cfg(cfg)
