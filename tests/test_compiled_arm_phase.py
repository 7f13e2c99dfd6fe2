"""The compiled arm loop behind the runner seam gives the reference loop's log and exceptions."""

from __future__ import annotations

from collections.abc import Iterator

import numba  # noqa: F401  (the `fast` extra: without it these tests fail, they do not skip)
import numpy as np
import pytest

from rcmplan.compiled import arm_phase
from rcmplan.compiled import cache as fast_cache
from rcmplan.control import Controller, DlsSolver, LoopSettings, Phase, PinvSolver, TipSolver
from rcmplan.control.log import ARRAY_FIELDS, RunLog
from rcmplan.control.solvers import Solver
from rcmplan.control.targets import rcm_target, solve_pose
from rcmplan.exceptions import ConvergenceError
from rcmplan.robot.arms import shipped_arm
from rcmplan.robot.model import SerialArm
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.scene.procedures import injection
from rcmplan.sim import KinematicPlant

TOL = 1e-12


@pytest.fixture(autouse=True)
def mode_restored() -> Iterator[None]:
    yield
    fast_cache.set_mode(None)


@pytest.fixture(scope="module")
def ur5() -> SerialArm:
    return shipped_arm("ur5")


def assert_same_log(a: RunLog, b: RunLog) -> None:
    assert len(a) == len(b) > 0
    for k in ARRAY_FIELDS:
        x, y = getattr(a, k), getattr(b, k)
        if x.dtype.kind == "f":
            np.testing.assert_array_equal(np.isnan(x), np.isnan(y), err_msg=k)
            np.testing.assert_allclose(x, y, rtol=0, atol=TOL, err_msg=k)
        else:
            np.testing.assert_array_equal(x, y, err_msg=k)
    assert a.phase_names == b.phase_names and a.solver_names == b.solver_names


def injection_phase(robot: SerialArm, name: str) -> tuple[Phase, np.ndarray]:
    """A phase of the default injection and the joints it starts from (at p3, or at home)."""
    eye = default_eye(robot)
    points = default_points(eye)
    phase = next(ph for ph in injection(robot, eye, points) if ph.name == name)
    if phase.kind == "free":
        return phase, robot.home
    return phase, solve_pose(robot, rcm_target(points.p3, eye.port)).q


def run(mode: str, robot: SerialArm, solver: Solver, phase: Phase, q0: np.ndarray,
        settings: LoopSettings | None = None) -> tuple[Controller, RunLog]:  # fmt: skip
    fast_cache.set_mode(mode)
    plant = KinematicPlant(robot)
    plant.reset(robot.actuators_from_joints(q0))
    ctl = Controller(plant, solver, settings=settings)
    return ctl, ctl.run([phase])


@pytest.mark.parametrize(
    "solver", [PinvSolver(), PinvSolver(variant="thesis"), DlsSolver()], ids=lambda s: s.name
)
def test_the_ur5_p3_p4_phase_gives_the_reference_log(ur5: SerialArm, solver: Solver) -> None:
    phase, q0 = injection_phase(ur5, "p3-p4")
    ref_ctl, ref = run("off", ur5, solver, phase, q0)
    ctl, log = run("on", ur5, solver, phase, q0)
    assert_same_log(log, ref)
    assert ctl.lam == pytest.approx(ref_ctl.lam, abs=TOL)
    np.testing.assert_allclose(ctl.plant.read_actuators(), ref_ctl.plant.read_actuators(), 0, TOL)
    assert ctl.plant.time == ref_ctl.plant.time


def test_the_redundant_panda_p3_p4_phase_gives_the_reference_log() -> None:
    panda = shipped_arm("panda")
    phase, q0 = injection_phase(panda, "p3-p4")
    assert_same_log(run("on", panda, PinvSolver(), phase, q0)[1],
                    run("off", panda, PinvSolver(), phase, q0)[1])  # fmt: skip


def test_a_free_space_approach_gives_the_reference_log(ur5: SerialArm) -> None:
    phase, q0 = injection_phase(ur5, "approach")
    assert_same_log(run("on", ur5, PinvSolver(), phase, q0)[1],
                    run("off", ur5, PinvSolver(), phase, q0)[1])  # fmt: skip


def test_the_compiled_path_runs_the_arm_phase(ur5: SerialArm, monkeypatch) -> None:
    calls = []
    monkeypatch.setattr(arm_phase, "run_arm_phase", lambda *a: calls.append(a))
    phase, q0 = injection_phase(ur5, "p3-p4")
    run("on", ur5, PinvSolver(), phase, q0)
    assert len(calls) == 1


def test_a_stop_raises_the_reference_error_and_keeps_the_partial_log(ur5: SerialArm) -> None:
    phase, q0 = injection_phase(ur5, "p3-p4")
    settings = LoopSettings(max_iterations=1)
    errors = []
    for mode in ("off", "on"):
        with pytest.raises(ConvergenceError) as info:
            run(mode, ur5, PinvSolver(K=(0.2,) * 6), phase, q0, settings)
        errors.append(info.value)
    assert str(errors[1]) == str(errors[0])
    assert_same_log(errors[1].log, errors[0].log)


def test_a_subclass_of_serial_arm_runs_on_the_reference_path(ur5: SerialArm) -> None:
    class Other(SerialArm):
        pass

    other = Other(ur5.chain, ur5.needle, ur5.home, "other", roll_joint=5)
    ctl = Controller(KinematicPlant(other), TipSolver())
    assert not arm_phase.applies(ctl, TipSolver())
