"""Compile (or load from numba's cache) every kernel ahead of a first run: each loop, screen
and step with the argument types the runners use, on small jobs.

`compile_kernels()` fills numba's cache (in a container build, say); a run does not need it,
as every kernel compiles when first called. The one module of `rcmplan.compiled` that builds
controllers (the runners only receive them).
"""

from __future__ import annotations

import importlib.util

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.compiled import arm_phase, curved_phase, qp_mujoco_phase, qp_phase
from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.arm import FastArm, check_arm_targets
from rcmplan.compiled.arm_qp import curved_qp_applies
from rcmplan.compiled.curved import curved_arrays, screen
from rcmplan.compiled.phase import run_phase_compiled, run_phase_on_plant
from rcmplan.compiled.records import robot_params
from rcmplan.compiled.runner import FastIramis
from rcmplan.control.phase import LoopSettings, interpolate
from rcmplan.control.solvers import DlsSolver, PinvSolver, Solver, TipSolver
from rcmplan.control.targets import rcm_target
from rcmplan.control.tasks import JacobianVariant
from rcmplan.controller import Controller
from rcmplan.robot.chain import JointChain
from rcmplan.robot.curved import CurvedTipRobot
from rcmplan.robot.iramis import Iramis
from rcmplan.robot.model import SerialArm
from rcmplan.robot.needle import StraightNeedle
from rcmplan.sim.kinematic import KinematicPlant


def compile_kernels() -> None:
    """Compile (or load from numba's cache) every kernel with the argument types used here:
    `python -m rcmplan.warmup` fills the cache ahead of a first run (in a container build,
    say). Its four parts may run in separate processes at once (`scripts/check.sh` runs them
    in two): each kernel's cache entry is its own file."""
    compile_iramis_kernels()
    compile_arm_kernels()
    compile_curved_kernels()
    compile_subretinal_kernels()


def compile_iramis_kernels() -> None:
    """Compile (or load from numba's cache) iRAM!S's kernels: its kinematics, each loop and
    screen on the kinematic plant and on a plant stepping in Python, the QP loop, and the loops
    around the dynamic MuJoCo plant if MuJoCo is installed."""
    robot = Iramis()
    fast = FastIramis(robot)
    q, K = robot.home.copy(), np.ones(6)
    x = fast.task(q, 0.5)
    variants: tuple[JacobianVariant, ...] = ("exact", "thesis")
    for variant in variants:
        fast.augmented_jacobian(q, 0.5, variant)
        fast.step(q, 0.5, x, K, variant)
        fast.batch_task_jacobians(q[None, :], np.array([0.5]), variant)
    tip = robot.tip(q)
    trocar = tip + np.array([8e-3, 0.0, 0.0])  # on the needle, 8 mm behind the tip
    path = interpolate(tip, tip + np.array([-1e-3, 1e-4, 0.0]), 2)
    rcm = np.array([rcm_target(t, trocar) for t in path])
    fast_cache.loop_kernels().screen_targets(
        robot_params(robot), 0.1, rcm, np.zeros(2, dtype=np.bool_)
    )
    free = interpolate(tip, tip + 1e-4, 2)
    jobs: list[tuple[Solver, FloatArray]] = [
        (PinvSolver(), rcm), (PinvSolver(variant="thesis"), rcm), (DlsSolver(), rcm),
        (TipSolver(), free),
    ]  # fmt: skip
    for solver, targets in jobs:
        for plant, run in ((KinematicPlant(robot), run_phase_compiled),
                           (_SteppedPlant(robot), run_phase_on_plant)):  # fmt: skip
            ctl = Controller(plant, solver)
            ctl.lam = 1.0 - 8e-3 / robot.params.l6
            run(ctl, solver, targets, ctl.log.phase_id("warm"), 0)
    _compile_qp_loop(robot, trocar)
    if importlib.util.find_spec("mujoco") is not None:
        _compile_mujoco_loop(robot, jobs)


def _compile_qp_loop(robot: Iramis, trocar: FloatArray) -> None:
    """The QP in the compiled iRAM!S loop (the loop is one for every method; this runs its QP
    branch and loads DAQP's binding), on a 20 um move about the trocar, and its step one period
    at a time (`qp_period.period_step`); nothing if DAQP's C solver cannot be called from
    compiled code (`cache.qp_loop`)."""
    from rcmplan.compiled.qp_period import period_step
    from rcmplan.control.qp import QpSolver
    from rcmplan.control.targets import rcm_target

    tip = robot.tip(robot.home)
    path = interpolate(tip, tip + np.array([-2e-5, 2e-6, 0.0]), 2)
    targets = np.array([rcm_target(t, trocar) for t in path])
    solver = QpSolver(robot)
    ctl = Controller(KinematicPlant(robot), solver)
    ctl.lam = 1.0 - 8e-3 / robot.params.l6
    qp_phase.run_if_ready(ctl, solver, targets, ctl.log.phase_id("warm"), 0, robot_params(robot))
    period_step(solver)  # the step one period at a time (teleoperation), built on a first step


def _compile_mujoco_loop(robot: Iramis, jobs: list[tuple[Solver, FloatArray]]) -> None:
    """The compiled loop around the dynamic MuJoCo plant, on a short move per solver (up to
    0.5 mm: with the reference's 30 ms ramp it takes more than the default 100 periods). The
    loop is the kinematic plant's, given the plant's arrays: this loads what the runs above
    compiled (0.4 s in one measurement) and would compile it again only if the arrays' types
    differed from `exact_plant`'s."""
    from rcmplan.sim.mujoco.plant import MujocoPlant

    loop = fast_cache.closed_loop()
    for solver, targets in jobs:
        plant = MujocoPlant(robot, mode="dynamic")
        ctl = Controller(plant, solver, settings=LoopSettings(max_iterations=1000))
        ctl.lam = 1.0 - 8e-3 / robot.params.l6
        loop.run_phase_on_mujoco(ctl, solver, targets[:1], ctl.log.phase_id("warm"), 0)
    _compile_qp_mujoco_loop(robot, jobs[0][1])


def _compile_qp_mujoco_loop(robot: Iramis, targets: FloatArray) -> None:
    """The QP in the compiled loop around the dynamic MuJoCo plant (`qp_mujoco_phase`: its
    servo plan), on the first of the short RCM move's targets."""
    from rcmplan.control.qp import QpSolver
    from rcmplan.sim.mujoco.plant import MujocoPlant

    plant = MujocoPlant(robot, mode="dynamic")
    solver = QpSolver(robot, servo=plant)
    ctl = Controller(plant, solver, settings=LoopSettings(max_iterations=1000))
    ctl.lam = 1.0 - 8e-3 / robot.params.l6
    qp_mujoco_phase.run_if_ready(ctl, solver, targets[:1], ctl.log.phase_id("warm"), 0,
                                 robot_params(robot))  # fmt: skip


class _SteppedPlant(KinematicPlant):
    """A kinematic plant that takes the per-iteration path of plants with dynamics."""


def compile_arm_kernels() -> None:
    """Compile (or load from numba's cache) the arm kernels, both loops, the target screen and
    the QP step with the argument types used here, on iRAM!S's DH chain holding its needle (no
    robot package needed)."""
    from rcmplan.sim.kinematic import KinematicPlant

    robot = Iramis()
    mount = np.eye(4)
    mount[2, 3] = -robot.params.l6  # the needle runs along the tip frame's z up to its origin
    arm = SerialArm(JointChain.from_dh(robot.chain), StraightNeedle(robot.params.l6, mount),
                    robot.home, name="warm", roll_joint=5)  # fmt: skip
    fast, q = FastArm(arm), arm.home
    x = fast.task(q, 0.5)
    fast.augmented_jacobian(q, 0.5, "thesis")
    fast.step(q, 0.5, x, np.ones(6), np.empty(6))
    fast.dls_step(q, 0.5, x, 1e-4, np.empty(6))
    tip, trocar = arm.tip(q), arm.needle_point(q, 0.5)
    rcm = np.array([rcm_target(tip - 1e-4 * arm.needle_axis(q), trocar)])  # insert 0.1 mm
    check_arm_targets(arm, rcm)
    jobs: list[tuple[Solver, FloatArray]] = [
        (PinvSolver(), rcm), (PinvSolver(variant="thesis"), rcm), (DlsSolver(), rcm),
        (TipSolver(), tip[None, :] + 1e-5),
    ]  # fmt: skip
    for solver, targets in jobs:
        for run in (arm_phase.run_arm_phase_compiled, arm_phase.run_arm_phase):
            ctl = Controller(KinematicPlant(arm), solver)
            ctl.lam = 0.5
            run(ctl, solver, targets, ctl.log.phase_id("warm"), 0)
    _compile_arm_qp(arm, rcm[0])


def _compile_arm_qp(arm: SerialArm, target: FloatArray) -> None:
    """The arm's compiled QP step (`arm_qp`), one step and one assembly, and one phase of the
    arm loop with the QP; nothing if DAQP's C solver cannot be called from compiled code
    (`cache.daqp_callable`)."""
    from rcmplan.compiled.arm_qp import arm_qp_step
    from rcmplan.control.qp import QpSolver

    fast = arm_qp_step(QpSolver(arm))
    if fast is not None:
        fast.step(arm, arm.home, 0.5, target, fast.e)  # the solve and the RCM box's hold
        fast.problem(arm.home, 0.5, target)
        solver = QpSolver(arm)  # and the QP in the arm loop, whole phases and per iteration
        for run in (arm_phase.run_arm_phase_compiled, arm_phase.run_arm_phase):
            ctl = Controller(KinematicPlant(arm), solver)
            ctl.lam = 0.5
            run(ctl, solver, target[None, :], ctl.log.phase_id("warm"), 0)


def compile_curved_kernels(on: tuple[str, ...] = ("iramis", "arm")) -> None:
    """Compile (or load from numba's cache) the curved needle's loops, steps, target screens
    and needle frames with the argument types used here: the screen and each curved solver on
    one target (one step called from Python, one phase in the loop), the QP and its limited
    free-space step included, on iRAM!S and (or, `on`) on iRAM!S's DH chain as an arm holding
    the needle (no robot package needed). `scripts/check.sh` compiles the two in its two
    compile processes."""
    from rcmplan.control.curved import (
        CurvedDlsSolver,
        CurvedPinvSolver,
        CurvedPoseSolver,
        LimitedPoseSolver,
    )
    from rcmplan.control.qp import QpSolver
    from rcmplan.robot.chain import JointChain
    from rcmplan.robot.curved_needle import CurvedNeedle
    from rcmplan.robot.iramis import Iramis
    from rcmplan.robot.model import SerialArm
    from rcmplan.robot.needle import StraightNeedle
    from rcmplan.sim.kinematic import KinematicPlant

    iramis = Iramis()
    mount = np.eye(4)
    mount[2, 3] = -iramis.params.l6  # the needle runs along the tip frame's z up to its origin
    arm = SerialArm(JointChain.from_dh(iramis.chain), StraightNeedle(iramis.params.l6, mount),
                    iramis.home, name="warm", roll_joint=5)  # fmt: skip
    bases: dict[str, Iramis | SerialArm] = {"iramis": iramis, "arm": arm}
    for base in (bases[name] for name in on):
        robot = CurvedTipRobot(base, CurvedNeedle(base.needle_length))
        q = robot.home
        shaft = robot.needle_point(q, 0.5)
        x = np.array([*robot.tip(q), robot.roll(q), *shaft]) + 1e-6
        pose = np.array([*robot.tip(q), robot.roll(q), *robot.needle_point(q, 0.0)]) + 1e-6
        jobs: list[tuple[Solver, FloatArray]] = [
            (CurvedPinvSolver(), x), (CurvedDlsSolver(), x), (CurvedPoseSolver(), pose)
        ]  # fmt: skip
        arrays = curved_arrays(robot)
        if arrays is None:
            continue
        jobs.append((LimitedPoseSolver(), pose))
        screen(robot, arrays, x[None, :], np.ascontiguousarray(q, dtype=np.float64))
        robot.needle_frames(q[None, :])
        for solver, target in jobs:
            solver.step(robot, q, 0.5, target, solver.error(robot, q, 0.5, target))  # from Python
            ctl = Controller(KinematicPlant(base), solver, robot=robot)
            ctl.lam = 0.5
            pid = ctl.log.phase_id("warm")
            if arrays.P is not None:
                run_phase_compiled(ctl, solver, target[None, :], pid, 0, arrays.P)
            else:
                arm_phase.run_arm_phase_compiled(ctl, solver, target[None, :], pid, 0, arrays)
        qp = QpSolver(robot)
        ctl = Controller(KinematicPlant(base), qp, robot=robot)
        ctl.lam = 0.5
        pid = ctl.log.phase_id("warm")
        if arrays.P is not None:
            qp_phase.run_if_ready(ctl, qp, x[None, :], pid, 0, arrays.P)
            if isinstance(base, Iramis) and importlib.util.find_spec("mujoco") is not None:
                _compile_curved_mujoco(robot, base, arrays.P, x)
        elif curved_qp_applies(qp):
            arm_phase.run_arm_phase_compiled(ctl, qp, x[None, :], pid, 0, arrays)


def _compile_curved_mujoco(
    robot: CurvedTipRobot, base: Iramis, P: FloatArray, x: FloatArray
) -> None:
    """A curved needle's loops around the dynamic MuJoCo plant: pinv, and the QP planned from
    the servo's last command, on one target (P: the kernels' parameters with the arc)."""
    from rcmplan.control.curved import CurvedPinvSolver
    from rcmplan.control.qp import QpSolver
    from rcmplan.sim.mujoco.plant import MujocoPlant

    settings = LoopSettings(max_iterations=1000)
    plant = MujocoPlant(base, mode="dynamic")
    pinv = CurvedPinvSolver()
    ctl = Controller(plant, pinv, settings=settings, robot=robot)
    ctl.lam = 0.5
    curved_phase.run_if_fast(ctl, pinv, x[None, :], ctl.log.phase_id("warm"), 0)
    plant = MujocoPlant(base, mode="dynamic")
    qp = QpSolver(robot, servo=plant)
    ctl = Controller(plant, qp, settings=settings, robot=robot)
    ctl.lam = 0.5
    qp_mujoco_phase.run_if_ready(ctl, qp, x[None, :], ctl.log.phase_id("warm"), 0, P)


def compile_subretinal_kernels() -> None:
    """Compile (or load from numba's cache) the subretinal episode's compiled block of QP
    periods (`qp_periods`), on a short episode, and the iOCT B-scan's kernels."""
    from rcmplan.subretinal.episode import run_episode
    from rcmplan.subretinal.episode_settings import EpisodeSettings

    run_episode(EpisodeSettings(hold_s=0.2, hover_s=0.1, start_height_m=200e-6,
                                advance_speed_m_s=0.5e-3, settle_s=0.05))  # fmt: skip
    compile_bscan_kernels()


def compile_bscan_kernels() -> None:
    """Compile (or load from numba's cache) the iOCT B-scan's kernels: the reflectivity at
    points, one image rendered and segmented with the needle tenting the retina (its shadow,
    surface and tip, the mask under it), and one segmented without a needle."""
    from rcmplan.subretinal.ioct import BScanScene, IoctModel, reflectivity, render_bscan
    from rcmplan.subretinal.segment import segment_bscan

    model, rng = IoctModel(), np.random.default_rng(0)
    for tip in ((60e-6, 20e-6), None):
        scene = BScanScene(tent_m=0.0 if tip is None else 20e-6, tip_m=tip)
        segment_bscan(render_bscan(model, scene, rng), model, scene.curvature_radius_m,
                      scene.needle_diameter_m)  # fmt: skip
    reflectivity(BScanScene(), np.zeros(1), np.zeros(1))


if __name__ == "__main__":
    compile_kernels()
