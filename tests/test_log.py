"""The run log keeps a curved needle's roll error: its own column, NaN for a straight needle, in
the arrays, the CSV and the NPZ (older NPZ files without it load with NaN)."""

from __future__ import annotations

import csv
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from rcmplan.control import Phase, PinvSolver
from rcmplan.control.curved import CurvedPinvSolver
from rcmplan.control.curved_targets import solve_curved_pose
from rcmplan.control.log import ARRAY_FIELDS, LogBuilder, RunLog
from rcmplan.control.runner import ReferenceRunner
from rcmplan.control.targets import rcm_target, solve_pose
from rcmplan.controller import Controller
from rcmplan.job import run_scenario
from rcmplan.robot.curved import CurvedTipRobot, curved_robot
from rcmplan.robot.curved_needle import CurvedNeedle
from rcmplan.robot.registry import make_robot
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.scene.scenario import load_scenario
from rcmplan.sim import KinematicPlant

SOLVER = CurvedPinvSolver(K=(1.0, 1.0, 1.0, 0.5, 1.0, 1.0, 1.0))


@pytest.fixture(scope="module")
def robot() -> CurvedTipRobot:
    base = make_robot("iramis")
    return curved_robot(base, CurvedNeedle(base.needle_length, 12e-3, 0.25))


def curved_log(robot: CurvedTipRobot) -> tuple[RunLog, np.ndarray]:
    """A reference run turning the roll by 20 mrad and moving the tip 50 um with the RCM held,
    the roll's gain 0.5 (its error halves each iteration)."""
    eye = default_eye(robot)
    start = np.array([*default_points(eye).p3, 0.1, *eye.port])
    pose = solve_curved_pose(robot, start)
    plant = KinematicPlant(robot.base)
    plant.reset(robot.actuators_from_joints(pose.q))
    targets = start + np.outer(np.linspace(0.25, 1.0, 4), [5e-5, 0.0, 0.0, 2e-2, 0.0, 0.0, 0.0])
    ctl = Controller(plant, SOLVER, robot=robot, runner=ReferenceRunner())
    return ctl.run([Phase("roll", targets)]), targets


def test_a_curved_needles_records_keep_its_roll_error(robot: CurvedTipRobot) -> None:
    log, targets = curved_log(robot)
    solver = SOLVER
    assert len(log) > 0
    for i in range(len(log)):
        e = solver.error(robot, log.joints[i], float(log.lam[i]), targets[log.step[i]])
        np.testing.assert_array_equal(log.error[i], np.delete(e, 3))
        assert log.roll_error[i] == e[3]
    assert np.abs(log.roll_error).max() > 1e-3


def test_a_straight_needles_roll_error_is_nan() -> None:
    robot = make_robot("iramis")
    eye = default_eye(robot)
    pts = default_points(eye)
    pose = solve_pose(robot, rcm_target(pts.p3, eye.port))
    plant = KinematicPlant(robot)
    plant.reset(robot.actuators_from_joints(pose.q))
    ctl = Controller(plant, PinvSolver(), runner=ReferenceRunner())
    tip = pts.p3 + 2e-4 * (pts.p4 - pts.p3) / np.linalg.norm(pts.p4 - pts.p3)
    log = ctl.run([Phase("p3-p4", np.array([rcm_target(tip, eye.port)]))])
    assert len(log) > 0 and np.isnan(log.roll_error).all()


def test_csv_and_npz_carry_the_roll_error(robot: CurvedTipRobot, tmp_path: Path) -> None:
    log, _ = curved_log(robot)
    log.save_csv(tmp_path / "log.csv")
    with open(tmp_path / "log.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    np.testing.assert_array_equal([float(r["roll_error_rad"]) for r in rows], log.roll_error)
    log.save_npz(tmp_path / "log.npz")
    back = RunLog.load_npz(tmp_path / "log.npz")
    for k in ARRAY_FIELDS:
        np.testing.assert_array_equal(getattr(back, k), getattr(log, k))


def test_an_npz_written_without_the_roll_error_loads_with_nan(
    robot: CurvedTipRobot, tmp_path: Path
) -> None:
    log, _ = curved_log(robot)
    arrays = {k: getattr(log, k) for k in ARRAY_FIELDS if k != "roll_error"}
    names = {"phase_names": np.array(log.phase_names), "solver_names": np.array(log.solver_names)}
    np.savez(tmp_path / "old.npz", **arrays, **names)
    back = RunLog.load_npz(tmp_path / "old.npz")
    assert len(back) == len(log) and np.isnan(back.roll_error).all()
    np.testing.assert_array_equal(back.error, log.error)


def test_records_and_logs_built_without_a_roll_error_hold_nan(robot: CurvedTipRobot) -> None:
    log, _ = curved_log(robot)
    builder = LogBuilder()
    row = {k: getattr(log, k)[0] for k in ARRAY_FIELDS if k != "roll_error"}
    builder.append(**row)
    builder.extend(2, **{k: getattr(log, k)[:2] for k in row})
    assert np.isnan(builder.finish().roll_error).all()
    arrays = {k: getattr(log, k) for k in row}
    assert np.isnan(RunLog(**arrays).roll_error).all()


def test_a_log_without_records_has_the_robot_s_actuator_columns() -> None:
    """A run refused before motion leaves an empty log: its actuator and joint columns are as
    many as the controller's actuator labels, so figures indexed by the robot's joints read it
    (the curved scenario on the Panda visiting p6: joint 7 beyond travel at a lateral target,
    the bend p6 asks for lying in the rolls joint 7's travel cannot give)."""
    builder = LogBuilder(actuator_labels=tuple(f"j{i}_rad" for i in range(7)))
    log = builder.finish()
    assert log.sliders.shape == (0, 7) and log.joints.shape == (0, 7)
    assert LogBuilder().finish().sliders.shape == (0, 6)  # no labels: iRAM!S's six
    sc = replace(load_scenario("curved").with_robot("panda"), visits=("p6",))
    result = run_scenario(sc)
    assert result.status == "unreachable_target"
    assert result.summary()["limit_violations"]["travel"] == 0
    bad = replace(sc.method_settings, extra={"tip_speed": 1.0})  # not a QP option
    refused = run_scenario(replace(sc.with_method("qp"), method_settings=bad))  # no controller
    assert refused.status == "invalid_input" and refused.log.sliders.shape == (0, 7)
