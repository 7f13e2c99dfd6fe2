"""The QP's cost terms as kernels: the X_ext Jacobian from its parts and a weighted task's
(H, f), and its synchronisation on a servo plant. The Python QP (`qp_problem`, `objective`,
`qp`) and the compiled QP step call them."""

from __future__ import annotations

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.control.limits.rows import SCALE
from rcmplan.linalg import lu_solve


@njit(cache=True, borrows=True)
def x_ext_jacobian(JT_tip: FloatArray, JT_angles: FloatArray, JT_rcm: FloatArray,
                   out: FloatArray) -> None:  # fmt: skip
    """d X_ext / d (x SCALE) = J_a T (eq. 3.15, exact angle rows) into out (6, w): the tip's x
    row, the needle angles' rows JT_angles (2, w), the RCM point's rows."""
    for j in range(out.shape[1]):
        out[0, j] = JT_tip[0, j]
        out[1, j], out[2, j] = JT_angles[0, j], JT_angles[1, j]
        out[3, j], out[4, j], out[5, j] = JT_rcm[0, j], JT_rcm[1, j], JT_rcm[2, j]


@njit(cache=True, borrows=True)
def x_c_point_rows(task: FloatArray, JT: FloatArray) -> None:
    """The point rows of a curved needle's task d X_c / d (x SCALE) (7, w) into JT (6.., w):
    the tip's (X_c's rows 0-2), then the RCM point's (rows 4-6), as the rows' kernels read
    them (`x_ext_jacobian` builds X_ext's task from such rows)."""
    for j in range(task.shape[1]):
        for i in range(3):
            JT[i, j], JT[3 + i, j] = task[i, j], task[4 + i, j]


@njit(cache=True, borrows=True)
def weighted_cost(task: FloatArray, weights: FloatArray, K: FloatArray, e: FloatArray,
                  damping: float, H: FloatArray, f: FloatArray) -> None:  # fmt: skip
    """H (w, w) and f (w,) of 1/2 |W (task x SCALE - K e)|^2 / SCALE^2 + 1/2 D^2 |x|^2 for a
    task Jacobian (k, w) with row weights W (k,), gains K (k,) and error e (k,)."""
    k, n = task.shape
    for j in range(n):
        for col in range(n):
            acc = 0.0
            for i in range(k):
                acc += (weights[i] * task[i, j]) * (weights[i] * task[i, col])
            H[j, col] = acc
        H[j, j] += damping**2
        acc = 0.0
        for i in range(k):
            acc += (weights[i] * task[i, j]) * (weights[i] * K[i] * e[i] / SCALE)
        f[j] = -acc


@njit(cache=True, borrows=True)
def synchronise(H: FloatArray, f: FloatArray, speed: FloatArray, dt: float,
                M: FloatArray) -> float:  # fmt: skip
    """Scale the linear term f (w,) of 1/2 x'Hx + f'x by 1 / sigma when sigma > 1, sigma the
    largest fraction |x_i| / window_i that the unconstrained optimum x = -H^-1 f uses of the
    first k = len(speed) variables' windows, window_i = speed_i dt / SCALE (`qp.synchronised_step`);
    returns sigma. The solve is `linalg.lu_solve` in M (w + 1, w), scratch (H and f stay as
    they are)."""
    w = f.shape[0]
    for i in range(w):  # H in rows 0..w-1, f then -x in row w (H positive definite)
        for j in range(w):
            M[i, j] = H[i, j]
        M[w, i] = f[i]
    lu_solve(M, 0, w, w)
    sigma = 0.0
    for i in range(speed.shape[0]):
        sigma = max(sigma, abs(M[w, i]) / (speed[i] * dt / SCALE))
    if sigma > 1.0:
        for j in range(f.shape[0]):
            f[j] /= sigma
    return sigma
