"""A straight needle: the segment from p_base (lambda = 0) to p_tip (lambda = 1), eqs. 3.7-3.10."""

from __future__ import annotations

import numpy as np

from rcmplan._validate import FloatArray


def needle_point(p_base: FloatArray, p_tip: FloatArray, lam: float) -> FloatArray:
    """p(lambda) = p_base + lambda (p_tip - p_base) (eq. 3.7), in the frame of the inputs."""
    return p_base + lam * (p_tip - p_base)


def needle_point_jacobian(
    J_base: FloatArray, J_tip: FloatArray, p_base: FloatArray, p_tip: FloatArray, lam: float
) -> FloatArray:
    """Jacobian of p(lambda) w.r.t. (q, lambda): [J_base + lam (J_tip - J_base), p_tip - p_base].

    J_base and J_tip are the (3, n) linear-velocity Jacobians of the two points; the result is
    (3, n + 1), its last column the derivative along lambda (eqs. 3.9, 3.10).
    """
    J = np.empty((3, J_base.shape[1] + 1))
    J[:, :-1] = J_base + lam * (J_tip - J_base)
    J[:, -1] = p_tip - p_base
    return J


def closest_lambda(p_base: FloatArray, p_tip: FloatArray, point: FloatArray) -> float:
    """The lambda in [0, 1] of the needle point closest to `point` (drift correction, ch. 5)."""
    axis = p_tip - p_base
    lam = float(np.dot(point - p_base, axis) / np.dot(axis, axis))
    return min(1.0, max(0.0, lam))
