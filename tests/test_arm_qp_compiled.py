"""The compiled QP step on serial arms equals the reference QP controller: the assembled
problem, its solution, whole runs, and where the compiled step declines."""

from __future__ import annotations

from collections.abc import Iterator

import numba  # noqa: F401  (the `fast` extra: without it these tests fail, they do not skip)
import numpy as np
import pytest

from rcmplan.compiled import arm_phase
from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.arm_qp import ArmQpStep, arm_qp_applies
from rcmplan.compiled.records import QP
from rcmplan.control.augmented import extended_task
from rcmplan.control.limits import TissueDepthLimit
from rcmplan.control.limits.workspace import WorkspaceBound
from rcmplan.control.log import RunLog
from rcmplan.control.objective import Objective
from rcmplan.control.qp import QpSolver
from rcmplan.control.qp_backends import solve
from rcmplan.control.qp_limits import QpLimits
from rcmplan.control.qp_problem import SCALE, StepInput, build_step
from rcmplan.control.targets import rcm_target, solve_pose
from rcmplan.control.tasks import Posture
from rcmplan.controller import Controller
from rcmplan.exceptions import InvalidInputError, QPError, UnreachableTargetError
from rcmplan.robot.model import SerialArm
from rcmplan.robot.registry import make_robot
from rcmplan.scene.eye import default_eye, default_points, eye_frame
from rcmplan.scene.procedures import injection
from rcmplan.sim import KinematicPlant
from rcmplan.sim.mujoco.compiled import exact_plant

from logcheck import assert_same_log
from paths import use_path

X_TOL = 1e-6  # DAQP's primal tolerance, in the variables' unit (um, urad)
RUN_TOL = 1e-11  # [m], [rad]: the tolerance of the other compiled-path tests
NULL_SPACE_TOL = 1e-9  # [rad]: a redundant arm's joints (see the injection test)


@pytest.fixture(scope="module", params=["ur5", "panda"])
def arm(request: pytest.FixtureRequest) -> SerialArm:
    robot = make_robot(request.param)
    assert isinstance(robot, SerialArm)
    return robot


@pytest.fixture(autouse=True)
def fast_on() -> Iterator[None]:
    use_path("on")
    yield
    use_path(None)


def solvers(arm: SerialArm) -> list[QpSolver]:
    """QP solvers that exercise every row: the default one, an RCM equality, a retina contact
    listed at a point with other gains, damping and singular margin, no eye, and a tip speed
    bound with two extra limits (a tissue-depth sphere, then a turned workspace box)."""
    eye = default_eye(arm)
    contact = tuple(default_points(eye).p5)
    box = WorkspaceBound(tuple(eye.center), tuple(map(tuple, eye_frame(eye))),
                         (-3e-3, -2e-3, -4e-3), (2e-3, 3e-3, 1e-3), gain=0.3)  # fmt: skip
    depth = TissueDepthLimit(eye.center, eye.retina_radius - 1e-3, gain=0.7, recovery=2e-6)
    return [
        QpSolver(arm, eye),
        QpSolver(arm, eye, limits=QpLimits(rcm_tolerance=0.0)),
        QpSolver(arm, eye, K=(0.5, 1.2, 0.8, 1.0, 1.5, 0.7), damping=3e-3,
                 limits=QpLimits(contacts=(contact,), rcm_weight=4.0, singular_margin=0.05)),
        QpSolver(arm, None, dt=2e-3),
        QpSolver(arm, eye, limits=QpLimits(tip_speed=5e-3), extra_limits=(depth, box)),
    ]  # fmt: skip


def states(arm: SerialArm, rng: np.random.Generator, n: int,
           spread: float = 1e-3) -> Iterator[tuple]:  # fmt: skip
    """(q, lam, target): random poses about home (some near the singular floor), each with the
    target of a pose `spread` away (rad), and poses near the injection's targets, on and off
    the retina and with the tip in the trocar's zone."""
    eye = default_eye(arm)
    for _ in range(n):
        q = arm.home + rng.normal(0.0, 0.4, arm.home.shape)
        lam = float(rng.uniform(0.0, 1.0))
        yield q, lam, extended_task(arm, q + rng.normal(0.0, spread, q.shape), lam)
    pts = default_points(eye)
    for point in (pts.p3, pts.p4, pts.p5, pts.p6, pts.p7, eye.port + 1e-3 * eye.axis):
        target = rcm_target(point, eye.port)
        pose = solve_pose(arm, target)
        yield pose.q + rng.normal(0.0, spread / 10, pose.q.shape), pose.lam, target


def relative_gap(a: np.ndarray, b: np.ndarray) -> float:
    """max |a - b| over max |a| (0 for empty arrays)."""
    assert a.shape == b.shape
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(a)), 1e-300)) if a.size else 0.0


def test_compiled_arm_qp_equals_build_step_at_many_states(arm: SerialArm) -> None:
    rng = np.random.default_rng(20180507)
    rows = set()
    for solver in solvers(arm):
        fast = ArmQpStep(solver)
        for q, lam, target in states(arm, rng, 60):
            step = fast.problem(q, lam, target)
            np.testing.assert_allclose(fast.e, solver.task_error(arm, q, lam, target), rtol=0,
                                       atol=1e-15)  # fmt: skip
            inp = StepInput(q, lam, target, fast.e.copy(), solver.K, solver.damping, solver.dt,
                            solver.weights)  # fmt: skip
            ref = build_step(arm, inp, solver.rows, solver.bounds)
            for name in ("P", "q", "G", "h", "A", "b", "lb", "ub"):
                gap = relative_gap(getattr(ref.problem, name), getattr(step.problem, name))
                assert gap <= 1e-12, (name, gap)
            assert relative_gap(ref.task, step.task) <= 1e-12
            np.testing.assert_array_equal(ref.sliders, step.sliders)
            rows.add(step.problem.G.shape[0])
    assert len(rows) >= 4, rows  # the retina row on and off, the box and tip rows, no eye


def test_compiled_arm_step_solves_to_the_reference_solvers_step(arm: SerialArm) -> None:
    rng = np.random.default_rng(7)
    outcomes = {"solved": 0, "infeasible": 0}
    for solver in solvers(arm):
        fast = ArmQpStep(solver)
        for q, lam, target in states(arm, rng, 40, spread=1e-6):
            e = solver.task_error(arm, q, lam, target)
            inp = StepInput(q, lam, target, e, solver.K, solver.damping, solver.dt,
                            solver.weights)  # fmt: skip
            ref = build_step(arm, inp, solver.rows, solver.bounds)
            try:
                x_ref = solve(ref.problem).x
            except QPError:
                assert fast.solve(q, lam, target) != 1
                outcomes["infeasible"] += 1
                continue
            assert fast.solve(q, lam, target) == 1
            # QpSolver.error: J x* / K, or the plain error for a step at full joint speed.
            e_ref = e if solver.speed_limited(arm, x_ref) else ref.task @ x_ref / solver.K
            np.testing.assert_allclose(fast.e, e_ref, rtol=0, atol=X_TOL * SCALE)
            m = len(arm.active)
            np.testing.assert_allclose(fast.d[:m], x_ref[:m] * SCALE, rtol=0, atol=X_TOL * SCALE)
            assert fast.d[m] == pytest.approx(x_ref[m] * SCALE / arm.needle_length,
                                              abs=X_TOL * SCALE)  # fmt: skip
            outcomes["solved"] += 1
    assert outcomes["solved"] > 150 and outcomes["infeasible"] > 0, outcomes


def joint_tolerance(arm: SerialArm) -> float:
    """The joints' tolerance between the two paths: RUN_TOL, or NULL_SPACE_TOL on a redundant
    arm, whose null space (Panda: 6 active joints and lambda for the 6 X_ext rows) no task
    holds: the 1-ulp differences the paths leave at the approach's end move along it (3.8e-11
    rad at most over the injection, while the tip, RCM point, lambda and errors agree to
    1e-12)."""
    return NULL_SPACE_TOL if len(arm.active) + 1 > 6 else RUN_TOL


def run(arm: SerialArm, compiled: bool) -> tuple[RunLog, Controller]:
    eye = default_eye(arm)
    ctl = Controller(KinematicPlant(arm), QpSolver(arm, eye))
    use_path("on" if compiled else "off")
    return ctl.run(injection(arm, eye, default_points(eye))), ctl


def test_an_arm_qp_injection_runs_its_steps_compiled_with_the_reference_log(
    arm: SerialArm,
) -> None:
    (a, ref), (b, fast) = run(arm, False), run(arm, True)
    assert isinstance(a, RunLog) and len(a) > 1000
    joint_tol = joint_tolerance(arm)
    assert_same_log(a, b, RUN_TOL, joint_atol=joint_tol)
    np.testing.assert_allclose(ref.plant.read_actuators(), fast.plant.read_actuators(),
                               rtol=0, atol=joint_tol)  # fmt: skip
    assert abs(ref.lam - fast.lam) <= RUN_TOL
    # The QP holds its own RCM box on the true kinematics (`rcm_step.box_margin`): before it
    # did, the second-order part of the first step towards each target took the UR5 to 0.80
    # um and the Panda to 0.83 um.
    deviation = np.linalg.norm(b.rcm_deviation(), axis=1)[np.isfinite(b.trocar[:, 0])]
    assert deviation.max() <= QpLimits().rcm_tolerance
    inside = [name for name, path in fast.phase_paths.items() if path == "compiled"]
    assert set(ref.phase_paths.values()) == {"reference"}
    assert inside == ["approach", "align", "insert", "p3-p4", "p4-p3", "p3-p5", "p5-p3", "p3-p6",
                      "p6-p3", "p3-p7", "p7-p3", "retract", "withdraw"]  # fmt: skip


class SteppedPlant(KinematicPlant):
    """A kinematic plant the loop cannot step inside compiled code (`exact_commands` False):
    the arm loop's iteration is one compiled call, the plant steps in Python."""

    exact_commands = False


def test_the_arm_loop_runs_the_qp_on_a_plant_stepping_in_python(arm: SerialArm) -> None:
    eye = default_eye(arm)
    plan = injection(arm, eye, default_points(eye))[:4]  # approach, align, insert, p3-p4
    logs, ctls = [], []
    for mode in ("off", "on"):
        use_path(mode)
        ctl = Controller(SteppedPlant(arm), QpSolver(arm, eye))
        logs.append(ctl.run(plan))
        ctls.append(ctl)
    assert len(logs[0]) > 300
    assert_same_log(logs[0], logs[1], RUN_TOL, joint_atol=joint_tolerance(arm))
    assert set(ctls[0].phase_paths.values()) == {"reference"}
    assert set(ctls[1].phase_paths.values()) == {"compiled"}
    assert arm_phase.arm_code(ctls[1], ctls[1].solver) == QP


def test_the_qp_with_a_servo_on_the_dynamic_mujoco_arm_runs_in_the_arm_loop(
    arm: SerialArm,
) -> None:
    """On the dynamic MuJoCo plant the QP plans from the servo's last command
    (`arm_qp_kernels.solve_arm_step` with its servo array), one compiled call per period."""
    from rcmplan.control.methods import make_solver
    from rcmplan.sim.registry import make_plant

    eye = default_eye(arm)
    plan = injection(arm, eye, default_points(eye))[:3]  # approach, align, insert
    logs, ctls = [], []
    for mode in ("off", "on"):
        use_path(mode)
        plant = make_plant("mujoco", arm)
        plant.reset(arm.home_actuators)
        solver = make_solver("qp", robot=arm, plant=plant, eye=eye)
        assert isinstance(solver, QpSolver) and solver.servo is plant
        ctl = Controller(plant, solver)
        logs.append(ctl.run(plan))
        ctls.append(ctl)
    assert len(logs[0]) > 200
    assert_same_log(logs[0], logs[1], RUN_TOL)
    assert set(ctls[0].phase_paths.values()) == {"reference"}
    assert set(ctls[1].phase_paths.values()) == {"compiled"}


class SubclassQp(QpSolver):
    """A subclass may change the step: it runs on the reference path."""


@pytest.mark.parametrize("case", ["other back end", "subclass", "daqp binding unusable",
                                  "three extra limits", "posture objective"])  # fmt: skip
def test_the_compiled_arm_step_declines_what_it_does_not_reproduce(
    arm: SerialArm, case: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    eye = default_eye(arm)
    assert arm_qp_applies(QpSolver(arm, eye))
    box = WorkspaceBound((0.0, 0.0, 0.0), tuple(map(tuple, np.eye(3))), (-1.0,) * 3, (1.0,) * 3)
    solver: QpSolver
    if case == "other back end":
        solver = QpSolver(arm, eye, backend="quadprog")
    elif case == "subclass":
        solver = SubclassQp(arm, eye)
    elif case == "daqp binding unusable":
        monkeypatch.setitem(fast_cache._state, "daqp_abi", False)
        solver = QpSolver(arm, eye)
    elif case == "three extra limits":
        solver = QpSolver(arm, eye, extra_limits=(box, box, box))
    else:  # a cost term the compiled assembly does not hold
        posture = Objective(Posture(), arm.home[list(arm.active)], 0.2, 1e-3)
        solver = QpSolver(arm, eye, objectives=(posture,))
    assert not arm_qp_applies(solver)
    with pytest.raises(InvalidInputError, match="solver"):
        ArmQpStep(solver)
    ctl = Controller(KinematicPlant(arm), solver)
    assert arm_phase.arm_code(ctl, solver) is None


class ServoPlant(KinematicPlant):
    """A plant whose servos follow commands over several periods (the QP plans from them): its
    last command is `lead`, its resolution 1 urad."""

    exact_commands = False

    def __init__(self, arm: SerialArm) -> None:
        super().__init__(arm)
        self.lead = arm.home.copy()
        self.actuator_resolution = np.full(len(arm.home), 1e-6)

    @property
    def command(self) -> np.ndarray:
        return self.lead.copy()


def test_error_and_step_at_one_state_share_one_servo_solve(
    arm: SerialArm, monkeypatch: pytest.MonkeyPatch
) -> None:
    plant = ServoPlant(arm)
    fast = ArmQpStep(QpSolver(arm, None, servo=plant))
    calls: list[int] = []
    solve = fast._k.solve_packed  # the one compiled call per solve (`solve_arm_step` inside)
    monkeypatch.setattr(fast._k, "solve_packed", lambda *a: calls.append(1) or solve(*a))
    q, lam, target = next(states(arm, np.random.default_rng(1), 1, spread=1e-6))
    plant.lead = q + 1e-4
    fast.step(arm, q, lam, target, fast.error(arm, q, lam, target))
    assert len(calls) == 1
    plant.lead = q + 2e-4  # a new command: a new solve
    fast.step(arm, q, lam, target, fast.error(arm, q, lam, target))
    assert len(calls) == 2


def test_the_compiled_arm_step_plans_from_a_servos_command_as_the_solver_does(
    arm: SerialArm,
) -> None:
    """With a servo the QP is built at its last command rounded to its resolution, the cost
    synchronised to the speed window, the error J x* / K plus the command's lead, the step from
    the measured joints (`QpSolver`'s servo plan; `arm_qp_kernels.solve_arm_step`)."""
    from rcmplan.compiled.qp_period import period_step

    plant = ServoPlant(arm)
    rng = np.random.default_rng(11)
    solved = 0
    for eye, n in ((None, 30), (default_eye(arm), 0)):  # random poses; near the injection's
        solver = QpSolver(arm, eye, servo=plant)
        assert solver.servo is plant and arm_qp_applies(solver)
        fast, step = ArmQpStep(solver), period_step(solver)
        assert step is not None
        for q, lam, target in states(arm, rng, n, spread=1e-6):
            plant.lead = q + rng.normal(0.0, 2e-4, q.shape)  # the servo not yet at its command
            try:
                e_ref = solver.error(arm, q, lam, target)
            except UnreachableTargetError:  # the solver's own target check, on both paths
                with pytest.raises(UnreachableTargetError):
                    fast.error(arm, q, lam, target)
                continue
            except QPError:
                assert fast.solve(q, lam, target) != 1
                continue
            d_ref, dlam_ref = solver.step(arm, q, lam, target, e_ref)
            e = fast.error(arm, q, lam, target)
            np.testing.assert_allclose(e, e_ref, rtol=0, atol=X_TOL * SCALE)
            d, dlam = fast.step(arm, q, lam, target, e_ref)
            np.testing.assert_allclose(d, d_ref, rtol=0, atol=X_TOL * SCALE)
            assert dlam == pytest.approx(dlam_ref, abs=X_TOL * SCALE)
            np.testing.assert_allclose(step(q, lam, target), d_ref, rtol=0, atol=X_TOL * SCALE)
            solved += 1
    assert solved >= 10, solved


def test_the_period_step_runs_an_arms_qp_compiled(arm: SerialArm) -> None:
    from rcmplan.compiled.qp_period import period_step

    eye = default_eye(arm)
    solver = QpSolver(arm, eye)
    step = period_step(solver)
    assert step is not None
    rng = np.random.default_rng(5)
    for q, lam, target in list(states(arm, rng, 0, spread=1e-6)):
        ref = solver.step(arm, q, lam, target, solver.task_error(arm, q, lam, target))[0]
        np.testing.assert_allclose(step(q, lam, target), ref, rtol=0, atol=X_TOL * SCALE)


def test_a_solve_that_fails_in_the_arm_loop_raises_the_reference_qp_error(arm: SerialArm) -> None:
    """A phase whose QP has no solution stops the compiled arm loop with QP_FAILED, raised as
    the reference path's QPError (the arm loop read DAQP's exit flag from the wrong array)."""
    from rcmplan.control.phase import LoopSettings, Phase

    rng = np.random.default_rng(3)
    solver = QpSolver(arm, default_eye(arm))
    outcomes: dict[str, int] = {}
    for q, _, target in states(arm, rng, 40, spread=0.3):
        try:
            s = arm.actuators_from_joints(q)
            plant = KinematicPlant(arm)
            plant.reset(s)
        except Exception:  # a random pose beyond travel: not a start
            continue
        ctl = Controller(plant, solver, settings=LoopSettings(max_target_step=None))
        try:
            ctl.run_phase(Phase("far", target[None, :]))
            outcome = "ran"
        except QPError:
            outcome = "qp_error"
        except Exception as exc:  # other stops are counted, not this test's
            assert not isinstance(exc, IndexError | TypeError | AttributeError), exc
            outcome = type(exc).__name__
        assert ctl.phase_paths.get("far", "compiled") == "compiled"
        outcomes[outcome] = outcomes.get(outcome, 0) + 1
    assert outcomes.get("qp_error", 0) > 0, outcomes


@pytest.mark.parametrize("given", ["QP without its arrays", "pinv with the QP's arrays"])
def test_the_arm_loop_takes_the_qps_arrays_with_the_qp_only(arm: SerialArm, given: str) -> None:
    """The arm loop picks the QP's code by its arrays alone (numba prunes the other methods'
    branches): method QP without them is refused, not run as another method, and so is
    another method given them."""
    from rcmplan.control.solvers import PinvSolver

    ctl = Controller(KinematicPlant(arm), PinvSolver())
    setup = arm_phase._Setup(ctl, ctl.solver)
    target = extended_task(arm, arm.home, 0.5)[None, :]
    head = list(setup.head(target))
    assert head[9] is None  # qpa, None for the pinv solver
    n = arm.chain.n
    if given.startswith("QP"):
        head[2] = QP  # the method code
    else:
        head[9] = arm_phase.qp_arrays(QpSolver(arm, default_eye(arm)), n)
        assert head[9] is not None
    with pytest.raises(ValueError, match="need qpa"):
        fast_cache.algorithm().run_targets(
            *head, 0, 0, arm.home.copy(), np.empty(n), np.array([0.5, 0.0, 1e-3]),
            np.empty((20, setup.width)), np.empty((20, 2), dtype=np.int64),
            np.zeros(3, dtype=np.int64), setup.fail, exact_plant(),
            fast_cache.algorithm().work_arrays(n),
        )  # fmt: skip
