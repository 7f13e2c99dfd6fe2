"""The compiled loop around the dynamic MuJoCo plant equals the per-iteration path bit for bit:
records, plant state, stops and partial logs."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import numba  # the `fast` extra, likewise (these tests fail without it, they do not skip)
import numpy as np
import pytest

from rcmplan import Iramis
from rcmplan.compiled import mujoco_loop as fm
from rcmplan.compiled import phase
from rcmplan.control import (
    DlsSolver,
    Phase,
    PinvSolver,
    extended_task,
    interpolate,
)
from rcmplan.control.log import ARRAY_FIELDS, RunLog
from rcmplan.controller import Controller
from rcmplan.exceptions import SimulationError
from rcmplan.sim.mujoco import compiled
from rcmplan.sim.mujoco.actuators import PiezoParameters
from rcmplan.sim.mujoco.files import mujoco_module
from rcmplan.sim.mujoco.plant import MujocoPlant

from paths import use_path

# MuJoCo through rcmplan (which picks headless EGL first); without the `sim` extra these tests
# fail, they do not skip.
mujoco = mujoco_module()


@pytest.fixture(autouse=True)
def fast_on() -> Iterator[None]:
    use_path("on")
    yield
    use_path(None)


def phases(robot: Iramis, n: int = 12) -> list[Phase]:
    """A pivot (RCM) phase from home, then a short free move of the tip."""
    x0 = extended_task(robot, robot.home, 1.0)
    pivot = Phase("pivot", interpolate(x0, x0 + [0, 0.002, 0.02, 0, 0, 0], n))

    def free(q: np.ndarray) -> np.ndarray:
        tip = robot.tip(q)
        return interpolate(tip, tip + [2e-4, -1e-4, 1e-4], 4)

    return [pivot, Phase("free", free, kind="free")]


def run(
    per_iteration: bool, monkeypatch: pytest.MonkeyPatch, solver: Any, **plant: Any
) -> tuple[RunLog | None, MujocoPlant, Controller, Exception | None]:
    """Run `phases` on a fresh dynamic plant on one path; returns (log, plant, controller,
    the exception raised or None)."""
    robot = Iramis()
    p = MujocoPlant(robot, mode="dynamic", **plant)
    ctl = Controller(p, solver)
    with monkeypatch.context() as m:
        if per_iteration:
            m.setattr(p, "compiled_physics", False)
        else:
            m.setattr(fm, "run_phase_on_mujoco", counted(fm.run_phase_on_mujoco))
        try:
            return ctl.run(phases(robot)), p, ctl, None
        except SimulationError as exc:
            return exc.log, p, ctl, exc


calls: list[int] = []


def counted(fn: Callable[..., bool]) -> Callable[..., bool]:
    def wrapper(*args: Any, **kwargs: Any) -> bool:
        done = fn(*args, **kwargs)
        calls.append(int(done))
        return done

    return wrapper


def assert_identical(a: RunLog | None, b: RunLog | None) -> None:
    assert a is not None and b is not None
    assert len(a) == len(b) > 0
    for k in ARRAY_FIELDS:
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k), err_msg=k)
    assert a.phase_names == b.phase_names and a.solver_names == b.solver_names


def assert_same_plant(a: MujocoPlant, b: MujocoPlant) -> None:
    np.testing.assert_array_equal(a.data.qpos, b.data.qpos)
    np.testing.assert_array_equal(a.data.qvel, b.data.qvel)
    np.testing.assert_array_equal(a.data.act, b.data.act)
    np.testing.assert_array_equal(a._cmd, b._cmd)
    assert a.time == b.time


@pytest.mark.parametrize(
    "solver, ramp",
    [(PinvSolver(), 0.03), (DlsSolver(), 0.03), (PinvSolver(), 0.0)],
    ids=["pinv", "dls", "pinv-velocity-steps"],
)
def test_compiled_loop_equals_the_per_iteration_path(
    solver: Any, ramp: float, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls.clear()
    piezo = PiezoParameters.from_robot(Iramis(), ramp_time=ramp)
    ref, ref_plant, ref_ctl, err = run(True, monkeypatch, solver, piezo=piezo)
    assert err is None
    got, plant, ctl, err = run(False, monkeypatch, solver, piezo=piezo)
    assert err is None
    assert calls == [1, 1]  # both phases (RCM and free) ran compiled
    assert_identical(ref, got)
    assert_same_plant(ref_plant, plant)
    assert ctl.lam == ref_ctl.lam
    assert ref is not None and ref.time[-1] > 0.5  # a real dynamic run: hundreds of periods


def test_full_record_blocks_resume_where_they_paused(monkeypatch: pytest.MonkeyPatch) -> None:
    ref, ref_plant, _, _ = run(True, monkeypatch, PinvSolver())
    monkeypatch.setattr(phase, "CAPACITY", 7)  # pause every 7 records, mid-target
    got, plant, _, _ = run(False, monkeypatch, PinvSolver())
    assert_identical(ref, got)
    assert_same_plant(ref_plant, plant)


def test_a_plant_failure_stops_both_paths_alike_with_the_partial_log(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # the pivot's loop gap: about 4 nm over its first target, 4.6 nm when the second starts
    ref, _, _, ref_err = run(True, monkeypatch, PinvSolver(), gap_limit=4.3e-9)
    got, _, _, err = run(False, monkeypatch, PinvSolver(), gap_limit=4.3e-9)
    assert ref_err is not None and err is not None
    assert "loop-closure gap" in str(err) and str(err) == str(ref_err)
    assert_identical(ref, got)


def test_a_diverged_state_raises_simulation_error(monkeypatch: pytest.MonkeyPatch) -> None:
    robot = Iramis()
    plant = MujocoPlant(robot)
    plant.data.qvel[0] = np.nan
    ctl = Controller(plant, PinvSolver())
    with pytest.raises(SimulationError, match=r"diverged \(NaN or inf\) at t = 0.001 s"):
        ctl.run(phases(robot)[:1])
    assert plant.time == pytest.approx(1e-3)  # the compiled loop stopped after one period


def test_without_the_c_library_the_dynamic_plant_says_what_it_needs(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The dynamic plant's period is the compiled one (`compiled.advance`), which calls
    MuJoCo's C functions: without them (a MuJoCo whose library is not beside its package)
    the plant refuses its first period, saying so, and the run stops with it."""
    monkeypatch.setattr(compiled, "function_addresses", lambda mj: None)
    robot = Iramis()
    plant = MujocoPlant(robot, mode="dynamic")
    with pytest.raises(SimulationError, match="needs MuJoCo's C functions"):
        plant.advance()
    assert plant.time == 0.0  # no period ran
    with pytest.raises(SimulationError, match="needs MuJoCo's C functions"):
        Controller(MujocoPlant(robot, mode="dynamic"), PinvSolver()).run(phases(robot)[:1])


def test_library_path_finds_the_loaded_mujoco_library() -> None:
    path = compiled.library_path(mujoco)
    assert path is not None and path.exists()
    addresses = compiled.function_addresses(mujoco)
    assert addresses is not None and all(a > 0 for a in addresses)


def test_one_compiled_loop_serves_every_plant() -> None:
    """The kinematic plant's loop argument (`exact_plant`) and a plant stepping in Python's
    (`stepping_plant`) have the numba types of a dynamic MuJoCo plant's
    (`PlantArrays.loop_args`), so the one loop compiles once for every plant; a changed array
    type in either would compile a second loop (and fail here)."""
    arrays = compiled.plant_arrays(MujocoPlant(Iramis(), mode="dynamic"))
    assert arrays is not None
    dynamic = numba.typeof(arrays.loop_args())
    assert numba.typeof(compiled.exact_plant()) == dynamic
    assert numba.typeof(compiled.stepping_plant()) == dynamic
    assert compiled.stepping_plant()[2] == -1 and compiled.exact_plant()[2] == 0
