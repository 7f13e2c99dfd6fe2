"""Many arrays in two buffers, so that a kernel called from Python once per control period
receives two arrays instead of dozens: numba converts each array argument of every call (about
0.08 us each, measured with an empty kernel), and a step's arrays (the arm, its work array, the
settings, the QP's buffers) number about thirty.

`pack` copies float64 arrays into one float64 buffer F, int64 and int32 arrays into one int64
buffer Z (integers), each from a 64-byte boundary; Z's head holds, per array in the order
given, its start (in words of its buffer), rows and columns (0 columns: a vector). Python gets
the arrays back from `pack` itself, as views of the buffers; compiled code as views too (`vec`,
`mat`, `ints`, `int32s`: no copy, no allocation; inlined into the caller), so Python, the
kernels and DAQP's C code all work in the buffers' memory.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from rcmplan._jit import njit
from rcmplan._validate import FloatArray
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.chain_kinematics import IntArray

ALIGN = 8  # words: every array (and each buffer) starts on a 64-byte boundary
HEAD = 3  # words of Z's head per array: start, rows, columns


def _words(count: int) -> int:
    """count rounded up to a whole number of ALIGN words."""
    return -(-count // ALIGN) * ALIGN


def _aligned(words: int, dtype: type) -> np.ndarray:
    """A zeroed 1-D array of `words` 8-byte elements starting on a 64-byte boundary."""
    raw: np.ndarray = np.zeros(words + ALIGN, dtype=dtype)
    skip = (-raw.ctypes.data % (8 * ALIGN)) // 8
    return raw[skip : skip + words]


def pack(arrays: Sequence[np.ndarray]) -> tuple[FloatArray, IntArray, list[np.ndarray]]:
    """(F, Z, views): F and Z holding copies of `arrays` (float64 vectors and matrices, int64
    and int32 vectors) in the layout of the module docstring, and each array's copy as a view
    of its buffer, in the order given."""
    spans = []
    f_used, i_used = 0, _words(HEAD * len(arrays))
    for a in arrays:
        integers = a.ndim == 1 and a.dtype in (np.int64, np.int32)
        if not integers and (a.dtype != np.float64 or a.ndim not in (1, 2)):
            valid = "float64 vectors or matrices, int64 or int32 vectors"
            raise InvalidInputError("arrays", f"an array of {a.dtype}, shape {a.shape}", valid)
        words = _words(a.size if a.dtype != np.int32 else (a.size + 1) // 2)
        if a.dtype == np.float64:
            spans.append(f_used)
            f_used += words
        else:
            spans.append(i_used)
            i_used += words
    F, Z = _aligned(f_used, np.float64), _aligned(i_used, np.int64)
    views: list[np.ndarray] = []
    for k, (a, start) in enumerate(zip(arrays, spans, strict=True)):
        Z[HEAD * k : HEAD * k + HEAD] = start, a.shape[0], a.shape[1] if a.ndim == 2 else 0
        if a.dtype == np.float64:
            view = F[start : start + a.size].reshape(a.shape)
        elif a.dtype == np.int64:
            view = Z[start : start + a.size]
        else:
            view = Z[start : start + (a.size + 1) // 2].view(np.int32)[: a.size]
        view[...] = a
        views.append(view)
    return F, Z, views


@njit(cache=True, inline="always")
def vec(F: FloatArray, Z: IntArray, k: int) -> FloatArray:
    """Array k of `pack`'s arrays, a float64 vector, as a view of F."""
    start = Z[HEAD * k]
    return F[start : start + Z[HEAD * k + 1]]


@njit(cache=True, inline="always")
def mat(F: FloatArray, Z: IntArray, k: int) -> FloatArray:
    """Array k of `pack`'s arrays, a float64 matrix, as a view of F."""
    start, rows, cols = Z[HEAD * k], Z[HEAD * k + 1], Z[HEAD * k + 2]
    return F[start : start + rows * cols].reshape((rows, cols))


@njit(cache=True, inline="always")
def ints(Z: IntArray, k: int) -> IntArray:
    """Array k of `pack`'s arrays, an int64 vector, as a view of Z."""
    start = Z[HEAD * k]
    return Z[start : start + Z[HEAD * k + 1]]


@njit(cache=True, inline="always")
def int32s(Z: IntArray, k: int) -> np.ndarray:
    """Array k of `pack`'s arrays, an int32 vector, as a view of Z."""
    start, size = Z[HEAD * k], Z[HEAD * k + 1]
    return Z[start : start + (size + 1) // 2].view(np.int32)[:size]
