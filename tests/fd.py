"""One shared finite-difference Jacobian for every Jacobian test.

`fd_jacobian(f, x)` differentiates f at x by central differences, column by column:
- f(x) a vector (m,): the (m, n) Jacobian d f / d x;
- f(x) a rotation (3, 3): the (3, n) angular Jacobian, column j = log(R(x+h) R(x-h)^T) / (2 eps),
  the world-frame angular velocity per unit x_j;
- f(x) a pose (4, 4): the (6, n) geometric Jacobian, rows (linear velocity of the origin,
  angular velocity), both in the world frame, as a robot's geometric Jacobian states them.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.spatial.transform import Rotation


def rotation_log(R: np.ndarray) -> np.ndarray:
    """The rotation vector (3,) of a rotation matrix, in [rad]."""
    return Rotation.from_matrix(R).as_rotvec()


def _difference(plus: np.ndarray, minus: np.ndarray) -> np.ndarray:
    """f(x+h) - f(x-h) as a vector: plain for vectors, through the rotation log otherwise."""
    if plus.shape == (3, 3):
        return rotation_log(plus @ minus.T)
    if plus.shape == (4, 4):
        angular = rotation_log(plus[:3, :3] @ minus[:3, :3].T)
        return np.concatenate([plus[:3, 3] - minus[:3, 3], angular])
    return np.ravel(plus - minus)


def fd_jacobian(
    f: Callable[[np.ndarray], np.ndarray], x: np.ndarray, eps: float = 1e-6
) -> np.ndarray:
    """The (m, n) central-difference Jacobian of f at x (see the module docstring for m)."""
    x = np.asarray(x, dtype=float)
    columns = []
    for j in range(x.size):
        h = np.zeros_like(x)
        h[j] = eps
        plus, minus = np.asarray(f(x + h), dtype=float), np.asarray(f(x - h), dtype=float)
        columns.append(_difference(plus, minus) / (2.0 * eps))
    return np.stack(columns, axis=1)
