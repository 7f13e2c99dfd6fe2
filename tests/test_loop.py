"""Algorithms 1 and 2 on the kinematic plant: accuracy, drift correction, failures keep the log."""

from __future__ import annotations

import numpy as np
import pytest

from rcmplan import Iramis
from rcmplan.control import (
    DlsSolver,
    LoopSettings,
    Phase,
    PinvSolver,
    extended_task,
    interpolate,
    rcm_target,
    solve_pose,
    split_steps,
)
from rcmplan.controller import Controller
from rcmplan.exceptions import (
    ConvergenceError,
    InvalidInputError,
    SingularPoseError,
    UnreachableTargetError,
)
from rcmplan.robot.needle import angles_from_axis, axis_from_angles
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.scene.procedures import Steps, line_targets
from rcmplan.sim import KinematicPlant

from paths import use_path

UM = 1e-6


def pivot_phase(robot: Iramis, n: int = 500) -> Phase:
    x0 = extended_task(robot, robot.home, 1.0)
    return Phase("align", interpolate(x0, x0 + [0, 0.0048, 0.212, 0, 0, 0], n))


def controller_at(robot: Iramis, q: np.ndarray, lam: float, solver, **settings) -> Controller:
    plant = KinematicPlant(robot)
    plant.reset(robot.actuators_from_joints(q))
    ctl = Controller(plant, solver, settings=LoopSettings(**settings))
    ctl.lam = lam
    return ctl


def max_dev(log) -> float:
    return float(np.nanmax(np.linalg.norm(log.rcm_deviation(), axis=1)))


@pytest.mark.parametrize("solver", [PinvSolver(), DlsSolver()], ids=["pinv", "dls"])
def test_pivot_alignment_holds_the_rcm_within_a_micrometre(robot: Iramis, solver) -> None:
    log = controller_at(robot, robot.home, 1.0, solver).run([pivot_phase(robot)])
    assert max_dev(log) <= 1 * UM
    q_end = log.joints[-1]
    assert (q_end[1], q_end[3]) == pytest.approx((0.0048, 0.212), abs=1e-8)
    assert set(np.unique(log.step)) == set(range(500))


def p3_pose(robot: Iramis):
    eye = default_eye(robot)
    pts = default_points(eye)
    return eye, pts, solve_pose(robot, rcm_target(pts.p3, eye.port))


@pytest.mark.parametrize("solver", [PinvSolver(), DlsSolver()], ids=["pinv", "dls"])
def test_move_between_two_retina_points_holds_the_rcm(robot: Iramis, solver) -> None:
    eye, pts, _ = p3_pose(robot)
    pose = solve_pose(robot, rcm_target(pts.p4, eye.port))
    log = controller_at(robot, pose.q, pose.lam, solver).run(
        [Phase("p4-p6", line_targets(pts.p4, pts.p6, eye.port, Steps()))]
    )
    assert max_dev(log) <= 1 * UM
    assert np.linalg.norm(log.tip[-1] - pts.p6) <= 1 * UM


def test_drift_correction_keeps_p_rcm_on_the_foot_point_and_off_lets_it_slide(
    robot: Iramis,
) -> None:
    eye, pts, pose = p3_pose(robot)
    logs = {}
    for drift in (True, False):
        ctl = controller_at(robot, pose.q, pose.lam, PinvSolver(), drift_correction=drift)
        logs[drift] = ctl.run([Phase("p3-p4", line_targets(pts.p3, pts.p4, eye.port, Steps()))])
    on, off = logs[True], logs[False]
    # On: lambda is the needle point closest to the trocar, so p_rcm - trocar is the line distance.
    np.testing.assert_allclose(
        np.linalg.norm(on.rcm_deviation(), axis=1), on.line_distance(), atol=1e-12
    )
    assert max_dev(on) <= 1 * UM
    # Off: the needle line still passes within a micrometre, but p_rcm slides along it.
    assert float(off.line_distance().max()) <= 1 * UM
    assert max_dev(off) > max_dev(on)


def test_random_reachable_targets_in_a_cone_all_converge(robot: Iramis, rng) -> None:
    eye, pts, pose = p3_pose(robot)
    phi0, psi0 = angles_from_axis(eye.axis)
    worst = 0.0
    for _ in range(200):
        phi, psi = phi0 + rng.uniform(-0.12, 0.12), psi0 + rng.uniform(-0.12, 0.12)
        target = eye.port + rng.uniform(3e-3, 20e-3) * axis_from_angles(phi, psi)
        ctl = controller_at(robot, pose.q, pose.lam, PinvSolver())
        log = ctl.run([Phase("move", line_targets(pts.p3, target, eye.port, Steps()))])
        worst = max(worst, max_dev(log))
        assert np.linalg.norm(log.tip[-1] - target) <= 1 * UM
    assert worst <= 1 * UM


@pytest.mark.parametrize(
    "tip",
    [
        lambda eye: eye.port + 0.099 * eye.axis,  # beyond the needle: lambda < 0
        lambda eye: eye.port + 0.02 * axis_from_angles(1.2, 0.1),  # sliders beyond travel
        lambda eye: eye.port + 0.02 * axis_from_angles(0.1, 1.5),  # needle angle out of reach
    ],
    ids=["lambda", "travel", "angle"],
)
def test_unreachable_targets_raise_before_any_motion(robot: Iramis, tip) -> None:
    eye, pts, pose = p3_pose(robot)
    ctl = controller_at(robot, pose.q, pose.lam, PinvSolver())
    s0 = ctl.plant.read_actuators()
    targets = np.array([rcm_target(pts.p3, eye.port), rcm_target(tip(eye), eye.port)])
    with pytest.raises(UnreachableTargetError) as info:
        ctl.run([Phase("move", targets)])
    assert len(info.value.log) == 0
    np.testing.assert_array_equal(ctl.plant.read_actuators(), s0)


def test_iteration_cap_raises_convergence_error_with_the_partial_log(robot: Iramis) -> None:
    ctl = controller_at(robot, robot.home, 1.0, PinvSolver(K=(0.01,) * 6), max_iterations=5)
    with pytest.raises(ConvergenceError, match="after 5 iterations") as info:
        ctl.run([pivot_phase(robot, n=10)])
    assert len(info.value.log) == 5
    assert info.value.log.phase_names == ("align",)


def test_singular_pose_raises_and_keeps_the_log(robot: Iramis) -> None:
    q = np.array([0.0, 1.1, 0.0, 0.0, 0.0, 0.0])  # |cos q1| = 0.45, below the threshold 0.5
    ctl = controller_at(robot, q, 1.0, PinvSolver(), singular_threshold=0.5)
    x0 = extended_task(robot, q, 1.0)
    with pytest.raises(SingularPoseError) as info:
        ctl.run([Phase("pivot", (x0 + [0, 0.01, 0, 0, 0, 0])[None, :])])
    assert info.value.log is not None


def test_split_steps_makes_equal_steps_within_both_sizes() -> None:
    start = np.zeros(6)
    goal = np.array([1e-3, 0.01, -0.004, 0, 0, 0])
    steps = split_steps(start, goal, 2e-4, 2e-3)
    assert len(steps) == 5
    np.testing.assert_allclose(steps[-1], goal)
    assert np.all(np.abs(np.diff(steps, axis=0))[:, 1:3] <= 2e-3 + 1e-15)


def test_split_steps_refuses_a_step_larger_than_the_distance() -> None:
    with pytest.raises(InvalidInputError, match="distance"):
        split_steps(np.zeros(3), np.array([1e-4, 0, 0]), 1e-3)


def test_non_finite_targets_raise() -> None:
    with pytest.raises(InvalidInputError, match="finite"):
        rcm_target(np.array([np.nan, 0, 0]), np.zeros(3))


def test_solve_pose_realises_the_target_exactly(robot: Iramis, rng) -> None:
    eye, pts, _ = p3_pose(robot)
    for name in ("p3", "p4", "p5", "p6", "p7"):
        x = rcm_target(pts.as_dict()[name], eye.port)
        pose = solve_pose(robot, x)
        np.testing.assert_allclose(extended_task(robot, pose.q, pose.lam), x, atol=1e-14)
        np.testing.assert_allclose(robot.tip(pose.q), pts.as_dict()[name], atol=1e-14)


def test_log_builder_keeps_a_copy_of_each_block() -> None:
    from rcmplan.control.log import ARRAY_FIELDS, SHAPES, LogBuilder

    log, buf = LogBuilder(), np.zeros(4)
    cols = {k: np.zeros((4, SHAPES[k]) if k in SHAPES else 4) for k in ARRAY_FIELDS}
    log.extend(4, **{**cols, "time": buf})
    buf[:] = 1.0  # the caller refills its buffer for the next block
    log.extend(4, **{**cols, "time": buf})
    np.testing.assert_array_equal(log.finish().time, [0, 0, 0, 0, 1, 1, 1, 1])


@pytest.mark.parametrize("mode", ["off", "on"])
def test_a_phase_beyond_the_rcm_bound_stops_the_run_on_either_path(robot: Iramis, mode) -> None:
    from rcmplan.exceptions import RcmBoundError
    from rcmplan.scene.procedures import injection

    eye = default_eye(robot)
    phases = injection(robot, eye, default_points(eye))
    use_path(mode)
    try:
        ctl = Controller(
            KinematicPlant(robot), PinvSolver(), settings=LoopSettings(rcm_bound=0.2e-6)
        )
        with pytest.raises(RcmBoundError, match=r"beyond the bound of 0\.200 um") as info:
            ctl.run(phases)
    finally:
        use_path(None)
    err = info.value
    assert err.deviation > 0.2e-6
    assert err.log is not None
    inside = err.log.select(np.isfinite(err.log.trocar[:, 0]))
    worst = np.linalg.norm(inside.rcm_deviation(), axis=1).max()
    assert worst == pytest.approx(err.deviation, abs=0.0)
    assert err.log.phase_names[-1] == err.phase  # the run ended in the phase that broke it


def test_an_rcm_bound_that_holds_lets_the_run_finish(robot: Iramis) -> None:
    from rcmplan.scene.procedures import injection

    eye = default_eye(robot)
    log = Controller(KinematicPlant(robot), PinvSolver()).run(
        injection(robot, eye, default_points(eye))
    )
    inside = log.select(np.isfinite(log.trocar[:, 0]))
    assert np.linalg.norm(inside.rcm_deviation(), axis=1).max() < LoopSettings().rcm_bound


def test_a_phase_starting_far_from_the_needle_is_refused_before_it_moves(robot: Iramis) -> None:
    """A user's splice of a return from p4 right after `insert` (the needle still at p3)."""
    from rcmplan.scene.procedures import injection

    eye = default_eye(robot)
    pts = default_points(eye)
    phases = injection(robot, eye, pts)
    insert_end = next(i for i, p in enumerate(phases) if p.name == "insert") + 1
    spliced = Phase("spliced", line_targets(pts.p4, pts.p3, eye.port, Steps()))
    assert np.linalg.norm(pts.p4 - pts.p3) > 1e-3  # farther than the default bound
    ctl = Controller(KinematicPlant(robot), PinvSolver())
    with pytest.raises(
        InvalidInputError, match=r"\d+\.\d+ mm jump from the needle's tip to target 0"
    ) as info:
        ctl.run([*phases[:insert_end], spliced])
    assert info.value.log is not None
    assert "spliced" not in {info.value.log.phase_names[i] for i in info.value.log.phase}


def test_the_jump_check_can_be_switched_off(robot: Iramis) -> None:
    settings = LoopSettings(max_target_step=None)
    assert settings.max_target_step is None
    with pytest.raises(InvalidInputError, match="max_target_step"):
        LoopSettings(max_target_step=-1.0)


def test_target_tips_are_target_tip_of_each_row() -> None:
    from rcmplan.control.targets import rcm_targets, target_tip, target_tips

    rng = np.random.default_rng(3)
    trocar = np.array([0.02, 0.001, -0.002])
    tips = trocar + rng.uniform(-5e-3, 5e-3, (40, 3)) + [0.01, 0.0, 0.0]
    targets = rcm_targets(tips, trocar)
    got = target_tips(targets)
    assert np.array_equal(got, np.array([target_tip(t) for t in targets]))
    assert np.allclose(got, tips, rtol=0.0, atol=1e-12)
    curved = np.hstack([tips, rng.uniform(-1.0, 1.0, (40, 4))])
    assert np.array_equal(target_tips(curved), tips)


def test_target_tips_name_the_first_target_whose_axis_fixes_no_tip() -> None:
    from rcmplan.control.targets import target_tips

    targets = np.tile([0.03, 0.1, 0.05, 0.02, 0.0, 0.0], (4, 1))
    targets[2, 1:3] = [np.pi / 2, 0.0]  # axis along z: x_tip does not fix the tip
    with pytest.raises(UnreachableTargetError, match="target 2: needle axis perpendicular"):
        target_tips(targets)


def test_a_jump_between_two_targets_is_refused_naming_them(robot: Iramis) -> None:
    eye = default_eye(robot)
    pts = default_points(eye)
    path = line_targets(pts.p3, pts.p4, eye.port, Steps())
    jumped = np.vstack([path[:3], path[-1:]])  # target 2 to 3: the rest of the way at once
    ctl = Controller(KinematicPlant(robot), PinvSolver())
    ctl.plant.reset(robot.actuators_from_joints(solve_pose(robot, path[0]).q))
    with pytest.raises(InvalidInputError, match=r"mm jump from target 2 to 3"):
        ctl.run_phase(Phase("jumped", jumped))
