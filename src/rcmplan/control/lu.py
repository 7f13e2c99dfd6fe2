"""The compiled LU solve every compiled step uses (`rcmplan.compiled.chain_solve`, the curved
needle's `rcmplan.control.curved_step`): one place, so that every solve rounds alike."""

from __future__ import annotations

from numba import njit

from rcmplan._validate import FloatArray


@njit(cache=True)
def lu_solve(W: FloatArray, S: int, n: int, b: int) -> None:
    """Solve M x = W[b, :n] in place for the n x n matrix M at rows S.. of W (overwritten):
    Gaussian elimination with partial pivoting as LAPACK's getrf/getrs do it (multipliers
    scaled by the pivot's reciprocal, back substitution dividing), the way `np.linalg.solve`
    solves the reference's systems."""
    for c in range(n):
        p = c
        for r in range(c + 1, n):
            if abs(W[S + r, c]) > abs(W[S + p, c]):
                p = r
        if p != c:
            for k in range(c, n):
                W[S + c, k], W[S + p, k] = W[S + p, k], W[S + c, k]
            W[b, c], W[b, p] = W[b, p], W[b, c]
        inv = 1.0 / W[S + c, c]
        for r in range(c + 1, n):
            f = W[S + r, c] * inv
            for k in range(c + 1, n):
                W[S + r, k] -= f * W[S + c, k]
            W[b, r] -= f * W[b, c]
    for r in range(n - 1, -1, -1):
        acc = W[b, r]
        for k in range(r + 1, n):
            acc -= W[S + r, k] * W[b, k]
        W[b, r] = acc / W[S + r, r]
