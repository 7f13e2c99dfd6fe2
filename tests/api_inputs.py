"""Plausible-but-wrong inputs for the public API and the rule every call must keep.

`probe(label, fn, *args)` calls fn: a typed rcmplan error (an `InvalidInputError` naming one
of the arguments, when `names` are given) or a result that `ok` accepts (finite, within its
documented bounds) passes; a generic Python exception, a RuntimeWarning on the way (numpy's
"overflow encountered", "invalid value": bad input must be refused, not computed with) or a
result `ok` refuses fails the test.
With RCMPLAN_API_TALLY=FILE set, nothing fails: every outcome is counted per label and the
counts are written to FILE (JSON) when the run ends, the measure in docs/robustness.md.
"""

from __future__ import annotations

import atexit
import json
import math
import os
import shutil
import tempfile
import warnings
from collections import Counter, defaultdict
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

from rcmplan.exceptions import InvalidInputError, RcmplanError

TALLY_FILE = os.environ.get("RCMPLAN_API_TALLY")
FOLDER = Path(tempfile.mkdtemp(prefix="rcmplan-api-"))  # files the tests write, removed at exit
atexit.register(shutil.rmtree, FOLDER, True)
TALLY: dict[str, Counter[str]] = defaultdict(Counter)
FIRST: dict[str, list[str]] = defaultdict(list)  # the first faults of each label, for the report


def examples(n: int) -> settings:
    """Seeded settings with n examples per test (the same inputs on every run)."""
    return settings(
        max_examples=n, derandomize=True, database=None, deadline=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much,
                               HealthCheck.data_too_large],
    )  # fmt: skip


def finite(x: Any) -> bool:
    """True when x is a finite number or an array of finite numbers (not bool, not text)."""
    if isinstance(x, str | bytes | bool | np.bool_) or x is None:
        return False
    try:
        arr = np.asarray(x, dtype=float)
    except (TypeError, ValueError, OverflowError):
        return False
    return bool(np.all(np.isfinite(arr)))


def shaped(shape: tuple[int, ...]) -> Callable[[Any], bool]:
    """A check: a finite float array of this shape."""
    return lambda x: isinstance(x, np.ndarray) and x.shape == shape and finite(x)


def fields_finite(obj: Any) -> bool:
    """True when every numeric attribute of a constructed object (dataclass, named tuple or
    plain object) is finite: no NaN or inf kept for later."""
    values: Iterable[Any]
    if hasattr(obj, "_asdict"):
        values = obj._asdict().values()
    else:
        values = vars(obj).values() if hasattr(obj, "__dict__") else ()
    for v in values:
        if isinstance(v, bool | str | np.bool_) or v is None:
            continue
        if isinstance(v, int | float | np.number) and not math.isfinite(float(v)):
            return False
        if isinstance(v, np.ndarray) and v.dtype.kind == "f" and not np.isfinite(v).all():
            return False
        numeric = isinstance(v, tuple) and all(isinstance(e, int | float) for e in v)
        if numeric and not all(math.isfinite(float(e)) for e in v):
            return False
    return True


def _record(label: str, outcome: str, detail: str = "") -> None:
    TALLY[label][outcome] += 1
    if detail and len(FIRST[label]) < 3:
        FIRST[label].append(detail[:300])


def probe(
    label: str, fn: Callable[..., Any], *args: Any, ok: Callable[[Any], bool] | None = None,
    names: tuple[str, ...] = (), **kwargs: Any,
) -> Any:  # fmt: skip
    """fn(*args, **kwargs) under the rule (module docstring); the result, or None if refused."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)  # raised, then a generic fault
            out = fn(*args, **kwargs)
    except RcmplanError as exc:
        named = (
            type(exc) is not InvalidInputError
            or not names
            or any(n in str(exc.name) for n in names)
        )
        if not named:
            return _fault(label, "unnamed", f"{exc.name!r} names none of {names}: {exc}")
        _record(label, "typed")
        return None
    except Exception as exc:  # the rule: never a generic Python exception
        return _fault(label, "generic", f"{type(exc).__name__}: {exc}")
    if ok is not None and not _holds(ok, out):
        return _fault(label, "silent", f"returned {out!r}"[:300])
    _record(label, "ok")
    return out


def _holds(ok: Callable[[Any], bool], out: Any) -> bool:
    """ok(out), False when the check itself cannot read the result."""
    try:
        return bool(ok(out))
    except Exception:
        return False


def _fault(label: str, kind: str, detail: str) -> None:
    _record(label, kind, f"{kind}: {detail}")
    if TALLY_FILE is None:
        raise AssertionError(f"{label}: {kind}: {detail}")


def _write_tally() -> None:
    if TALLY_FILE is None or not TALLY:
        return
    faults = ("generic", "silent", "unnamed")
    report = {
        "calls": sum(sum(c.values()) for c in TALLY.values()),
        "faults": {k: sum(c[k] for c in TALLY.values()) for k in faults},
        "functions_with_faults": sorted(k for k, c in TALLY.items() if any(c[f] for f in faults)),
        "per_function": {k: dict(c) for k, c in sorted(TALLY.items())},
        "first_faults": dict(FIRST),
    }
    with open(TALLY_FILE, "w") as fh:
        json.dump(report, fh, indent=1)


atexit.register(_write_tally)

# --- strategies ------------------------------------------------------------------------------
# Each kind of argument comes as an `Arg`: `good` values (within the documented range, in the
# forms users pass: float, int, numpy scalar; list, tuple or array) and `bad` ones (NaN, inf,
# out of range, text, booleans, huge ints, wrong shapes, junk). `one_bad` draws a call's
# arguments all good but at most one, so a refusal has one argument to name.
BAD_SCALARS = st.sampled_from(
    [math.nan, math.inf, -math.inf, "0.1", "", True, False, None, 10**400, -(10**400), 1e300,
     -1e300, 1j, [0.1], (), np.array([0.5]), np.nan, b"1", object()]
)  # fmt: skip
JUNK = st.one_of(
    BAD_SCALARS, st.text(max_size=4), st.dictionaries(st.text(max_size=2), st.integers(), max_size=2),
    st.lists(st.text(max_size=2), max_size=3),
)  # fmt: skip


class Arg(NamedTuple):
    """Good and bad values of one argument."""

    good: st.SearchStrategy[Any]
    bad: st.SearchStrategy[Any]

    def any(self) -> st.SearchStrategy[Any]:
        """Good or bad, half and half (a plain one_of would weigh the many bad forms more)."""
        return st.booleans().flatmap(lambda good: self.good if good else self.bad)


def number(low: float, high: float) -> Arg:
    """Numbers in [low, high] (float, int, numpy float); outside it, non-finite and wrong."""
    inside = st.floats(low, high, allow_nan=False)
    good = [inside, inside.map(np.float64)]
    if math.ceil(low) <= math.floor(high):
        good.append(st.integers(math.ceil(low), math.floor(high)))
    span = abs(low) + abs(high)
    bad = st.one_of(
        st.floats(allow_nan=True, allow_infinity=True).filter(lambda x: not low <= x <= high),
        st.floats(low - 10 * span - 1, low, exclude_max=True),
        st.floats(high, high + 10 * span + 1, exclude_min=True), BAD_SCALARS,
    )  # fmt: skip
    return Arg(st.one_of(*good), bad)


def numbers(low: float, high: float) -> st.SearchStrategy[Any]:
    """number(low, high), good or bad."""
    return number(low, high).any()


def _corrupt(values: list[float], i: int, bad: Any) -> list[Any]:
    out: list[Any] = list(values)
    out[i % len(out)] = bad
    return out


def vector(n: int, low: float, high: float) -> Arg:
    """Length-n vectors in [low, high] as list, tuple or array; one bad entry, wrong lengths, a
    row instead of a vector, text, float32, nested, junk."""
    raw = st.lists(st.floats(low, high, allow_nan=False), min_size=n, max_size=n)
    bad = st.one_of(
        st.builds(_corrupt, raw, st.integers(0, n), BAD_SCALARS),
        st.builds(_corrupt, raw, st.integers(0, n), st.sampled_from([math.nan, math.inf])),
        st.lists(st.floats(low, high), min_size=0, max_size=n + 3).filter(lambda v: len(v) != n),
        raw.map(lambda v: np.array(v)[None, :]), raw.map(lambda v: [str(x) for x in v]),
        raw.map(lambda v: [v]), JUNK,
    )  # fmt: skip
    good = st.one_of(raw, raw.map(np.array), raw.map(tuple))
    return Arg(good, bad)


def vectors(n: int, low: float, high: float) -> st.SearchStrategy[Any]:
    """vector(n, low, high), good or bad."""
    return vector(n, low, high).any()


def matrix(good: Any) -> Arg:
    """The matrix `good` (array or list of lists); one bad entry, a slice, scaled, junk."""
    g = np.asarray(good, dtype=float)
    bad = st.one_of(
        st.just(g[:-1]), st.just(g.ravel()),
        st.builds(lambda i, b: _set(g, i, b), st.integers(0, g.size - 1),
                  st.sampled_from([math.nan, math.inf, 2.0, -1.0, 1e300])),
        st.floats(0.1, 0.9).map(lambda s: g * s), JUNK,
    )  # fmt: skip
    return Arg(st.sampled_from([g, g.tolist()]), bad)


def matrices(shape: tuple[int, int], good: Any) -> st.SearchStrategy[Any]:
    """matrix(good), good or bad."""
    return matrix(good).any()


def _set(g: np.ndarray, i: int, value: float) -> np.ndarray:
    out = g.copy().ravel()
    out[i] = value
    return out.reshape(g.shape)


def choice(good: list[Any], bad: list[Any] | None = None) -> Arg:
    """One of `good`; one of `bad` or junk."""
    bad_values = st.one_of(st.sampled_from(bad), JUNK) if bad else JUNK
    return Arg(st.sampled_from(good), bad_values)


def maybe(strategy: st.SearchStrategy[Any]) -> st.SearchStrategy[Any]:
    """None (the default) or the strategy's values."""
    return st.one_of(st.none(), strategy)


def optional(arg: Arg) -> Arg:
    """None (the default) or a good value; bad values as they are."""
    return Arg(maybe(arg.good), arg.bad)


@st.composite
def one_bad(draw: st.DrawFn, *args: Arg) -> tuple[Any, ...]:
    """Values for args: all good (half of the draws), or all good but one bad one."""
    values = [draw(a.good) for a in args]
    i = draw(st.integers(-len(args), len(args) - 1))
    if i >= 0:
        values[i] = draw(args[i].bad)
    return tuple(values)


def names_or_junk() -> st.SearchStrategy[Any]:
    """Names: short text, empty, unhashable, numbers."""
    return st.one_of(st.text(max_size=8), st.sampled_from(["", "ur5", "iramis", "x.toml"]), JUNK)
