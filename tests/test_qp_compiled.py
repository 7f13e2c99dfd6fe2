"""The compiled QP step and loop equal the reference QP controller: the problem, its solution,
whole runs, their stops, and where the compiled path declines."""

from __future__ import annotations

from collections.abc import Iterator

import numba  # noqa: F401  (the `fast` extra: without it these tests fail, they do not skip)
import numpy as np
import pytest

from heavy import HEAVY
from qp_oracle import QpStepOracle
from rcmplan import Iramis
from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled import qp_phase
from rcmplan.compiled.qp_period import period_step
from rcmplan.compiled.runner import fast_converge_phase
from rcmplan.control import LoopSettings, Phase, PinvSolver
from rcmplan.control.augmented import extended_task
from rcmplan.control.limited_tip import LimitedTipSolver
from rcmplan.control.limits import TipSpeed, TissueDepthLimit
from rcmplan.control.limits.workspace import WorkspaceBound
from rcmplan.control.log import RunLog
from rcmplan.control.phase import split_steps
from rcmplan.control.qp import QpSolver
from rcmplan.control.qp_backends import solve
from rcmplan.control.qp_limits import QpLimits
from rcmplan.control.qp_problem import SCALE, StepInput, StepQP, build_step
from rcmplan.control.targets import rcm_target
from rcmplan.controller import Controller
from rcmplan.exceptions import ConvergenceError, QPError
from rcmplan.scene.constrained import grazing_spiral
from rcmplan.scene.eye import default_eye, default_points, eye_frame
from rcmplan.scene.procedures import injection
from rcmplan.sim import KinematicPlant

from conftest import random_joints
from logcheck import assert_same_log as same_log
from paths import use_path

# DAQP's primal tolerance is 1e-6 in the variables' unit (um): 1e-12 m per step.
X_TOL = 1e-6
RUN_TOL = 1e-11


@pytest.fixture(autouse=True)
def fast_on() -> Iterator[None]:
    use_path("on")
    yield
    use_path(None)


def reference(run):  # type: ignore[no-untyped-def]
    use_path("off")
    try:
        return run()
    finally:
        use_path("on")


def solvers(robot: Iramis) -> list[QpSolver]:
    """QP solvers that exercise every row: the default one, an RCM equality, a retina contact
    listed at a point, other gains and damping, no eye, teleoperation's workspace box (turned,
    and small enough that random states lie on both sides of its faces), and a tip speed bound
    with two extra limits (a tissue-depth sphere, then the box)."""
    eye = default_eye(robot)
    contact = tuple(default_points(eye).p5)
    turn = eye_frame(eye)
    box = WorkspaceBound(tuple(eye.center), tuple(map(tuple, turn)), (-3e-3, -2e-3, -4e-3),
                         (2e-3, 3e-3, 1e-3), gain=0.3)  # fmt: skip
    depth = TissueDepthLimit(eye.center, eye.retina_radius - 1e-3, gain=0.7, recovery=2e-6)
    return [
        QpSolver(robot, eye, extra_limits=(box,)),
        QpSolver(robot, eye, limits=QpLimits(rcm_tolerance=0.0), extra_limits=(box,)),
        QpSolver(robot, eye),
        QpSolver(robot, eye, limits=QpLimits(rcm_tolerance=0.0)),
        QpSolver(robot, eye, K=(0.5, 1.2, 0.8, 1.0, 1.5, 0.7), damping=3e-3,
                 limits=QpLimits(contacts=(contact,), rcm_weight=4.0, singular_margin=0.3)),
        QpSolver(robot, None, dt=2e-3),
        QpSolver(robot, eye, limits=QpLimits(tip_speed=5e-3), extra_limits=(depth, box)),
    ]  # fmt: skip


def states(
    robot: Iramis, rng: np.random.Generator, n: int, spread: float = 1e-3
) -> Iterator[tuple]:
    """(q, lam, target): random poses (some past the singular floor), each with the target of a
    pose `spread` away (m, rad), and poses near targets on and off the retina and with the tip
    in the trocar's zone."""
    eye = default_eye(robot)
    pts = default_points(eye)
    for q in random_joints(rng, n, angle=1.5):
        lam = float(rng.uniform(0.0, 1.0))
        yield q, lam, extended_task(robot, q + rng.normal(0.0, spread, 6), lam)
    for point in (pts.p3, pts.p4, pts.p5, pts.p6, pts.p7, eye.port + 1e-3 * eye.axis):
        target = rcm_target(point, eye.port)
        q = robot.needle_pose(point, target[1], target[2]) + rng.normal(0.0, spread / 10, 6)
        yield q, float(rng.uniform(0.3, 0.9)), target


def relative_gap(a: np.ndarray, b: np.ndarray) -> float:
    """max |a - b| over max |a| (0 for empty arrays)."""
    assert a.shape == b.shape
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(a)), 1e-300)) if a.size else 0.0


def assert_same_step(ref: StepQP, step: StepQP) -> None:
    """The compiled assembly's step equals the Python one: every array of the problem and
    the task to 1e-12 relative, the actuators it was built at exactly."""
    for name in ("P", "q", "G", "h", "A", "b", "lb", "ub"):
        gap = relative_gap(getattr(ref.problem, name), getattr(step.problem, name))
        assert gap <= 1e-12, (name, gap)
    assert relative_gap(ref.task, step.task) <= 1e-12
    np.testing.assert_array_equal(ref.sliders, step.sliders)


def test_compiled_qp_equals_build_step_at_many_states(robot: Iramis, rng) -> None:  # type: ignore[no-untyped-def]
    for solver in solvers(robot):
        fast = QpStepOracle(solver)
        for q, lam, target in states(robot, rng, 150):
            step = fast.problem(q, lam, target)
            e_ref = solver.task_error(robot, q, lam, target)
            np.testing.assert_allclose(fast.e, e_ref, rtol=0, atol=1e-15)
            # The error from the kernels' X_ext (equal to rounding, tests/test_fast.py): the
            # cost's q is compared on the same error, everything else on the reference's.
            inp = StepInput(q, lam, target, fast.e.copy(), solver.K, solver.damping, solver.dt,
                            solver.weights)  # fmt: skip
            assert_same_step(build_step(robot, inp, solver.rows, solver.bounds), step)


def test_compiled_step_solves_to_the_reference_solvers_step(robot: Iramis, rng) -> None:  # type: ignore[no-untyped-def]
    outcomes = {"solved": 0, "infeasible": 0}
    for solver in solvers(robot):
        fast = QpStepOracle(solver)
        for q, lam, target in states(robot, rng, 100, spread=1e-6):
            # QpSolver.error without its target check (random targets lie anywhere).
            e = solver.task_error(robot, q, lam, target)
            inp = StepInput(q, lam, target, e, solver.K, solver.damping, solver.dt,
                            solver.weights)  # fmt: skip
            ref = build_step(robot, inp, solver.rows, solver.bounds)
            try:
                x_ref = solve(ref.problem).x
            except QPError as exc:
                with pytest.raises(QPError) as info:
                    fast.solve(q, lam, target)
                assert str(info.value) == str(exc)
                outcomes["infeasible"] += 1
                continue
            x, e_fast = fast.solve(q, lam, target)
            np.testing.assert_allclose(x, x_ref, rtol=0, atol=X_TOL)
            # QpSolver.error: J x* / K, or the plain error for a step at full actuator speed.
            e_ref = e if solver.speed_limited(robot, x_ref) else ref.task @ x_ref / solver.K
            np.testing.assert_allclose(e_fast, e_ref, rtol=0, atol=X_TOL * SCALE)
            outcomes["solved"] += 1
    assert outcomes["solved"] > 300 and outcomes["infeasible"] > 0, outcomes


def assert_same_log(a: RunLog, b: RunLog) -> None:
    same_log(a, b, RUN_TOL)


def both(robot: Iramis, make, phases: list[Phase]) -> tuple:  # type: ignore[no-untyped-def]
    """The reference and the compiled run of the same job: (log or exception, controller)."""
    out = []
    for compiled in (False, True):
        ctl = make()
        try:
            result = ctl.run(phases) if compiled else reference(lambda c=ctl: c.run(phases))
        except QPError as exc:
            result = exc
        except ConvergenceError as exc:
            result = exc
        out.append((result, ctl))
    return tuple(out)


@pytest.mark.parametrize("scene", ["injection", "grazing spiral"])
def test_compiled_qp_loop_equals_the_reference_controller(robot: Iramis, scene: str) -> None:
    """The whole grazing spiral, and the injection up to its first return to p3 (its whole
    13 phases with RCMPLAN_HEAVY_TESTS=1: the reference QP takes about 15 s on them)."""
    if scene == "injection":
        eye = default_eye(robot)
        phases = injection(robot, eye, default_points(eye))
        phases = phases if HEAVY else phases[:5]
    else:
        eye, _, phases = grazing_spiral(robot)
    (ref, ca), (fast, cb) = both(robot, lambda: Controller(KinematicPlant(robot),
                                                           QpSolver(robot, eye)), phases)  # fmt: skip
    assert isinstance(ref, RunLog) and isinstance(fast, RunLog)
    assert_same_log(ref, fast)
    np.testing.assert_allclose(ca.plant.read_actuators(), cb.plant.read_actuators(), atol=RUN_TOL)
    assert ca.plant.time == cb.plant.time and abs(ca.lam - cb.lam) <= RUN_TOL


def test_a_full_record_buffer_pauses_and_resumes_the_loop(
    robot: Iramis, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(qp_phase, "ITERATIONS_PER_TARGET", 1)  # room for one target at a time
    eye = default_eye(robot)
    phases = injection(robot, eye, default_points(eye))[:4]
    (ref, _), (fast, _) = both(robot, lambda: Controller(KinematicPlant(robot),
                                                         QpSolver(robot, eye)), phases)  # fmt: skip
    assert isinstance(fast, RunLog) and len(fast) > 1000
    assert_same_log(ref, fast)


def test_iteration_cap_stops_both_paths_alike(robot: Iramis) -> None:
    eye = default_eye(robot)
    phases = injection(robot, eye, default_points(eye))[:4]
    (a, _), (b, _) = both(robot, lambda: Controller(
        KinematicPlant(robot), QpSolver(robot, eye), settings=LoopSettings(max_iterations=40)),
        phases)  # fmt: skip
    assert isinstance(a, ConvergenceError) and type(a) is type(b)
    assert "phase 'p3-p4' step 0" in str(a)  # a QP phase, after three that finish
    assert str(a).split("|error|")[0] == str(b).split("|error|")[0]
    np.testing.assert_allclose(a.error, b.error, rtol=0, atol=RUN_TOL)
    assert len(a.log) > 0
    assert_same_log(a.log, b.log)


def test_an_infeasible_step_raises_the_reference_qperror(robot: Iramis) -> None:
    # The needle starts 1 mm off the trocar: the RCM box cannot be reached in one step at
    # 10 um per slider step, so the first QP is infeasible on both paths.
    tip = robot.tip(robot.home)
    trocar = robot.needle_point(robot.home, 0.9) + np.array([0.0, 1e-3, 0.0])
    targets = np.array([rcm_target(tip + d, trocar) for d in ([-1e-5, 0, 0], [-2e-5, 0, 0])])
    (a, ca), (b, cb) = both(robot, lambda: Controller(KinematicPlant(robot), QpSolver(robot)),
                            [Phase("off the trocar", targets)])  # fmt: skip
    assert isinstance(a, QPError) and isinstance(b, QPError)
    assert str(a) == str(b) and "infeasible" in str(a)
    assert a.problem is not None and b.problem is not None
    assert_same_log(a.log, b.log)
    np.testing.assert_array_equal(ca.plant.read_actuators(), cb.plant.read_actuators())


class RecordingQp(QpSolver):
    """A subclass may change the step: it runs on the reference path."""


class SteepEye:
    """An eye whose retina distance is not the kernels' sphere's."""

    def __init__(self, eye) -> None:  # type: ignore[no-untyped-def]
        self.center, self.wall, self.port = eye.center, eye.wall, eye.port
        self.trocar_radius, self.retina_radius = eye.trocar_radius, eye.retina_radius

    def distance_to_retina(self, p: np.ndarray) -> float:
        return 2.0 * (self.retina_radius - float(np.linalg.norm(p - self.center)))


@pytest.mark.parametrize("case", ["other back end", "subclass", "daqp binding unusable", "odd eye"])
def test_compiled_qp_declines_what_it_does_not_reproduce(
    robot: Iramis, case: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    eye = default_eye(robot)
    solver: QpSolver = QpSolver(robot, eye)
    if case == "other back end":
        solver = QpSolver(robot, eye, backend="quadprog")
    elif case == "subclass":
        solver = RecordingQp(robot, eye)
    elif case == "daqp binding unusable":
        monkeypatch.setitem(fast_cache._state, "daqp_abi", False)
    else:
        solver = QpSolver(robot, SteepEye(eye))
        assert period_step(solver) is None  # nor does the step one period at a time
    ctl = Controller(KinematicPlant(robot), solver)
    targets = injection(robot, eye, default_points(eye))[2].plan(robot.home)
    assert not fast_converge_phase(ctl, solver, targets, ctl.log.phase_id("p"), 0)
    assert len(ctl.log) == 0


# --- the QP's free-space step, compiled (TIP_LIMITED) -------------------------------------------
def approach_with(robot: Iramis, free: LimitedTipSolver) -> tuple:  # type: ignore[type-arg]
    eye = default_eye(robot)
    phases = injection(robot, eye, default_points(eye))[:1]  # the approach, in free space
    return both(robot, lambda: Controller(KinematicPlant(robot), PinvSolver(), free), phases)


def test_the_limited_free_step_runs_compiled_and_equals_the_reference(robot: Iramis) -> None:
    (ref, _), (fast, cb) = approach_with(robot, LimitedTipSolver())
    assert isinstance(ref, RunLog) and isinstance(fast, RunLog)
    assert cb.phase_paths == {"approach": "compiled"}
    assert_same_log(ref, fast)
    moves = np.abs(np.diff(fast.sliders, axis=0))
    bound = robot.speed * 1e-3
    assert np.all(moves <= bound * (1 + 1e-9))
    assert np.any(moves >= bound * (1 - 1e-9))  # the speed bound was active


def test_the_limited_free_step_with_a_tip_speed_runs_compiled_and_equals_the_reference(
    robot: Iramis,
) -> None:
    free = LimitedTipSolver(tip_speed=2e-3)  # each tip axis moves at most 2 um per period
    (ref, _), (fast, cb) = approach_with(robot, free)
    assert isinstance(ref, RunLog) and isinstance(fast, RunLog)
    assert cb.phase_paths == {"approach": "compiled"}
    assert_same_log(ref, fast)
    moves = np.max(np.abs(np.diff(fast.tip, axis=0)), axis=1)
    bound = 2e-3 * free.dt
    assert np.all(moves <= bound * 1.01)  # to first order
    assert np.sum(moves >= 0.99 * bound) > 10  # the tip speed bound was active


def test_a_limited_step_below_the_tip_speed_is_not_lengthened(robot: Iramis) -> None:
    """A tip step shorter than tip speed x dt (and within every actuator's speed) is taken as
    it is, compiled as in the reference: the factor never exceeds 1."""
    tip = robot.tip(robot.home)
    phases = [Phase("short", np.array([tip + np.array([0.3e-6, 0.2e-6, 0.0])]), "free")]
    free = LimitedTipSolver(tip_speed=2e-3)  # 2 um per period, ~6x the step
    (ref, _), (fast, cb) = both(
        robot, lambda: Controller(KinematicPlant(robot), PinvSolver(), free), phases
    )
    assert isinstance(ref, RunLog) and isinstance(fast, RunLog)
    assert cb.phase_paths == {"short": "compiled"}
    assert_same_log(ref, fast)
    assert len(fast) <= 3  # the first step lands on the target (to first order)


def test_the_compiled_limited_step_stops_at_the_travel_margin_as_the_reference_does(
    robot: Iramis,
) -> None:
    q = robot.home
    tip = robot.tip(q)
    axis = (tip - robot.needle_point(q, 0.0)) / np.linalg.norm(tip - robot.needle_point(q, 0.0))
    # pushed 55 mm along the needle: the insertion stage L5 (travel to 50 mm) must stop short
    phases = [Phase("beyond", split_steps(tip, tip + 55e-3 * axis, 0.5e-3), "free")]
    free = LimitedTipSolver()
    (ref, _), (fast, cb) = both(
        robot, lambda: Controller(KinematicPlant(robot), PinvSolver(), free), phases
    )
    assert isinstance(ref, ConvergenceError) and isinstance(fast, ConvergenceError)
    assert str(ref) == str(fast)
    assert cb.phase_paths == {"beyond": "compiled"}
    assert_same_log(ref.log, fast.log)
    top = robot.upper[4] - free.travel_margin
    assert fast.log.sliders[:, 4].max() == pytest.approx(top, abs=1e-12)  # at the band's edge


# --- one QP step per period, compiled (teleoperation) -------------------------------------------
def test_a_teleoperation_session_runs_its_qp_compiled_with_the_reference_records() -> None:
    from rcmplan.teleop import SyntheticSurgeon, TeleopSettings, run_replay
    from rcmplan.teleop.motion_plan import MotionPlan, Move
    from rcmplan.teleop.session import Session

    # 2.5 mm towards the retina, 0.75 mm past its margin, held there; then 10 mm sideways,
    # past the workspace box
    push = MotionPlan(duration=3.5, moves=(Move(0.5, 1.2, (0.0, 0.0, 50e-3)),
                                           Move(1.9, 1.0, (200e-3, 0.0, 0.0))))  # fmt: skip
    settings = TeleopSettings()
    assert Session(settings).fast_step is not None
    track = SyntheticSurgeon(plan=push, seed=3).track()
    fast = run_replay(settings, track)
    ref = reference(lambda: run_replay(settings, track))
    assert fast.status == ref.status == "ok"
    assert_same_log(ref.log, fast.log)
    from rcmplan.teleop.summary import summary

    held = summary(fast)["fixture_active_s"]
    assert held["retina"] > 0.5 and held["workspace"] > 0.1, held  # both fixtures held the tip


def test_the_period_step_declines_what_it_does_not_reproduce(robot: Iramis) -> None:
    from rcmplan.robot.registry import make_robot

    eye = default_eye(robot)
    assert period_step(QpSolver(robot, eye)) is not None
    assert period_step(QpSolver(robot, eye, limits=QpLimits(tip_speed=0.01))) is not None
    box = WorkspaceBound((0.0, 0.0, 0.0), tuple(map(tuple, np.eye(3))), (-1.0,) * 3, (1.0,) * 3)
    assert period_step(QpSolver(robot, eye, extra_limits=(box, box))) is not None
    assert period_step(QpSolver(robot, eye, extra_limits=(box, box, box))) is None  # > MAX_EXTRA
    assert period_step(QpSolver(robot, eye, extra_limits=(TipSpeed(0.01),))) is None  # no kind
    ur5 = make_robot("ur5")  # an arm's QP runs compiled too (`arm_qp`)
    assert period_step(QpSolver(ur5, default_eye(ur5))) is not None
    assert period_step(QpSolver(ur5, default_eye(ur5), backend="quadprog")) is None


def test_a_moving_depth_limit_is_read_at_each_step(robot: Iramis, rng) -> None:  # type: ignore[no-untyped-def]
    eye = default_eye(robot)
    depth = TissueDepthLimit(eye.center, eye.retina_radius - 1e-3)
    solver = QpSolver(robot, eye, extra_limits=(depth,))
    fast = QpStepOracle(solver)
    q, lam, target = next(states(robot, rng, 0))  # near a target point in the eye
    bounds = []
    d = float(np.linalg.norm(robot.tip(q) - eye.center))
    for radius in (d + 10e-6, d + 20e-6):  # the tip 10 and 20 um inside the sphere
        depth.set_floor(radius)
        step = fast.problem(q, lam, target)
        inp = StepInput(q, lam, target, fast.e.copy(), solver.K, solver.damping, solver.dt,
                        solver.weights)  # fmt: skip
        ref = build_step(robot, inp, solver.rows, solver.bounds)
        assert relative_gap(ref.problem.h, step.problem.h) <= 1e-12
        bounds.append(step.problem.h[-1])
    assert bounds[0] != bounds[1]  # the depth row moved with the floor


class LaggingServo:
    """A plant whose servos follow the command (`QpSolver`'s `servo`): the last command and
    its resolution, nothing simulated."""

    exact_commands = False

    def __init__(self, command: np.ndarray) -> None:
        self.command = command
        self.actuator_resolution = np.array([1e-9] * 5 + [1e-6])


def test_the_period_step_with_a_servo_equals_the_reference_step(robot: Iramis, rng) -> None:  # type: ignore[no-untyped-def]
    """Planned from the servo's command (rounded), the cost synchronised: the compiled step
    equals `QpSolver.step` from the measured joints, synchronised steps among them (targets
    whose tip and angles lie up to 0.2 mm and mrad away, their RCM point the needle's own)."""
    from rcmplan.compiled.qp_period import period_step
    from rcmplan.control.cost import synchronise

    eye = default_eye(robot)
    servo = LaggingServo(robot.home_actuators.copy())
    depth = TissueDepthLimit(eye.center, eye.retina_radius - 1e-3)
    solver = QpSolver(robot, None, servo=servo, extra_limits=(depth,))
    step = period_step(solver)
    assert step is not None
    speed = np.ascontiguousarray(robot.speed[list(robot.active)])
    checked = synchronised = 0
    for q, lam, target in states(robot, rng, 60, spread=2e-4):
        target[3:] = robot.needle_point(q, lam)  # the RCM box holds at the start
        servo.command = robot.actuators_from_joints(q) + np.r_[rng.normal(0.0, 2e-6, 5), 0.0]
        plan = solver.planned_joints(robot, q)
        try:
            dq_ref, _ = solver.step(robot, q, lam, target, solver.task_error(robot, q, lam, target))
        except QPError:
            continue
        np.testing.assert_allclose(step(q, lam, target), dq_ref, rtol=0, atol=1e-11)
        e = solver.task_error(robot, plan, lam, target)
        inp = StepInput(plan, lam, target, e, solver.K, solver.damping, solver.dt, solver.weights)
        free = build_step(robot, inp, solver.rows, solver.bounds).problem  # not synchronised
        M = np.empty((free.q.shape[0] + 1, free.q.shape[0]))
        synchronised += synchronise(np.array(free.P), np.array(free.q), speed, solver.dt, M) > 1.0
        checked += 1
    assert checked > 30 and synchronised > 10, (checked, synchronised)
