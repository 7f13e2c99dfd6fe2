"""The linear algebra of every step, written once and compiled: the LU solve, the damped
(or minimum-norm) least-squares step, the square solve and the pseudoinverse step with a
null-space term. The robot models' Newton solves, the Python solvers and the compiled loops
all call these functions, so every step rounds alike whoever drives it.

The kernels work on rows of one float64 array W (a work block), named by their first row:
J (rows j.., `rows` x `cols`), a `rows` x `rows` scratch matrix S (rows s..), and vector
rows b (right-hand side, then solution) and z (a null-space step). W is at least
max(rows, cols) wide. `step` is the entry for a Jacobian held as its own array.
"""

from __future__ import annotations

import numpy as np

from rcmplan._jit import njit
from rcmplan._validate import FloatArray


# A zero pivot gives inf or NaN, not an exception.
@njit(cache=True, borrows=True, error_model="numpy")
def lu_solve(W: FloatArray, s: int, n: int, b: int) -> None:
    """Solve M x = W[b, :n] in place for the n x n matrix M at rows s.. of W (overwritten):
    Gaussian elimination with partial pivoting as LAPACK's getrf/getrs do it (multipliers
    scaled by the pivot's reciprocal, back substitution dividing). A singular M gives inf or
    NaN in x."""
    for c in range(n):
        p = c
        for r in range(c + 1, n):
            if abs(W[s + r, c]) > abs(W[s + p, c]):
                p = r
        if p != c:
            for k in range(c, n):
                W[s + c, k], W[s + p, k] = W[s + p, k], W[s + c, k]
            W[b, c], W[b, p] = W[b, p], W[b, c]
        inv = 1.0 / W[s + c, c]
        for r in range(c + 1, n):
            f = W[s + r, c] * inv
            for k in range(c + 1, n):
                W[s + r, k] -= f * W[s + c, k]
            W[b, r] -= f * W[b, c]
    for r in range(n - 1, -1, -1):
        acc = W[b, r]
        for k in range(r + 1, n):
            acc -= W[s + r, k] * W[b, k]
        W[b, r] = acc / W[s + r, r]


@njit(cache=True, borrows=True)
def gram(W: FloatArray, j: int, rows: int, cols: int, damping: float, s: int) -> None:
    """S = J J^T + D^2 I (rows x rows) over J's first `cols` columns, into rows s.."""
    for i in range(rows):
        for k in range(i + 1):
            acc = 0.0
            for c in range(cols):
                acc += W[j + i, c] * W[j + k, c]
            W[s + i, k], W[s + k, i] = acc, acc
        W[s + i, i] += damping * damping


@njit(cache=True, borrows=True)
def back(W: FloatArray, j: int, rows: int, cols: int, b: int, d: FloatArray) -> None:
    """d[:cols] = J^T W[b, :rows]."""
    for c in range(cols):
        acc = 0.0
        for i in range(rows):
            acc += W[j + i, c] * W[b, i]
        d[c] = acc


@njit(cache=True, borrows=True)
def damped(W: FloatArray, j: int, rows: int, cols: int, damping: float, s: int, b: int,
           d: FloatArray) -> None:  # fmt: skip
    """d[:cols] = J^T f with (J J^T + D^2 I) f = W[b] (eqs. 2.19, 2.20): damped least squares,
    or with D = 0 the minimum-norm solution of J d = W[b] (J of full row rank). W[b] and S
    are overwritten."""
    gram(W, j, rows, cols, damping, s)
    lu_solve(W, s, rows, b)
    back(W, j, rows, cols, b, d)


@njit(cache=True, borrows=True)
def square(W: FloatArray, j: int, n: int, s: int, b: int, d: FloatArray) -> None:
    """d = J^-1 W[b] for the square J (n x n), copied to S and solved there (`lu_solve`);
    W[b] is overwritten."""
    for r in range(n):
        for c in range(n):
            W[s + r, c] = W[j + r, c]
    lu_solve(W, s, n, b)
    for r in range(n):
        d[r] = W[b, r]


@njit(cache=True, borrows=True)
def pinv(W: FloatArray, j: int, rows: int, cols: int, s: int, b: int, z: int,
         d: FloatArray) -> None:  # fmt: skip
    """d with J d = W[b]: `square` when J is square, else the minimum-norm solution plus the
    null-space part of the step W[z]: d = J^+ (W[b] - J z) + z."""
    if cols == rows:
        square(W, j, rows, s, b, d)
        return
    for i in range(rows):
        acc = W[b, i]
        for c in range(cols):
            acc -= W[j + i, c] * W[z, c]
        W[b, i] = acc
    damped(W, j, rows, cols, 0.0, s, b, d)
    for c in range(cols):
        d[c] += W[z, c]


def step(J: FloatArray, rhs: FloatArray, damping: float = 0.0,
         z: FloatArray | None = None) -> FloatArray:  # fmt: skip
    """The step d (cols,) of the Jacobian J (rows, cols) for the right-hand side rhs (rows,):
    `damped` with D = damping, or with z (cols,) given `pinv` (square: J^-1 rhs; wide: the
    minimum-norm solution plus z's null-space part). Non-finite entries where the system is
    singular."""
    rows, cols = J.shape
    W = np.zeros((2 * rows + 2, max(rows, cols)))
    W[:rows, :cols] = J
    b = 2 * rows
    W[b, :rows] = rhs
    d = np.empty(cols)
    if z is None:
        damped(W, 0, rows, cols, float(damping), rows, b, d)
    else:
        W[b + 1, :cols] = z
        pinv(W, 0, rows, cols, rows, b, b + 1, d)
    return d
