"""The compiled loop around the dynamic MuJoCo plant (`compiled/mujoco_loop.py`) with the QP gives
the Python loop's log and plant state; a solver it does not reproduce runs the Python loop."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numba  # noqa: F401  (the `fast` extra: without it these tests fail, they do not skip)
import numpy as np
import pytest

from heavy import heavy
from rcmplan import Iramis
from rcmplan.control import Phase, extended_task, interpolate
from rcmplan.control.log import RunLog
from rcmplan.control.objective import Objective
from rcmplan.control.phase import LoopSettings
from rcmplan.control.qp import QpSolver
from rcmplan.control.tasks import Posture
from rcmplan.controller import Controller
from rcmplan.job import run_scenario
from rcmplan.scene.scenario import load_scenario
from rcmplan.sim.kinematic import KinematicPlant
from rcmplan.sim.mujoco.files import mujoco_module
from rcmplan.sim.mujoco.plant import MujocoPlant

from logcheck import assert_same_log
from paths import use_path

mujoco = mujoco_module()  # without the `sim` extra these tests fail, they do not skip
TOL_M = 1e-9  # records within 1 nm (and 1 nrad): the same operations, rounding apart
SHORT = """name = "short-mujoco-qp"
description = "the default injection visiting p4 only, on the dynamic MuJoCo plant"
procedure = "injection"
plant = "mujoco"

[points]
visits = ["p4"]

[controller]
method = "qp"
max_iterations = 200
rcm_bound_um = 2.0
"""


@pytest.fixture(autouse=True)
def compiled_default() -> Iterator[None]:
    yield
    use_path(None)


def phases(robot: Iramis) -> list[Phase]:
    """A pivot about the needle's end (RCM targets), then a short free move of the tip."""
    x0 = extended_task(robot, robot.home, 1.0)
    pivot = Phase("pivot", interpolate(x0, x0 + [0, 0.002, 0.02, 0, 0, 0], 12))

    def free(q: np.ndarray) -> np.ndarray:
        tip = robot.tip(q)
        return interpolate(tip, tip + [2e-4, -1e-4, 1e-4], 4)

    return [pivot, Phase("free", free, kind="free")]


def run(
    path: str, objectives: tuple[Objective, ...] = ()
) -> tuple[RunLog, MujocoPlant, Controller]:
    """The phases on a fresh dynamic plant with a QP whose servo is the plant, on `path`."""
    use_path(path)
    robot = Iramis()
    plant = MujocoPlant(robot, mode="dynamic")
    solver = QpSolver(robot, servo=plant, objectives=objectives)
    ctl = Controller(plant, solver, settings=LoopSettings(max_iterations=1000))
    return ctl.run(phases(robot)), plant, ctl


def test_the_compiled_qp_on_the_mujoco_plant_gives_the_python_loops_log() -> None:
    ref, ref_plant, ref_ctl = run("off")
    got, plant, ctl = run("on")
    assert ref_ctl.phase_paths == {"pivot": "reference", "free": "reference"}
    assert ctl.phase_paths == {"pivot": "compiled", "free": "compiled"}
    assert_same_log(ref, got, TOL_M, nonempty=True)
    np.testing.assert_allclose(plant.data.qpos, ref_plant.data.qpos, rtol=0, atol=TOL_M)
    np.testing.assert_allclose(plant.command, ref_plant.command, rtol=0, atol=TOL_M)
    assert plant.time == pytest.approx(ref_plant.time, abs=1e-12)
    assert ctl.lam == pytest.approx(ref_ctl.lam, abs=TOL_M)


def test_a_controller_hands_its_plant_to_a_qp_given_none() -> None:
    """QpSolver(robot) on the dynamic plant, as a user writes it: the controller makes the
    plant its servo (`QpSolver.follow`), so the run is the one with servo=plant, compiled
    (841 records; planned from the measured sliders instead, the pivot ran the Python loop
    and the phases took 1,281). On the kinematic plant (exact commands) the QP plans from the
    state."""
    robot = Iramis()
    plant = MujocoPlant(robot, mode="dynamic")
    solver = QpSolver(robot)
    ctl = Controller(plant, solver, settings=LoopSettings(max_iterations=1000))
    assert solver.servo is plant
    got = ctl.run(phases(robot))
    ref, _, _ = run("on")
    assert ctl.phase_paths == {"pivot": "compiled", "free": "compiled"}
    assert_same_log(ref, got, 0.0, nonempty=True)
    Controller(KinematicPlant(robot), solver)
    assert solver.servo is None


def test_a_qp_with_a_cost_term_the_kernels_do_not_assemble_runs_the_python_loop() -> None:
    robot = Iramis()
    posture = Objective(Posture(), robot.home[list(robot.active)], 0.2, 1e-3)
    _, _, ctl = run("on", (posture,))
    assert ctl.phase_paths["pivot"] == "reference"


@heavy
def test_a_short_qp_injection_on_mujoco_runs_compiled_with_the_python_loops_log(
    tmp_path: Path,
) -> None:
    path = tmp_path / "short-qp.toml"
    path.write_text(SHORT)
    results = {}
    for mode in ("off", "on"):
        use_path(mode)
        results[mode] = run_scenario(load_scenario(path))
    ref, got = results["off"], results["on"]
    assert got.finished and got.status == ref.status, got.summary()["message"]
    assert ref.summary()["execution_path"] == "reference"
    assert got.summary()["execution_path"] == "compiled"
    assert_same_log(ref.log, got.log, TOL_M, nonempty=True)
