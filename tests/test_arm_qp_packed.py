"""The arm QP step called from Python with its arrays packed in two buffers (`compiled/packed.py`,
`arm_qp_kernels.solve_packed`): the packing round-trips every array as a view of the buffers,
the packed step gives bit for bit what the kernel gives on separately allocated arrays, and
`ArmQpStep.error` and `step` refuse bad input with a typed error naming it."""

from __future__ import annotations

import numpy as np
import pytest

from rcmplan.compiled import packed
from rcmplan.compiled.arm_qp import ArmQpStep, step_buffers
from rcmplan.compiled.qp_period import period_step
from rcmplan.control.qp import QpSolver
from rcmplan.exceptions import InvalidInputError
from rcmplan.robot.model import SerialArm
from test_arm_qp_compiled import ServoPlant, solvers, states
from test_arm_qp_compiled import arm as arm  # the fixtures, shared
from test_arm_qp_compiled import fast_on as fast_on


def test_pack_gives_every_array_back_as_a_view_of_its_buffer() -> None:
    rng = np.random.default_rng(3)
    arrays = [rng.normal(size=(5, 3)), np.arange(7, dtype=np.int64), rng.normal(size=4),
              np.array([3, -1, 2], dtype=np.int32), np.zeros((0, 3)), rng.normal(size=(2, 7)),
              np.zeros(0), np.array([-5, 6], dtype=np.int32)]  # fmt: skip
    F, Z, python_views = packed.pack(arrays)
    views = [packed.mat(F, Z, 0), packed.ints(Z, 1), packed.vec(F, Z, 2), packed.int32s(Z, 3),
             packed.mat(F, Z, 4), packed.mat(F, Z, 5), packed.vec(F, Z, 6),
             packed.int32s(Z, 7)]  # fmt: skip
    for a, v, p in zip(arrays, views, python_views, strict=True):
        assert v.dtype == a.dtype and v.shape == a.shape and v.flags.c_contiguous
        np.testing.assert_array_equal(v, a)
        assert p.dtype == v.dtype and p.shape == v.shape and p.flags.c_contiguous
        if v.size:  # pack's own views are the memory compiled code reads
            assert p.ctypes.data == v.ctypes.data
            assert v.ctypes.data % 64 == 0  # each array from a 64-byte boundary
    for v in views:  # distinct memory: writing one array leaves every other as it was
        v[...] = 9
    for a, v in zip(arrays[1:], views[1:], strict=True):
        np.testing.assert_array_equal(v, np.full(a.shape, 9))
    views[0][1, 2] = -4.0  # a view writes into the buffer itself
    np.testing.assert_array_equal(packed.mat(F, Z, 0)[1], [9.0, 9.0, -4.0])


@pytest.mark.parametrize("bad", [np.zeros((2, 2, 2)), np.zeros(3, dtype=bool),
                                 np.zeros((2, 2), dtype=np.int64)])  # fmt: skip
def test_pack_refuses_arrays_it_cannot_give_back(bad: np.ndarray) -> None:
    with pytest.raises(InvalidInputError, match=r"^arrays ="):
        packed.pack([np.zeros(3), bad])


def separate_solve(fast: ArmQpStep, solver: QpSolver, q: np.ndarray, lam: float,
                   target: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:  # fmt: skip
    """The step's kernel called on freshly allocated arrays (not packed), as before the
    packing: (flag, e, d)."""
    A, ix, W, travel, Q, contacts, K, s, e, d, servo, *qp = step_buffers(solver, fast.K.copy())
    if servo.shape[0]:
        servo[: fast.n] = np.asarray(solver.servo.command)  # type: ignore[union-attr]
    flag = fast._k.solve_arm_step(A, ix, W, None, travel, Q, contacts, K, q, lam, target, s, e,
                                  d, tuple(qp), servo)  # fmt: skip
    return flag, e, d


def test_the_packed_step_equals_the_kernel_on_separate_arrays_bit_for_bit(arm: SerialArm) -> None:
    rng = np.random.default_rng(29)
    plant = ServoPlant(arm)
    outcomes = {"solved": 0, "not": 0}
    for solver in [*solvers(arm), QpSolver(arm, None, servo=plant)]:
        fast = ArmQpStep(solver)
        for q, lam, target in states(arm, rng, 12, spread=1e-6):
            plant.lead = q + rng.normal(0.0, 2e-4, q.shape)
            flag = fast.solve(q, lam, target)
            ref_flag, e, d = separate_solve(fast, solver, q, lam, target)
            assert flag == ref_flag
            if flag == 1:
                assert fast.e.tobytes() == e.tobytes() and fast.d.tobytes() == d.tobytes()
            outcomes["solved" if flag == 1 else "not"] += 1
    assert outcomes["solved"] > 60, outcomes


BAD_INPUTS = {
    "lam": lambda q, lam, t: (q, float("nan"), t),
    "lam ": lambda q, lam, t: (q, "0.5", t),
    "target": lambda q, lam, t: (q, lam, np.where(np.arange(6) == 2, np.nan, t)),
    "target ": lambda q, lam, t: (q, lam, t[:5]),
    "q": lambda q, lam, t: (np.where(np.arange(q.size) == 1, np.inf, q), lam, t),
    "q ": lambda q, lam, t: (q[:3], lam, t),
}


@pytest.mark.parametrize("case", sorted(BAD_INPUTS))
def test_error_step_and_the_period_step_name_a_bad_argument(arm: SerialArm, case: str) -> None:
    solver = QpSolver(arm, None)
    fast, period = ArmQpStep(solver), period_step(solver)
    assert period is not None
    q, lam, target = next(states(arm, np.random.default_rng(2), 1, spread=1e-6))
    bad = BAD_INPUTS[case](q, lam, target)
    name = case.strip()
    with pytest.raises(InvalidInputError, match=f"^{name} ="):
        fast.error(arm, *bad)
    with pytest.raises(InvalidInputError, match=f"^{name} ="):
        fast.step(arm, *bad, np.zeros(6))
    with pytest.raises(InvalidInputError, match=f"^{name} ="):
        period(*bad)


def test_a_step_after_error_checks_joints_changed_in_place(arm: SerialArm) -> None:
    """`step` skips the finiteness check only for the state `error` checked: joints written
    in place since are checked again."""
    fast = ArmQpStep(QpSolver(arm, None))
    q, lam, target = next(states(arm, np.random.default_rng(4), 1, spread=1e-6))
    q = q.copy()
    e = fast.error(arm, q, lam, target)
    d, dlam = fast.step(arm, q, lam, target, e)
    assert np.all(np.isfinite(d)) and np.isfinite(dlam)
    q[0] = np.nan
    with pytest.raises(InvalidInputError, match=r"^q ="):
        fast.step(arm, q, lam, target, e)
