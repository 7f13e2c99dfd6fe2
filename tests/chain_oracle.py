"""Numpy oracles of a serial arm's second-order kinematics, for the tests that hold the kernels
(`robot/chain_singular.py`) to an independent formulation: the point Jacobian's derivatives
over the joints, and the singularity measure's gradient through numpy's SVD, on the point
Jacobian written in numpy (`point_jacobian`)."""

from __future__ import annotations

import numpy as np

from rcmplan.robot.chain import JointChain
from rcmplan.robot.model import SerialArm


def cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b for (3,) arrays, or row-wise for arrays of 3-vectors that broadcast ((..., 3));
    numpy's cross costs tens of microseconds per call, this a few."""
    if a.ndim == 1 and b.ndim == 1:
        return np.array(
            [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
        )
    x = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    y = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    z = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return np.stack([x, y, z], axis=-1)


def point_jacobian(chain: JointChain, T: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Geometric Jacobian (6, n) of the world point p (3,) moving with the end frame, at the
    frames T (n + 1, 4, 4) of `JointChain.frames` (eqs. 2.9-2.11), in numpy."""
    n = chain.n
    z = np.einsum("kij,kj->ki", T[:n, :3, :3], np.asarray(chain.axes))  # joint axes, world
    prismatic = np.asarray(chain.prismatic, dtype=bool)
    lin = np.where(prismatic[:, None], z, cross3(z, p - T[:n, :3, 3]))  # eqs. 2.10, 2.11
    return np.vstack([lin.T, np.where(prismatic[:, None], 0.0, z).T])


def jacobian_derivatives(chain: JointChain, T: np.ndarray, J: np.ndarray) -> np.ndarray:
    """d J / d q_j for every joint j, (n, 6, n), of the point Jacobian J (6, n)
    (`point_jacobian` at frames T).

    Column k of a revolute joint is (z_k x (p - o_k), z_k); of a prismatic one (z_k, 0).
    A revolute joint j turns the joints after it and the point: for k > j the column turns
    with it, z_j x J_k; for k <= j only the point moves, z_k x J_v,j (revolute k). A
    prismatic joint j moves the point and the later joints' origins alike: only columns
    k <= j of revolute joints change, z_k x z_j.
    """
    n = chain.n
    z = np.einsum("kij,kj->ki", T[:n, :3, :3], np.asarray(chain.axes))
    revolute = ~np.asarray(chain.prismatic, dtype=bool)
    jj, kk = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    early = (kk <= jj) & revolute[None, :]  # z_k x J_v,j
    late = (kk > jj) & revolute[:, None]  # z_j x J_k
    out = np.zeros((n, 6, n))
    lin_early = cross3(z[None, :, :], J[:3].T[:, None, :])  # [j, k] = z_k x J_v,j
    lin_late = cross3(z[:, None, :], J[:3].T[None, :, :])  # [j, k] = z_j x J_v,k
    ang_late = cross3(z[:, None, :], J[3:].T[None, :, :])  # [j, k] = z_j x J_w,k
    lin = np.where(early[..., None], lin_early, 0.0) + np.where(late[..., None], lin_late, 0.0)
    out[:, :3, :] = lin.transpose(0, 2, 1)
    out[:, 3:, :] = np.where(late[..., None], ang_late, 0.0).transpose(0, 2, 1)
    return out


def singular_terms(arm: SerialArm, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """kappa = s_min / s_max of M = [J_tip / l; N J_omega] (1,) and its gradient (1, n) from
    numpy's SVD: d s_i / d q_j = u_i' (dM / dq_j) v_i, dM / dq_j from `jacobian_derivatives`
    and the normals' motion with the needle axis (d a / d q_j = omega_j x a)."""
    chain = arm.chain
    T = chain.frames(q)
    act = list(arm.active)
    J = point_jacobian(chain, T, T[-1, :3, :3] @ arm.needle.point_local(1.0) + T[-1, :3, 3])
    a = arm.needle_axis(q)
    helper = np.zeros(3)
    helper[int(np.argmin(np.abs(a)))] = 1.0
    c = cross3(a, helper)
    n1 = c / np.linalg.norm(c)
    N = np.array([n1, cross3(a, n1)])
    length = arm.needle_length
    M = np.vstack([J[:3, act] / length, N @ J[3:, act]])
    U, S, Vt = np.linalg.svd(M, full_matrices=False)
    grad = np.zeros((1, chain.n))
    dJ = jacobian_derivatives(chain, T, J)[act][:, :, act]  # (m, 6, m)
    da = cross3(J[3:, act].T, a)  # (m, 3): omega_j x a
    dc = cross3(da, helper)
    dn1 = (dc - np.outer(dc @ n1, n1)) / np.linalg.norm(c)
    dn2 = cross3(da, n1) + cross3(a, dn1)
    dN = np.stack([dn1, dn2], axis=1)  # (m, 2, 3)
    dM = np.concatenate([dJ[:, :3] / length, dN @ J[3:, act] + N @ dJ[:, 3:]], axis=1)
    ds_min = np.einsum("i,jik,k->j", U[:, -1], dM, Vt[-1])
    ds_max = np.einsum("i,jik,k->j", U[:, 0], dM, Vt[0])
    grad[0, act] = (ds_min * S[0] - S[-1] * ds_max) / S[0] ** 2
    return np.array([S[-1] / S[0]]), grad
