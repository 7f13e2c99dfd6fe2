"""Homogeneous-transform helpers for writing MJCF: DH frames at home, quaternions, numbers.

Pure numpy, no MuJoCo: the model files are generated from the `Iramis` DH table so that the
MuJoCo bodies carry exactly the DH frames (one source of numbers).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.robot.dh import dh_transform
from rcmplan.robot.iramis import Iramis


def dh_home_transforms(robot: Iramis) -> list[FloatArray]:
    """T_{i-1}^i at q = 0 for the six DH links, each (4, 4); frame 6 is the needle tip."""
    return [dh_transform(lk.theta, lk.d, lk.a, lk.alpha) for lk in robot.dh_links()]


def inverse(T: FloatArray) -> FloatArray:
    """Inverse of a rigid transform (4, 4)."""
    out = np.eye(4)
    out[:3, :3] = T[:3, :3].T
    out[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return out


def quat_from_matrix(R: FloatArray) -> FloatArray:
    """Unit quaternion (w, x, y, z) of a rotation matrix, w >= 0 (Shepperd's method)."""
    tr = float(np.trace(R))
    diag = np.array([tr, R[0, 0], R[1, 1], R[2, 2]])
    k = int(np.argmax(diag))
    if k == 0:
        w = 0.5 * np.sqrt(1.0 + tr)
        q = np.array([w, R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
        q[1:] /= 4.0 * w
    else:
        i, j, m = k - 1, k % 3, (k + 1) % 3
        v = 0.5 * np.sqrt(1.0 + R[i, i] - R[j, j] - R[m, m])
        q = np.empty(4)
        q[0] = (R[m, j] - R[j, m]) / (4.0 * v)
        q[1 + i] = v
        q[1 + j] = (R[j, i] + R[i, j]) / (4.0 * v)
        q[1 + m] = (R[m, i] + R[i, m]) / (4.0 * v)
    q /= np.linalg.norm(q)
    return q if q[0] >= 0.0 else -q


def fmt(values: Sequence[float] | FloatArray) -> str:
    """Numbers as an MJCF attribute, at full double precision, tiny round-off set to zero."""
    arr = np.asarray(values, dtype=float)
    arr = np.where(np.abs(arr) < 1e-15, 0.0, arr)
    return " ".join(f"{float(v):.17g}" for v in arr)


def pose_attrs(T: FloatArray) -> dict[str, str]:
    """MJCF `pos` and `quat` attributes of a transform (4, 4)."""
    return {"pos": fmt(T[:3, 3]), "quat": fmt(quat_from_matrix(T[:3, :3]))}


def joint_in_child(T_parent_child: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(pos, axis) in the child frame of a DH joint acting about/along the parent's z axis.

    A DH joint moves frame i about/along z_{i-1} through the origin of frame i-1; MuJoCo puts
    a joint in the child body's frame, so both are mapped through the inverse home transform.
    """
    inv = inverse(T_parent_child)
    return inv[:3, 3].copy(), inv[:3, :3] @ np.array([0.0, 0.0, 1.0])
