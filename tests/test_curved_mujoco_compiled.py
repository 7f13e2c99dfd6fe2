"""A curved needle on the dynamic MuJoCo plant runs in the compiled loop around the plant's period
(`compiled/mujoco_loop.py`) with the Python loop's log and plant state: X_c phases (pinv, DLS,
the QP planned from the plant's command) and whole-pose phases (the QP's limited ones), the
records with their roll error."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import numba  # noqa: F401  (the `fast` extra: without it these tests fail, they do not skip)
import numpy as np
import pytest

from rcmplan.control import Phase, interpolate
from rcmplan.control.curved import (
    CURVED_POSE_TASKS,
    CURVED_TASKS,
    CurvedDlsSolver,
    CurvedPinvSolver,
    CurvedPoseSolver,
)
from rcmplan.control.curved_targets import solve_curved_pose
from rcmplan.control.log import RunLog
from rcmplan.control.phase import LoopSettings
from rcmplan.control.qp import QpSolver
from rcmplan.control.solvers import Solver, Tolerance
from rcmplan.control.tasks import stack_value
from rcmplan.controller import Controller
from rcmplan.robot.curved import CurvedTipRobot, curved_robot
from rcmplan.robot.curved_needle import CurvedNeedle
from rcmplan.robot.registry import make_robot
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.sim.mujoco.arm_plant import ArmPlant
from rcmplan.sim.mujoco.files import mujoco_module
from rcmplan.sim.mujoco.plant import MujocoPlant

from logcheck import assert_same_log
from paths import use_path

mujoco = mujoco_module()  # without the `sim` extra these tests fail, they do not skip
TOL_M = 1e-9  # records within 1 nm (and 1 nrad): the same operations, rounding apart
# the roll's position servo settles to about 2.4e-7 rad (the `curved-mujoco` scenario's)
TOLERANCE = Tolerance(position=1e-7, angle=1e-5)


@pytest.fixture(autouse=True)
def compiled_default() -> Iterator[None]:
    yield
    use_path(None)


def run(path: str, solver: Solver | Callable[[MujocoPlant | ArmPlant, CurvedTipRobot], QpSolver],
        base_name: str = "iramis") -> tuple[RunLog, MujocoPlant | ArmPlant, Controller]:  # fmt: skip
    """From a pose with the tip at p3 and the shaft through the trocar: the tip 0.2 mm aside
    with the roll turned 2 mrad (X_c targets), then the whole needle 0.1 mm along x (poses).
    `solver`: a solver, or the QP made for the plant (its servo), with its own free step.
    base_name: the robot holding the needle (an arm: on its `ArmPlant`)."""
    base = make_robot(base_name)
    robot = curved_robot(base, CurvedNeedle(base.needle_length, 12e-3, 0.25))
    eye = default_eye(robot)
    start = solve_curved_pose(robot, np.array([*default_points(eye).p3, 0.0, *eye.port]))
    x0 = stack_value(CURVED_TASKS, robot, start.q, start.lam)
    pose0 = stack_value(CURVED_POSE_TASKS, robot, start.q, 0.0)
    phases = [Phase("aside", interpolate(x0, x0 + [2e-4, 1e-4, 0.0, 2e-3, 0.0, 0.0, 0.0], 8)),
              Phase("along", interpolate(pose0, pose0 + [1e-4, 0, 0, 0, 1e-4, 0, 0], 4),
                    kind="free")]  # fmt: skip
    use_path(path)
    plant = MujocoPlant(base, mode="dynamic") if base_name == "iramis" else ArmPlant(base)
    plant.reset(robot.actuators_from_joints(start.q))
    if callable(solver):
        solver = solver(plant, robot)
    free = solver.free_solver() if isinstance(solver, QpSolver) else CurvedPoseSolver(tol=TOLERANCE)
    ctl = Controller(plant, solver, free, settings=LoopSettings(max_iterations=2000), robot=robot)
    ctl.lam = start.lam
    return ctl.run(phases), plant, ctl


def curved_qp(plant: MujocoPlant | ArmPlant, robot: CurvedTipRobot) -> QpSolver:
    """The QP on iRAM!S holding the curved needle, the plant its servo (its steps planned from
    the plant's last command: `qp_mujoco_phase`, method CURVED_QP); its free steps the limited
    whole-pose steps (`LimitedPoseSolver`)."""
    return QpSolver(robot, default_eye(robot), tol=TOLERANCE, servo=plant)


@pytest.mark.parametrize(
    "solver", [CurvedPinvSolver(tol=TOLERANCE), CurvedDlsSolver(tol=TOLERANCE), curved_qp],
    ids=["pinv", "dls", "qp"],
)  # fmt: skip
def test_a_curved_needle_on_mujoco_runs_compiled_with_the_python_loops_log(solver) -> None:
    ref, ref_plant, ref_ctl = run("off", solver)
    got, plant, ctl = run("on", solver)
    assert ref_ctl.phase_paths == {"aside": "reference", "along": "reference"}
    assert ctl.phase_paths == {"aside": "compiled", "along": "compiled"}
    assert_same_log(ref, got, TOL_M, nonempty=True)
    assert np.isfinite(got.roll_error).all()  # every record states its roll error
    np.testing.assert_allclose(plant.data.qpos, ref_plant.data.qpos, rtol=0, atol=TOL_M)
    np.testing.assert_allclose(plant.command, ref_plant.command, rtol=0, atol=TOL_M)
    assert plant.time == pytest.approx(ref_plant.time, abs=1e-12)
    assert ctl.lam == pytest.approx(ref_ctl.lam, abs=TOL_M)


@pytest.mark.parametrize(
    "solver", [CurvedPinvSolver(tol=TOLERANCE), CurvedDlsSolver(tol=TOLERANCE), curved_qp],
    ids=["pinv", "dls", "qp"],
)  # fmt: skip
def test_a_curved_needle_on_an_arms_mujoco_plant_runs_compiled_with_the_python_loops_log(
    solver: Solver | Callable[[MujocoPlant | ArmPlant, CurvedTipRobot], QpSolver],
) -> None:
    """The same on the UR5's dynamic plant: the arm's iteration in the one compiled loop, which
    runs the `ArmPlant`'s period (`arm_phase.run_arm_phase_compiled`); the QP planned from the
    plant's last command (`arm_qp_kernels.solve_arm_step` with the servo's array)."""
    ref, ref_plant, ref_ctl = run("off", solver, "ur5")
    got, plant, ctl = run("on", solver, "ur5")
    assert ref_ctl.phase_paths == {"aside": "reference", "along": "reference"}
    assert ctl.phase_paths == {"aside": "compiled", "along": "compiled"}
    assert_same_log(ref, got, TOL_M, nonempty=True)
    assert np.isfinite(got.roll_error).all()
    np.testing.assert_allclose(plant.data.qpos, ref_plant.data.qpos, rtol=0, atol=TOL_M)
    np.testing.assert_allclose(plant.command, ref_plant.command, rtol=0, atol=TOL_M)
    assert plant.time == pytest.approx(ref_plant.time, abs=1e-12)
    assert ctl.lam == pytest.approx(ref_ctl.lam, abs=TOL_M)
