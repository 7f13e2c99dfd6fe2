"""Generated inputs to the public API (10,000 per run over the tests below, seeded): every call
either raises a typed rcmplan error or returns a finite result within its bounds; never a
generic Python error, never a silent NaN."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from rcmplan.control.phase import MAX_TARGETS, LoopSettings, interpolate, split_steps
from rcmplan.control.qp_limits import QpLimits
from rcmplan.control.solvers import DlsSolver, PinvSolver, Tolerance
from rcmplan.control.targets import pivot_target, rcm_target
from rcmplan.exceptions import RcmplanError
from rcmplan.robot.iramis import Iramis
from rcmplan.scene.procedures import Steps

ROBOT = Iramis()
# 1,250 examples x 8 generated tests = 10,000 inputs per run (issue floor: 10,000).
SETTINGS = settings(max_examples=1250, derandomize=True, database=None, deadline=None)

numbers = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(-2.0, 2.0),
    st.integers(-(10**400), 10**400),
    st.sampled_from([0, 1, -1, 1e-300, 1e300, -0.0]),
)
anything = st.one_of(
    numbers, st.text(max_size=3), st.none(), st.booleans(), st.lists(numbers, max_size=3)
)
vectors = st.one_of(
    st.lists(numbers, min_size=0, max_size=8),
    st.lists(st.floats(-1.5, 1.5), min_size=6, max_size=6),
    st.lists(st.floats(-3e-3, 3e-3), min_size=3, max_size=3),
    anything,
)


def outcome(fn: Any, *args: Any) -> Any:
    """fn(*args), or None if it raised a typed rcmplan error (any other error fails the test)."""
    try:
        return fn(*args)
    except RcmplanError:
        return None


def finite(x: Any) -> bool:
    """True when x is a finite number or array of them."""
    return bool(np.all(np.isfinite(np.asarray(x, dtype=float))))


@SETTINGS
@given(q=vectors, lam=numbers)
def test_needle_queries_are_finite_or_refused(q: Any, lam: Any) -> None:
    for fn, args in ((ROBOT.needle_point, (q, lam)), (ROBOT.needle_axis, (q,)),
                     (ROBOT.needle_base, (q,)), (ROBOT.singularity_measure, (q,))):  # fmt: skip
        out = outcome(fn, *args)
        assert out is None or finite(out)
    axis = outcome(ROBOT.needle_axis, q)
    assert axis is None or abs(float(np.linalg.norm(axis)) - 1.0) < 1e-12


@SETTINGS
@given(q=vectors, s=vectors, threshold=st.one_of(st.none(), numbers))
def test_limits_and_singularity_checks_are_finite_or_refused(
    q: Any, s: Any, threshold: Any
) -> None:
    margin = outcome(ROBOT.actuator_margin, s)
    assert margin is None or (finite(margin) and np.shape(margin) == (6,))
    outcome(ROBOT.check_singularity, q, threshold)
    m = outcome(ROBOT.singularity_measure, q)
    assert m is None or 0.0 <= m <= 1.0


@SETTINGS
@given(tip=vectors, trocar=vectors, x=numbers, phi=numbers, psi=numbers)
def test_targets_are_finite_or_refused(tip: Any, trocar: Any, x: Any, phi: Any, psi: Any) -> None:
    for out in (outcome(rcm_target, tip, trocar), outcome(pivot_target, x, phi, psi, trocar)):
        assert out is None or (finite(out) and np.shape(out) == (6,))


@SETTINGS
@given(position=numbers, angle=numbers, distance=numbers, turn=numbers)
def test_step_sizes_and_counts_are_bounded_or_refused(
    position: Any, angle: Any, distance: Any, turn: Any
) -> None:
    steps = outcome(Steps, position, angle)
    if steps is None:
        return
    assert 0 < steps.position <= 5e-3 and 0 < steps.angle <= 0.1
    n = outcome(steps.count, distance, turn)
    assert n is None or 1 <= n <= MAX_TARGETS


@SETTINGS
@given(start=vectors, goal=vectors, n=st.one_of(st.integers(-3, 10), numbers, anything),
       step=numbers, angle=st.one_of(st.none(), numbers))  # fmt: skip
def test_interpolation_and_splits_are_bounded_or_refused(
    start: Any, goal: Any, n: Any, step: Any, angle: Any
) -> None:
    rows = outcome(interpolate, start, goal, n)
    assert rows is None or (finite(rows) and 1 <= len(rows) <= MAX_TARGETS)
    rows = outcome(split_steps, start, goal, step, angle)
    assert rows is None or (finite(rows) and 1 <= len(rows) <= MAX_TARGETS)


def test_a_split_that_would_allocate_gigabytes_is_refused_before_allocating() -> None:
    assert outcome(split_steps, np.zeros(6), np.full(6, 0.1), 1e-5, 1e-9) is None
    assert outcome(Steps(1e-5, 1e-9).count, 0.01, 0.5) is None


@SETTINGS
@given(
    max_iterations=st.one_of(st.integers(-5, 10**7), anything),
    drift=anything,
    threshold=st.one_of(st.none(), numbers),
    bound=st.one_of(st.none(), numbers),
)
def test_loop_settings_are_bounded_or_refused(
    max_iterations: Any, drift: Any, threshold: Any, bound: Any
) -> None:
    cfg = outcome(LoopSettings, max_iterations, drift, threshold, bound)
    if cfg is not None:
        assert 1 <= cfg.max_iterations <= 100_000 and isinstance(cfg.drift_correction, bool)
        assert cfg.rcm_bound is None or 0 < cfg.rcm_bound <= 0.01


QP_FIELDS = ("rcm_tolerance", "travel_margin", "retina_margin", "eye_gain", "port_zone",
             "contact_tolerance", "singular_margin", "singular_gain", "angle_weight",
             "rcm_weight")  # fmt: skip


@SETTINGS
@given(name=st.sampled_from(QP_FIELDS), value=numbers)
def test_qp_settings_are_finite_and_bounded_or_refused(name: str, value: Any) -> None:
    lim = outcome(lambda: QpLimits(**{name: value}))
    if lim is not None:
        v = getattr(lim, name)
        assert math.isfinite(v) and 0 <= v <= 1e6


@SETTINGS
@given(K=vectors, damping=numbers, pos=numbers, ang=numbers)
def test_solver_constructors_accept_only_finite_bounded_settings(
    K: Any, damping: Any, pos: Any, ang: Any
) -> None:
    tol = outcome(lambda: Tolerance(pos, ang).checked())
    assert tol is None or (0 < tol.position < math.inf and 0 < tol.angle < math.inf)
    pinv = outcome(lambda: PinvSolver(K=K))
    if pinv is not None:
        k = np.asarray(pinv.K, dtype=float)
        assert finite(k) and np.all((k > 0) & (k < 2))
    dls = outcome(lambda: DlsSolver(damping=damping))
    assert dls is None or 0 < dls.damping < math.inf
