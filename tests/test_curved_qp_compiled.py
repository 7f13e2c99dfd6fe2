"""The QP controller on a curved needle, compiled (iRAM!S in its loop, an arm in the arm loop): its
step's problem equals the Python assembly (`qp_problem.build_step`) at many states, and the
curved injection's phases (the free-space limited pose steps and the QP's RCM phases) run in
the compiled loop with the Python loop's log and stops."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace

import numba  # noqa: F401  (the `fast` extra: without it these tests fail, they do not skip)
import numpy as np
import pytest

from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.arm_qp import assembled_step, qp_arrays
from rcmplan.compiled.curved import curved_arrays
from rcmplan.compiled.qp_params import qp_params
from rcmplan.compiled.qp_rows import X
from rcmplan.control import LoopSettings
from rcmplan.control.curved import CURVED_TASKS, LimitedPoseSolver
from rcmplan.control.limits import TissueDepthLimit
from rcmplan.control.log import RunLog
from rcmplan.control.methods import make_solver
from rcmplan.control.qp import QpSolver, joints_step
from rcmplan.control.qp_backends import solve
from rcmplan.control.qp_limits import QpLimits
from rcmplan.control.qp_problem import StepInput, build_step
from rcmplan.control.tasks import stack_value
from rcmplan.controller import Controller
from rcmplan.exceptions import ConvergenceError, QPError
from rcmplan.robot.curved import CurvedTipRobot, curved_robot
from rcmplan.robot.curved_block import BLOCK_ROWS
from rcmplan.robot.curved_needle import CurvedNeedle
from rcmplan.robot.iramis_kernels import trig
from rcmplan.robot.registry import make_robot
from rcmplan.scene.eye import default_eye
from rcmplan.scene.scenario import load_scenario
from rcmplan.sim import KinematicPlant
from test_qp_compiled import assert_same_step, relative_gap

from logcheck import assert_same_log
from paths import use_path

RUN_TOL = 1e-11  # DAQP's primal tolerance, 1e-6 um, is 1e-12 m per step
X_TOL = 1e-6  # the same in the QP's variables (micrometres, microradians)


@pytest.fixture(autouse=True)
def mode_restored() -> Iterator[None]:
    yield
    use_path(None)


@pytest.fixture(scope="module")
def robot() -> CurvedTipRobot:
    base = make_robot("iramis")
    return curved_robot(base, CurvedNeedle(base.needle_length, 12e-3, 0.25))


def solvers(robot: CurvedTipRobot) -> list[QpSolver]:
    """The default QP, an RCM equality, no eye, other gains and damping, and a tip speed bound
    with a tissue-depth sphere."""
    eye = default_eye(robot)
    depth = TissueDepthLimit(eye.center, eye.retina_radius - 1e-3, gain=0.7, recovery=2e-6)
    return [
        QpSolver(robot, eye),
        QpSolver(robot, eye, limits=QpLimits(rcm_tolerance=0.0)),
        QpSolver(robot, None, dt=2e-3),
        QpSolver(robot, eye, K=(0.5, 1.2, 0.8, 1.0, 1.5, 0.7, 0.9), damping=3e-3),
        QpSolver(robot, eye, limits=QpLimits(tip_speed=5e-3), extra_limits=(depth,)),
    ]


def test_the_compiled_curved_step_equals_build_step_at_many_states(robot: CurvedTipRobot,
                                                                   rng) -> None:  # type: ignore[no-untyped-def]  # fmt: skip
    arrays = curved_arrays(robot)
    assert arrays is not None and arrays.P is not None
    k = fast_cache.qp_kernels()
    for solver in solvers(robot):
        params = qp_params(robot, solver)
        assert params is not None
        Q, contacts = params
        K = np.ascontiguousarray(solver.K, dtype=np.float64)
        qp, C = k.buffers(curved=True), np.empty((BLOCK_ROWS, 7))
        s, e = np.empty(6), np.empty(7)
        for _ in range(60):
            q = robot.home + rng.normal(0.0, 0.05, 6)
            lam = float(rng.uniform(0.2, 0.9))
            target = stack_value(CURVED_TASKS, robot, q + rng.normal(0.0, 1e-3, 6), lam)
            rows = k.build_curved_step(arrays.P, Q, contacts, K, q, trig(q), lam, target, s, e,
                                       qp, C)  # fmt: skip
            step = assembled_step(qp, rows, s)
            np.testing.assert_allclose(e, solver.task_error(robot, q, lam, target), rtol=0,
                                       atol=1e-15)  # fmt: skip
            inp = StepInput(q, lam, target, e.copy(), solver.K, solver.damping, solver.dt,
                            solver.weights)  # fmt: skip
            assert_same_step(build_step(robot, inp, solver.rows, solver.bounds), step)


def test_the_arm_s_compiled_curved_step_equals_the_python_qp(rng) -> None:  # type: ignore[no-untyped-def]
    """The UR5 holding the curved needle: the cost, the variable bounds, the solution, the
    error and the step of the arm loop's solve (`arm_qp_kernels.solve_arm_step` given its work array)
    against `qp_problem.build_step` solved by DAQP through `qp_backends` (`QpSolver._solve`'s
    path: the random states' targets need not pass the solver's target check)."""
    base = make_robot("ur5")
    robot = curved_robot(base, CurvedNeedle(base.needle_length, 12e-3, 0.25))
    arrays = curved_arrays(robot)
    assert arrays is not None and arrays.P is None
    A, ix = arrays.arm()
    k, W = fast_cache.arm_qp_kernels(), np.empty(arrays.work_shape())
    solved = 0
    for solver in solvers(robot):
        travel, Q, contacts, qp, s, _, _ = qp_arrays(solver, arrays.n)
        K = np.ascontiguousarray(solver.K, dtype=np.float64)
        e, d = np.empty(7), np.empty(arrays.m + 1)
        for _ in range(30):
            q = robot.home + rng.normal(0.0, 0.05, arrays.n)
            lam = float(rng.uniform(0.2, 0.9))
            target = stack_value(CURVED_TASKS, robot, q + rng.normal(0.0, 1e-3, arrays.n), lam)
            flag = k.solve_arm_step(A, ix, W, W, travel, Q, contacts, K, q, lam, target, s, e, d,
                                    qp, np.zeros(0))  # fmt: skip
            e_ref = solver.task_error(robot, q, lam, target)
            inp = StepInput(q, lam, target, e_ref, solver.K, solver.damping, solver.dt,
                            solver.weights)  # fmt: skip
            ref = build_step(robot, inp, solver.rows, solver.bounds)
            P, nb = ref.problem.P, ref.problem.P.shape[0]
            assert relative_gap(P, qp[0]) <= 1e-12
            assert relative_gap(ref.problem.q, qp[1]) <= 1e-12
            bounds = np.r_[ref.problem.lb, ref.problem.ub]
            assert relative_gap(bounds, np.r_[qp[4][:nb], qp[3][:nb]]) <= 1e-12
            try:
                x = solve(ref.problem, "daqp").x
            except QPError:  # an infeasible state (an RCM equality far from the trocar)
                assert flag != 1
                continue
            assert flag == 1
            solved += 1
            np.testing.assert_allclose(qp[X], x, rtol=0, atol=X_TOL)
            if not solver.speed_limited(robot, x):
                np.testing.assert_allclose(e, ref.task @ x / solver.K, rtol=0, atol=1e-12)
            dq, dlam = joints_step(robot, ref.sliders, x, q)
            np.testing.assert_allclose(d, np.r_[dq, dlam], rtol=0, atol=1e-12)
    print(f"{solved} of 150 states solved")
    assert solved >= 75  # most states: the comparison is not vacuous


def curved_qp_run(mode: str, name: str = "iramis", phases: int = 4,
                  settings: LoopSettings | None = None) -> tuple[Controller, RunLog]:  # fmt: skip
    """The curved injection's first phases with the QP (approach and enter: the QP's limited
    whole-pose steps; insert and p3-p4: the QP) on `mode`'s path, on robot `name`."""
    scenario = replace(load_scenario("curved").with_method("qp"), visits=("p4",))
    robot = scenario.needle.fit(make_robot(name))
    assert isinstance(robot, CurvedTipRobot)
    plant = KinematicPlant(robot.base)
    plant.reset(robot.home_actuators)
    solver = make_solver("qp", scenario.method_settings, robot, eye=default_eye(robot))
    ctl = Controller(plant, solver, settings=settings or scenario.loop, robot=robot)
    assert isinstance(ctl.free_solver, LimitedPoseSolver)
    use_path(mode)
    try:
        return ctl, ctl.run(scenario.phases(robot)[:phases])
    finally:
        use_path(None)


@pytest.mark.parametrize("name", ["iramis", "ur5"])
def test_the_curved_qp_injection_runs_compiled_with_the_reference_log(name: str,
                                                                      monkeypatch) -> None:  # type: ignore[no-untyped-def]  # fmt: skip
    """iRAM!S in its own loop (`qp_phase`), the UR5 in the arm loop (`arm_loop`)."""
    ref_ctl, ref = curved_qp_run("off", name)

    def no_reference(*args: object) -> None:
        raise AssertionError("the reference loop ran")

    monkeypatch.setattr(Controller, "converge", no_reference)
    ctl, log = curved_qp_run("on", name)
    assert set(ctl.phase_paths.values()) == {"compiled"}
    assert set(ref_ctl.phase_paths.values()) == {"reference"}
    assert_same_log(log, ref, RUN_TOL, nonempty=True)
    assert np.isfinite(log.roll_error).all()
    np.testing.assert_allclose(ctl.plant.read_actuators(), ref_ctl.plant.read_actuators(),
                               rtol=0, atol=RUN_TOL)  # fmt: skip
    assert ctl.lam == pytest.approx(ref_ctl.lam, abs=RUN_TOL)


@pytest.mark.parametrize("name", ["iramis", "ur5"])
def test_an_iteration_cap_stops_both_paths_alike(name: str) -> None:
    settings = LoopSettings(max_iterations=2)
    errors, logs = [], []
    for mode in ("off", "on"):
        with pytest.raises(ConvergenceError) as info:
            curved_qp_run(mode, name, settings=settings)
        errors.append(str(info.value))
        logs.append(info.value.log)
    assert errors[0] == errors[1]
    assert_same_log(logs[1], logs[0], RUN_TOL, nonempty=True)
