"""The curved needle's kernels: J_c against finite differences of X_c, each step against the
equation it solves (numpy); the compiled loop against the loop run from Python: whole phases of
the curved injection (records with the roll error, the plant, lambda) on iRAM!S and the UR5,
the whole-pose phases on the Panda (seven joints), and the same exceptions; a straight needle's
runs keep their path and records; a degenerate whole-pose Jacobian gives a NaN step, which the
solvers called from Python refuse as the straight needle's do."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace

import numba  # noqa: F401  (the `fast` extra: without it these tests fail, they do not skip)
import numpy as np
import pytest

from rcmplan.compiled import curved_phase
from rcmplan.compiled.curved import curved_arrays
from rcmplan.control import LoopSettings, Phase, PinvSolver
from rcmplan.control.curved import (
    CURVED_TASKS,
    CurvedDlsSolver,
    CurvedPinvSolver,
    CurvedPoseSolver,
    task_jacobian,
)
from rcmplan.control.curved_step import least_norm
from rcmplan.control.curved_targets import solve_curved_pose
from rcmplan.control.log import RunLog
from rcmplan.control.methods import make_free_solver, make_solver
from rcmplan.control.solvers import Solver
from rcmplan.control.tasks import stack_value
from rcmplan.controller import Controller
from rcmplan.exceptions import (
    ConvergenceError,
    InvalidInputError,
    RcmplanError,
    SliderLimitError,
)
from rcmplan.robot import curved_block
from rcmplan.robot.curved import CurvedArrays, CurvedTipRobot, curved_robot
from rcmplan.robot.curved_needle import CurvedNeedle
from rcmplan.robot.registry import make_robot
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.scene.procedures import Steps, injection
from rcmplan.scene.scenario import load_scenario
from rcmplan.sim import KinematicPlant

from logcheck import assert_same_log as same_log
from paths import use_path

TOL = 1e-12
ROBOTS = ("iramis", "ur5")
METHODS = ("pinv", "dls")


@pytest.fixture(autouse=True)
def mode_restored() -> Iterator[None]:
    yield
    use_path(None)


@pytest.fixture(scope="module", params=ROBOTS)
def robot(request: pytest.FixtureRequest) -> CurvedTipRobot:
    base = make_robot(request.param)
    return curved_robot(base, CurvedNeedle(base.needle_length, 12e-3, 0.25))


def arrays_of(robot: CurvedTipRobot) -> CurvedArrays:
    arrays = curved_arrays(robot)
    assert arrays is not None
    return arrays


def configurations(robot: CurvedTipRobot, rng: np.random.Generator, n: int) -> np.ndarray:
    """n joint vectors near home (the roll turned by up to 1 rad)."""
    scale = np.array([5e-3 if u == "m" else 0.2 for u in robot.actuator_units])
    scale[robot.roll_joint] = 1.0
    return robot.home + scale * rng.uniform(-1.0, 1.0, (n, len(robot.home)))


def theta_ext_fd(f, robot: CurvedTipRobot, q0: np.ndarray, lam0: float,
                 h: float = 1e-7) -> np.ndarray:  # fmt: skip
    """Central differences of f(q, lambda) over theta_ext = (q[active], lambda), the roll
    row's differences wrapped to [-pi, pi)."""
    active = list(robot.active)
    x0 = np.append(q0[active], lam0)
    cols = []
    for j in range(x0.size):
        out = []
        for sign in (1.0, -1.0):
            x = x0.copy()
            x[j] += sign * h
            q = q0.copy()
            q[active] = x[:-1]
            out.append(f(q, float(x[-1])))
        diff = out[0] - out[1]
        diff[3] = (diff[3] + np.pi) % (2.0 * np.pi) - np.pi
        cols.append(diff / (2.0 * h))
    return np.array(cols).T


@pytest.mark.parametrize("pose", [False, True], ids=["x_c", "whole pose"])
def test_j_c_equals_finite_differences_of_x_c(robot: CurvedTipRobot, pose: bool, rng) -> None:
    for q in configurations(robot, rng, 5):
        lam = float(rng.uniform(0.2, 0.9))
        J = robot.task_and_jacobian(q, lam, pose)[1].copy()

        def x_c(qq: np.ndarray, ll: float) -> np.ndarray:
            return robot.task_and_jacobian(qq, ll, pose)[0].copy()

        np.testing.assert_allclose(J, theta_ext_fd(x_c, robot, q, lam), rtol=0, atol=2e-7)
        if pose:
            assert np.all(J[:, -1] == 0.0)  # lambda moves no point of the whole pose


def numpy_step(solver: Solver, robot: CurvedTipRobot, q: np.ndarray, lam: float,
               e: np.ndarray) -> np.ndarray:  # fmt: skip
    """The step the solver's equation defines, solved by numpy: J_c d = K e (square J_c); DLS
    d = J^T (J J^T + D^2 I)^-1 e with the roll row times l_s; the whole pose's least squares."""
    J = task_jacobian(solver.tasks, robot, q, lam)
    if isinstance(solver, CurvedPoseSolver):
        d = np.linalg.lstsq(J[:, :-1], np.asarray(solver.K) * e, rcond=None)[0]
        return np.append(d, 0.0)
    if isinstance(solver, CurvedDlsSolver):
        scale = np.ones(7)
        scale[3] = robot.needle_length
        Js, es = scale[:, None] * J, scale * e
        A = Js @ Js.T + solver.damping**2 * np.eye(7)
        return Js.T @ np.linalg.solve(A, es)
    return np.linalg.solve(J, np.asarray(solver.K) * e)


@pytest.mark.parametrize(
    "solver", [CurvedPinvSolver(), CurvedDlsSolver(), CurvedPoseSolver()], ids=lambda s: s.name
)
def test_each_step_solves_its_equation(robot: CurvedTipRobot, solver, rng) -> None:
    for q in configurations(robot, rng, 10):
        lam = float(rng.uniform(0.2, 0.9))
        x = stack_value(solver.tasks, robot, q, lam)
        target = x + rng.normal(0.0, 1e-4, 7)
        e = solver.error(robot, q, lam, target)
        dq, dlam = solver.step(robot, q, lam, target, e)
        np.testing.assert_allclose([*dq, dlam], numpy_step(solver, robot, q, lam, e),
                                   rtol=0, atol=TOL)  # fmt: skip


def test_a_satisfied_task_gives_zero_motion(robot: CurvedTipRobot) -> None:
    q = robot.home.copy()
    target = stack_value(CURVED_TASKS, robot, q, 0.5)
    dq, dlam = CurvedPinvSolver().step(robot, q, 0.5, target, np.zeros(7))
    assert np.abs(dq).max() == 0.0 and dlam == 0.0


def assert_same_log(a: RunLog, b: RunLog) -> None:
    same_log(a, b, TOL, nonempty=True)


def curved_run(name: str, method: str, mode: str, phases: int = 5,
               settings: LoopSettings | None = None) -> tuple[Controller, RunLog]:  # fmt: skip
    """The curved injection's first phases (approach and enter: whole poses; insert, p3-p4,
    p4-p3: X_c) on `mode`'s path, in 0.5 mm / 5 mrad steps (the RCM then moves about 12 um:
    no RCM bound, and the steps as the solver gives them), as `rcmplan.job` sets them up."""
    scenario = replace(load_scenario("curved").with_robot(name).with_method(method),
                       visits=("p4",), steps=Steps(0.5e-3, 5e-3))  # fmt: skip
    robot = scenario.needle.fit(make_robot(name))
    assert isinstance(robot, CurvedTipRobot)
    plant = KinematicPlant(robot.base)
    plant.reset(robot.home_actuators)
    solver = make_solver(method, scenario.method_settings, robot)
    ctl = Controller(plant, solver, make_free_solver(robot, scenario.method_settings),
                     settings=settings or replace(scenario.loop, rcm_bound=None, rcm_tolerance=None),
                     robot=robot)  # fmt: skip
    use_path(mode)
    try:
        return ctl, ctl.run(scenario.phases(robot)[:phases])
    finally:
        use_path(None)


@pytest.mark.parametrize("name", ROBOTS)
@pytest.mark.parametrize("method", METHODS)
def test_the_curved_injection_gives_the_reference_log(name: str, method: str, monkeypatch) -> None:
    ref_ctl, ref = curved_run(name, method, "off")

    def no_reference(*args: object) -> None:
        raise AssertionError("the reference loop ran")

    monkeypatch.setattr(Controller, "converge", no_reference)
    ctl, log = curved_run(name, method, "on")
    assert_same_log(log, ref)
    assert np.isfinite(log.roll_error).all()  # every record states its roll error
    np.testing.assert_allclose(ctl.plant.read_actuators(), ref_ctl.plant.read_actuators(),
                               rtol=0, atol=TOL)  # fmt: skip
    assert ctl.plant.time == pytest.approx(ref_ctl.plant.time, abs=1e-12)
    assert ctl.lam == pytest.approx(ref_ctl.lam, abs=TOL)


@pytest.mark.parametrize("name", ROBOTS)
def test_a_convergence_stop_raises_the_reference_error_with_the_partial_log(name: str) -> None:
    settings = LoopSettings(max_iterations=1)
    errors, logs = [], []
    for mode in ("off", "on"):
        with pytest.raises(ConvergenceError) as info:
            curved_run(name, "pinv", mode, settings=settings)
        errors.append(str(info.value))
        logs.append(info.value.log)
    assert errors[0] == errors[1]
    assert_same_log(logs[1], logs[0])


def test_a_roll_beyond_its_travel_raises_the_reference_error() -> None:
    base = make_robot("iramis")
    robot = curved_robot(base, CurvedNeedle(base.needle_length, 12e-3, 0.25))
    eye = default_eye(robot)
    pts = default_points(eye)
    start = solve_curved_pose(robot, np.array([*pts.p3, 0.0, *eye.port]))
    q0 = start.q.copy()
    q0[5] = robot.upper[5] - 1e-4  # 0.1 mrad from the roll's travel end, asked for 2 mrad more
    x0 = stack_value(CURVED_TASKS, robot, q0, start.lam)
    target = x0 + np.array([0.0, 0.0, 0.0, 2e-3, 0.0, 0.0, 0.0])
    messages = []
    for mode in ("off", "on"):
        plant = KinematicPlant(base)
        plant.reset(robot.actuators_from_joints(q0))
        ctl = Controller(plant, CurvedPinvSolver(), robot=robot)
        ctl.lam = start.lam
        use_path(mode)
        with pytest.raises(SliderLimitError) as info:
            ctl.run_phase(Phase("roll", target[None, :]))
        messages.append(str(info.value))
    assert messages[0] == messages[1]


class SteppedPlant(KinematicPlant):
    """The kinematic plant, stating no exact commands."""

    exact_commands = False


def test_a_plant_without_exact_commands_takes_the_reference_loop(robot: CurvedTipRobot) -> None:
    use_path("on")
    ctl = Controller(SteppedPlant(robot.base), CurvedPinvSolver(), robot=robot)
    target = stack_value(CURVED_TASKS, robot, robot.home, 0.5)[None, :]
    assert not curved_phase.run_if_fast(ctl, ctl.solver, target, 0, 0)


def redundant_curved() -> CurvedTipRobot:
    """The Panda with a curved needle: seven joints move it (the roll among them)."""
    base = make_robot("panda")
    robot = curved_robot(base, CurvedNeedle(base.needle_length, 12e-3, 0.25))
    assert arrays_of(robot).m == 7
    return robot


def test_the_whole_pose_step_of_a_redundant_arm_is_its_minimum_norm_least_squares(rng) -> None:
    robot, solver = redundant_curved(), CurvedPoseSolver()
    for q in configurations(robot, rng, 10):
        target = stack_value(solver.tasks, robot, q, 0.0) + rng.normal(0.0, 1e-4, 7)
        e = solver.error(robot, q, 0.0, target)
        dq, dlam = solver.step(robot, q, 0.0, target, e)
        J = task_jacobian(solver.tasks, robot, q, 0.0)
        assert np.linalg.matrix_rank(J[:, :-1]) == 6  # seven rows, seven joints: rank 6
        np.testing.assert_allclose([*dq, dlam], numpy_step(solver, robot, q, 0.0, e),
                                   rtol=0, atol=TOL)  # fmt: skip


def test_the_whole_pose_phases_of_a_redundant_arm_run_compiled_with_the_reference_log(
    monkeypatch,
) -> None:
    ref_ctl, ref = curved_run("panda", "pinv", "off", phases=2)  # approach, enter: whole poses
    assert arrays_of(ref_ctl.robot).m == 7

    def no_reference(*args: object) -> None:
        raise AssertionError("the reference loop ran")

    monkeypatch.setattr(Controller, "converge", no_reference)
    ctl, log = curved_run("panda", "pinv", "on", phases=2)
    assert_same_log(log, ref)
    np.testing.assert_allclose(ctl.plant.read_actuators(), ref_ctl.plant.read_actuators(),
                               rtol=0, atol=TOL)  # fmt: skip


def test_a_straight_needle_keeps_the_straight_records_on_the_compiled_path() -> None:
    logs = []
    base = make_robot("iramis")
    for robot in (base, curved_robot(base, CurvedNeedle(base.needle_length, 12e-3, 0.0))):
        assert curved_arrays(robot) is None
        eye = default_eye(robot)
        plant = KinematicPlant(base)
        plant.reset(robot.home_actuators)
        use_path("on")
        ctl = Controller(plant, PinvSolver(), robot=robot)
        logs.append(ctl.run(injection(robot, eye, default_points(eye), visits=("p4",))))
    assert_same_log(logs[1], logs[0])
    assert np.isnan(logs[0].roll_error).all()


def curved_targets(robot: CurvedTipRobot) -> list[np.ndarray]:
    """The X_c targets of every RCM phase of the `curved` scenario (checked before motion)."""
    scenario = load_scenario("curved").with_robot(robot.name)
    return [ph.plan(robot.home) for ph in scenario.phases(robot) if ph.kind == "rcm"]


def test_the_target_screen_follows_the_reference_newton_path(robot: CurvedTipRobot,
                                                             monkeypatch) -> None:  # fmt: skip
    seeds = []
    for mode in ("off", "on"):
        use_path(mode)
        ctl = Controller(KinematicPlant(robot.base), CurvedPinvSolver(), robot=robot)
        if mode == "on":  # every target cleared: no reference solve
            monkeypatch.setattr("rcmplan.control.curved_targets.solve_curved_pose", None)
        for targets in curved_targets(robot):
            ctl.check_targets(targets)
        seeds.append(ctl._check_seed)
    np.testing.assert_allclose(seeds[1], seeds[0], rtol=0, atol=TOL)


@pytest.mark.parametrize("bad", ["far", "roll", "nan"])
def test_a_target_the_needle_cannot_take_raises_the_reference_error(
    robot: CurvedTipRobot, bad: str
) -> None:
    # The UR5's last joint turns by +-2 pi: every roll lies within its travel, and both paths
    # accept the target that iRAM!S's q5 cannot take.
    accepted = bad == "roll" and robot.name != "iramis"
    targets = curved_targets(robot)[1].copy()
    if bad == "far":
        targets[20, :3] += np.array([0.0, 0.0, 0.3])  # 30 cm beyond the shaft
    elif bad == "roll":  # the roll far along, beyond iRAM!S's q5 travel after the last target
        targets[-1, 3] = targets[-1, 3] + 3.0
    else:
        targets[20, 5] = np.nan
    messages = []
    for mode in ("off", "on"):
        use_path(mode)
        ctl = Controller(KinematicPlant(robot.base), CurvedPinvSolver(), robot=robot)
        if accepted:
            ctl.check_targets(targets)
            continue
        with pytest.raises(RcmplanError) as info:
            ctl.check_targets(targets)
        messages.append(f"{type(info.value).__name__}: {info.value}")
    if accepted:
        return
    assert messages[1] == messages[0]
    assert messages[0].startswith("InvalidInputError" if bad == "nan" else "UnreachableTarget")


def test_a_degenerate_whole_pose_jacobian_gives_a_nan_step_not_an_exception() -> None:
    C, r = np.zeros((curved_block.BLOCK_ROWS, 8)), curved_block.J
    C[r : r + 3, :7] = C[r + 4 : r + 7, :7] = np.eye(3, 7)  # tip and base move alike: D = 0
    d = np.zeros(8)
    least_norm(C, 0, 7, d)
    assert np.isnan(d[:7]).all()


@pytest.mark.parametrize("solver", [CurvedPinvSolver(), CurvedDlsSolver(), CurvedPoseSolver()],
                         ids=lambda s: s.name)  # fmt: skip
def test_a_curved_solver_refuses_a_non_finite_error_as_the_straight_ones_do(
    robot: CurvedTipRobot, solver: Solver
) -> None:
    """A NaN in the error gives a NaN step from the kernel; `step` raises InvalidInputError
    naming the error (as `PinvSolver.step` does) instead of returning it."""
    q, lam = robot.home, 0.5
    target = stack_value(solver.tasks, robot, q, lam)  # type: ignore[attr-defined]
    error = solver.error(robot, q, lam, target)
    dq, _ = solver.step(robot, q, lam, target, error)
    assert np.isfinite(dq).all()  # a finite error: a finite step
    error[3] = np.nan
    with pytest.raises(InvalidInputError, match="error"):
        solver.step(robot, q, lam, target, error)
    with pytest.raises(InvalidInputError, match="error"):
        PinvSolver().step(robot.base, robot.base.home, lam, np.zeros(6), np.full(6, np.nan))
