"""Many arrays in two buffers, so that a kernel called from Python once per control period
receives two arrays instead of dozens: numba converts each array argument of every call (about
0.15 us each), and a step's arrays (the arm, its work array, the settings, the QP's buffers)
number about thirty.

`pack` copies float64 arrays into one float64 buffer F, int64 and int32 arrays into one int64
buffer I, each from a 64-byte boundary; I's head holds, per array in the order given, its start
(in words of its buffer), rows and columns (0 columns: a vector). Compiled code gets the
arrays back as views (`vec`, `mat`, `ints`, `int32s`: no copy, no allocation), so Python, the
kernels and DAQP's C code all work in the buffers' memory.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numba import njit

from rcmplan._validate import FloatArray
from rcmplan.robot.chain_kinematics import IntArray

ALIGN = 8  # words: every array (and each buffer) starts on a 64-byte boundary
HEAD = 3  # words of I's head per array: start, rows, columns


def _words(count: int) -> int:
    """count rounded up to a whole number of ALIGN words."""
    return -(-count // ALIGN) * ALIGN


def _aligned(words: int, dtype: type) -> np.ndarray:
    """A zeroed 1-D array of `words` 8-byte elements starting on a 64-byte boundary."""
    raw = np.zeros(words + ALIGN, dtype=dtype)
    skip = (-raw.ctypes.data % (8 * ALIGN)) // 8
    return raw[skip : skip + words]


def pack(arrays: Sequence[np.ndarray]) -> tuple[FloatArray, IntArray]:
    """(F, I) holding copies of `arrays` (float64, int64 or int32; 1-D or 2-D), in the layout
    of the module docstring."""
    spans = []
    f_used, i_used = 0, _words(HEAD * len(arrays))
    for a in arrays:
        if a.dtype not in (np.float64, np.int64, np.int32) or a.ndim not in (1, 2):
            raise ValueError(f"cannot pack an array of {a.dtype} with {a.ndim} dimensions")
        words = _words(a.size if a.dtype != np.int32 else (a.size + 1) // 2)
        if a.dtype == np.float64:
            spans.append(f_used)
            f_used += words
        else:
            spans.append(i_used)
            i_used += words
    F, I = _aligned(f_used, np.float64), _aligned(i_used, np.int64)
    for k, (a, start) in enumerate(zip(arrays, spans, strict=True)):
        I[HEAD * k : HEAD * k + HEAD] = start, a.shape[0], a.shape[1] if a.ndim == 2 else 0
        if a.dtype == np.float64:
            F[start : start + a.size] = a.ravel()
        elif a.dtype == np.int64:
            I[start : start + a.size] = a.ravel()
        else:
            I[start : start + (a.size + 1) // 2].view(np.int32)[: a.size] = a
    return F, I


@njit(cache=True)
def vec(F: FloatArray, I: IntArray, k: int) -> FloatArray:
    """Array k of `pack`'s arrays, a float64 vector, as a view of F."""
    start = I[HEAD * k]
    return F[start : start + I[HEAD * k + 1]]


@njit(cache=True)
def mat(F: FloatArray, I: IntArray, k: int) -> FloatArray:
    """Array k of `pack`'s arrays, a float64 matrix, as a view of F."""
    start, rows, cols = I[HEAD * k], I[HEAD * k + 1], I[HEAD * k + 2]
    return F[start : start + rows * cols].reshape((rows, cols))


@njit(cache=True)
def ints(I: IntArray, k: int) -> IntArray:
    """Array k of `pack`'s arrays, an int64 vector, as a view of I."""
    start = I[HEAD * k]
    return I[start : start + I[HEAD * k + 1]]


@njit(cache=True)
def int32s(I: IntArray, k: int) -> np.ndarray:
    """Array k of `pack`'s arrays, an int32 vector, as a view of I."""
    start, size = I[HEAD * k], I[HEAD * k + 1]
    return I[start : start + (size + 1) // 2].view(np.int32)[:size]
