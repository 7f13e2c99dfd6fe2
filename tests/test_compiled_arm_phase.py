"""The compiled arm loops behind the runner seam give the reference loop's log and exceptions: the
whole loop compiled on the kinematic plant, one compiled call per iteration on other plants."""

from __future__ import annotations

from collections.abc import Iterator

import numba  # noqa: F401  (the `fast` extra: without it these tests fail, they do not skip)
import numpy as np
import pytest

from rcmplan.compiled import arm_phase
from rcmplan.control import DlsSolver, LoopSettings, Phase, PinvSolver, TipSolver
from rcmplan.control.limited_tip import LimitedTipSolver
from rcmplan.control.log import RunLog
from rcmplan.control.solvers import Solver
from rcmplan.control.targets import rcm_target, solve_pose
from rcmplan.controller import Controller
from rcmplan.exceptions import ConvergenceError, RcmBoundError, SingularPoseError, SliderLimitError
from rcmplan.robot.model import SerialArm
from rcmplan.robot.shipped import shipped_arm
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.scene.procedures import injection
from rcmplan.sim import KinematicPlant

from logcheck import assert_same_log as same_log
from paths import use_path

TOL = 1e-12


@pytest.fixture(autouse=True)
def mode_restored() -> Iterator[None]:
    yield
    use_path(None)


@pytest.fixture(scope="module")
def ur5() -> SerialArm:
    return shipped_arm("ur5")


def assert_same_log(a: RunLog, b: RunLog) -> None:
    same_log(a, b, TOL, nonempty=True)


def injection_phase(robot: SerialArm, name: str) -> tuple[Phase, np.ndarray]:
    """A phase of the default injection and the joints it starts from (at p3, or at home)."""
    eye = default_eye(robot)
    points = default_points(eye)
    phase = next(ph for ph in injection(robot, eye, points) if ph.name == name)
    if phase.kind == "free":
        return phase, robot.home
    return phase, solve_pose(robot, rcm_target(points.p3, eye.port)).q


class SteppedPlant(KinematicPlant):
    """The kinematic plant, stating no exact commands: the per-iteration path."""

    exact_commands = False


def run(mode: str, robot: SerialArm, solver: Solver, phase: Phase, q0: np.ndarray,
        settings: LoopSettings | None = None,
        plant_type: type[KinematicPlant] = KinematicPlant) -> tuple[Controller, RunLog]:  # fmt: skip
    use_path(mode)
    plant = plant_type(robot)
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


def assert_same_plant(ctl: Controller, ref: Controller) -> None:
    assert ctl.lam == pytest.approx(ref.lam, abs=TOL)
    np.testing.assert_allclose(ctl.plant.read_actuators(), ref.plant.read_actuators(), 0, TOL)
    assert ctl.plant.time == ref.plant.time


def test_the_kinematic_plant_runs_the_whole_loop_compiled(ur5: SerialArm, monkeypatch) -> None:
    calls: list[str] = []
    monkeypatch.setattr(arm_phase, "run_arm_phase_compiled", lambda *a: calls.append("exact"))
    monkeypatch.setattr(arm_phase, "run_arm_phase", lambda *a: calls.append("per-iteration"))
    phase, q0 = injection_phase(ur5, "p3-p4")
    run("on", ur5, PinvSolver(), phase, q0)
    run("on", ur5, PinvSolver(), phase, q0, plant_type=SteppedPlant)
    assert calls == ["exact", "per-iteration"]


@pytest.mark.parametrize("solver", [PinvSolver(), DlsSolver()], ids=lambda s: s.name)
def test_a_plant_without_exact_commands_steps_in_python_with_the_reference_log(
    ur5: SerialArm, solver: Solver
) -> None:
    phase, q0 = injection_phase(ur5, "p3-p4")
    ref_ctl, ref = run("off", ur5, solver, phase, q0, plant_type=SteppedPlant)
    ctl, log = run("on", ur5, solver, phase, q0, plant_type=SteppedPlant)
    assert_same_log(log, ref)
    assert_same_plant(ctl, ref_ctl)


def test_the_free_approach_with_the_damped_tip_solver_gives_the_reference_log(
    ur5: SerialArm,
) -> None:
    phase, _ = injection_phase(ur5, "approach")  # from home
    tip_dls = TipSolver(damping=1e-3)
    logs = []
    for mode in ("off", "on"):
        use_path(mode)
        plant = KinematicPlant(ur5)
        ctl = Controller(plant, PinvSolver(), free_solver=tip_dls)
        logs.append((ctl, ctl.run([phase])))
    assert_same_log(logs[1][1], logs[0][1])
    assert_same_plant(logs[1][0], logs[0][0])


@pytest.mark.parametrize("plant_type", [KinematicPlant, SteppedPlant], ids=["exact", "stepped"])
def test_the_qps_limited_free_step_holds_joint_speed_with_the_reference_log(
    ur5: SerialArm, plant_type: type[KinematicPlant]
) -> None:
    """`LimitedTipSolver` on an arm runs in the arm loop (TIP_LIMITED): the approach from home
    with a 4 us period, where the joints' speed bounds the steps."""
    phase, _ = injection_phase(ur5, "approach")
    limited = LimitedTipSolver(dt=4e-6)
    logs = []
    for mode in ("off", "on"):
        use_path(mode)
        ctl = Controller(plant_type(ur5), PinvSolver(), free_solver=limited)
        logs.append((ctl, ctl.run([phase])))
    assert_same_log(logs[1][1], logs[0][1])
    assert_same_plant(logs[1][0], logs[0][0])
    assert logs[1][0].phase_paths == {"approach": "compiled"}
    moves = np.abs(np.diff(logs[1][1].joints, axis=0))[:, list(ur5.active)]
    bound = ur5.speed[list(ur5.active)] * limited.dt
    assert np.all(moves <= bound * (1 + 1e-9))
    assert np.sum(np.isclose(moves, bound, rtol=1e-9)) > 10  # the speed bound holds the steps


def test_the_qps_limited_free_step_holds_a_tip_speed_with_the_reference_log(
    ur5: SerialArm,
) -> None:
    """With a tip speed bound (`LimitedTipSolver(tip_speed=...)`) the arm loop also scales each
    step to hold the tip's first-order move per axis within tip speed x dt."""
    phase, _ = injection_phase(ur5, "approach")
    limited = LimitedTipSolver(tip_speed=2e-3)
    logs = []
    for mode in ("off", "on"):
        use_path(mode)
        ctl = Controller(KinematicPlant(ur5), PinvSolver(), free_solver=limited)
        logs.append((ctl, ctl.run([phase])))
    assert_same_log(logs[1][1], logs[0][1])
    assert logs[1][0].phase_paths == {"approach": "compiled"}
    bound = limited.tip_speed * limited.dt  # type: ignore[operator]
    moves = np.max(np.abs(np.diff(logs[1][1].tip, axis=0)), axis=1)
    assert np.all(moves <= bound * 1.01)  # to first order
    assert np.sum(moves >= 0.99 * bound) > 10  # the tip speed holds the steps


def stops(robot: SerialArm, solver: Solver, phase: Phase, q0: np.ndarray, error: type[Exception],
          settings: LoopSettings | None = None,
          plant_type: type[KinematicPlant] = KinematicPlant) -> None:  # fmt: skip
    """Both paths raise `error` with the same message, log, plant state and lambda."""
    got = []
    for mode in ("off", "on"):
        use_path(mode)
        plant = plant_type(robot)
        plant.reset(robot.actuators_from_joints(q0))
        ctl = Controller(plant, solver, settings=settings)
        with pytest.raises(error) as info:
            ctl.run([phase])
        got.append((ctl, info.value))
    (ref_ctl, ref), (ctl, exc) = got
    assert str(exc) == str(ref)
    if len(ref.log) or len(exc.log):
        assert_same_log(exc.log, ref.log)
    assert_same_plant(ctl, ref_ctl)


@pytest.mark.parametrize("plant_type", [KinematicPlant, SteppedPlant], ids=["exact", "stepped"])
def test_a_convergence_stop_raises_the_reference_error_and_keeps_the_partial_log(
    ur5: SerialArm, plant_type: type[KinematicPlant]
) -> None:
    phase, q0 = injection_phase(ur5, "p3-p4")
    stops(ur5, PinvSolver(K=(0.2,) * 6), phase, q0, ConvergenceError,
          LoopSettings(max_iterations=1), plant_type)  # fmt: skip


def test_a_phase_beyond_the_rcm_bound_raises_the_reference_error() -> None:
    panda = shipped_arm("panda")
    phase, q0 = injection_phase(panda, "p3-p4")
    ref = run("off", panda, PinvSolver(), phase, q0, LoopSettings(rcm_bound=None))[1]
    bound = 0.5 * float(np.nanmax(np.linalg.norm(ref.rcm_deviation(), axis=1)))  # half the phase's
    stops(panda, PinvSolver(), phase, q0, RcmBoundError, LoopSettings(rcm_bound=bound))


@pytest.mark.parametrize("plant_type", [KinematicPlant, SteppedPlant], ids=["exact", "stepped"])
def test_a_singular_pose_raises_the_reference_error(
    ur5: SerialArm, plant_type: type[KinematicPlant]
) -> None:
    phase, q0 = injection_phase(ur5, "p3-p4")  # the measure is about 0.05 on this phase
    stops(ur5, PinvSolver(), phase, q0, SingularPoseError, LoopSettings(singular_threshold=0.3),
          plant_type)  # fmt: skip


@pytest.mark.parametrize("plant_type", [KinematicPlant, SteppedPlant], ids=["exact", "stepped"])
def test_a_joint_leaving_its_travel_raises_the_reference_error(
    plant_type: type[KinematicPlant],
) -> None:
    ur5 = shipped_arm("ur5")  # a fresh model: its travel is narrowed below
    phase, q0 = injection_phase(ur5, "p3-p4")
    joints = run("off", ur5, PinvSolver(), phase, q0)[1].joints
    j = int(np.argmax(joints.max(axis=0) - q0))  # the joint that moves furthest up
    ur5.upper[j] = q0[j] + 0.5 * (joints[:, j].max() - q0[j])
    fixed = Phase(phase.name, phase.plan(q0))  # run_phase checks no fixed targets (run does)
    got = []
    for mode in ("off", "on"):
        use_path(mode)
        plant = plant_type(ur5)
        plant.reset(q0)
        ctl = Controller(plant, PinvSolver())
        with pytest.raises(SliderLimitError) as info:
            ctl.run_phase(fixed)
        got.append((ctl, info.value))
    (ref_ctl, ref), (ctl, exc) = got
    assert str(exc) == str(ref) and exc.index == ref.index
    assert_same_log(ctl.log.finish(), ref_ctl.log.finish())
    assert_same_plant(ctl, ref_ctl)


def test_a_subclass_of_serial_arm_runs_on_the_reference_path(ur5: SerialArm) -> None:
    class Other(SerialArm):
        pass

    other = Other(ur5.chain, ur5.needle, ur5.home, "other", roll_joint=5)
    ctl = Controller(KinematicPlant(other), TipSolver())
    assert not arm_phase.applies(ctl, TipSolver())
