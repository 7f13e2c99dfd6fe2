"""Kernels compiled without numba's reference counts (`rcmplan._jit.njit(borrows=True)`): what
they may not do is refused when they compile (the records of the loops built from them are held
to the reference loop's by tests/test_fast.py and the compiled-path tests)."""

from __future__ import annotations

import numpy as np
import pytest

from rcmplan._jit import njit


def test_a_borrowing_kernel_that_returns_an_array_is_refused() -> None:
    @njit(borrows=True)
    def same(a):  # type: ignore[no-untyped-def]
        return a

    with pytest.raises(TypeError, match=r"same: compiled without reference counts but returns"):
        same(np.arange(3.0))


def test_a_borrowing_kernel_that_takes_an_array_from_a_call_is_refused() -> None:
    @njit()
    def tail(a):  # type: ignore[no-untyped-def]
        return a[1:]

    @njit(borrows=True)
    def first_of_tail(a):  # type: ignore[no-untyped-def]
        return tail(a)[0]

    tail(np.arange(3.0))  # compiled with reference counts: it returns a new reference
    with pytest.raises(TypeError, match=r"first_of_tail: .* takes an array .* from the call"):
        first_of_tail(np.arange(3.0))


def test_a_kernel_compiled_first_for_a_borrowing_caller_is_held_to_the_same_rule() -> None:
    @njit()
    def same(a):  # type: ignore[no-untyped-def]
        return a  # numba compiles it without reference counts for the caller below

    @njit(borrows=True)
    def head(a):  # type: ignore[no-untyped-def]
        return same(a)[0]

    with pytest.raises(TypeError, match=r"same: compiled without reference counts but returns"):
        head(np.arange(3.0))


def test_a_borrowing_kernel_computes_as_the_counted_one() -> None:
    def total(a):  # type: ignore[no-untyped-def]
        s = 0.0
        for x in a[1:]:
            s += x * x
        return s

    a = np.linspace(-1.0, 2.0, 7)
    assert njit(borrows=True)(total)(a) == njit()(total)(a) == total(a)


def test_a_borrowing_kernel_may_view_its_own_arguments() -> None:
    @njit(borrows=True)
    def low_word(a):  # type: ignore[no-untyped-def]
        return a.view(np.int32)[0]  # a view of the argument: borrowed, not a new reference

    assert low_word(np.array([7], dtype=np.int64)) == 7
