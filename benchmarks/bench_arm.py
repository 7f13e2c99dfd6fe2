"""The compiled control step of any serial arm (UR5, Panda) against pinocchio and the Python step.

Run alone: python benchmarks/bench_arm.py. Needs the `fast` and `robots` extras; the pinocchio
rows need `pin` (the `bench` extra). Each row: figure, value, unit, peer, peer_value, ratio,
target. Times are medians per call from Python (`_common.per_call`).
- Compiled step: `FastArm.step` (all frames, X_ext, J_a with exact angle rows, and the pinv
  solve: Gaussian elimination on the UR5's square J_a, the minimum-norm step plus the null-space
  posture on the Panda's 6 x 7 J_a), into a preallocated `out`, contiguous float64 inputs.
- Python reference: `PinvSolver.step` on the same arm (X_ext Jacobian from the model, the
  solve); configurations alternate so the model's frame cache never hits.
- pinocchio: `forwardKinematics` + `computeFrameJacobian` (LOCAL_WORLD_ALIGNED) of the flange
  frame, on a model built from the same URDF file (the Panda's finger joints locked), checked
  against the rcmplan chain to 1e-10 first.
- Loop per iteration: the p3-p4 phase of the default injection from p3 (50 targets, about 150
  records) on the kinematic plant with `PinvSolver`, per record (one record per control step
  taken), median over repeats. "kernel": `algorithm.run_targets` alone, the whole Algorithm 1
  loop in numba (the <= 1.5 us floor is for the 7-DOF arm); "phase": the same through
  `arm_phase.run_arm_phase_compiled` from Python (setup, log, plant state); both against the
  reference loop (`Controller.converge` per target, no target check).
- QP loop per record: the same phase with `QpSolver(arm, default_eye(arm))` through
  `algorithm.run_targets` (the arm's compiled QP in the loop), against the reference loop
  with the same solver.
- Phase per record: the UR5's p3-p4 phase through `Controller.run` (`Controller.phase_times`:
  planning, the loop and the RCM bound check; its fixed targets are checked before the phases,
  outside this time), fast path on against off.
- Target screen per target: `arm.check_arm_targets` (compiled Newton IK along the path) against
  the reference check (`solve_pose` per target seeded with the previous joints) on the same
  phase's 50 targets planned from home.
"""

from __future__ import annotations

import math
import statistics
import time
from itertools import cycle
from typing import Any

import numpy as np

from _common import per_call, quick, row, use_path
from rcmplan.compiled import arm_phase
from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.arm import FastArm, check_arm_targets
from rcmplan.control import PinvSolver, extended_task, rcm_target, solve_pose
from rcmplan.control.qp import QpSolver
from rcmplan.controller import Controller
from rcmplan.robot.shipped import robot_chain, robot_file, shipped_arm
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.scene.procedures import injection
from rcmplan.sim import KinematicPlant
from rcmplan.sim.mujoco.compiled import exact_plant

SEED = 20180507
ARMS = {"panda": ("Panda (7 joints)", "panda_link8"), "ur5": ("UR5 (6 joints)", "tool0")}
FLOOR_US = 3.0  # the compiled 7-DOF step from Python, median
LOOP_FLOOR_US = 1.5  # the compiled 7-DOF loop per iteration


def problem(name: str) -> tuple[Any, np.ndarray, float, np.ndarray]:
    """(arm, joints near home, lambda, an X_ext target 1 mrad away) for a shipped arm."""
    arm = shipped_arm(name)
    rng = np.random.default_rng(SEED)
    q = arm.home + rng.uniform(-0.05, 0.05, arm.chain.n)
    return arm, q, 0.5, extended_task(arm, q + 1e-3, 0.5)


def compiled_us(name: str, n: int) -> float:
    """Median time of `FastArm.step` from Python in [us]."""
    arm, q, lam, target = problem(name)
    fast, K = FastArm(arm), np.ones(6)
    out = np.empty(len(arm.active) + 1)
    return 1e6 * per_call(lambda: fast.step(q, lam, target, K, out), n)


def python_us(name: str, n: int) -> float:
    """Median time of `PinvSolver.step` in [us], alternating between two configurations."""
    arm, q, lam, target = problem(name)
    solver = PinvSolver()
    states = cycle([(x, solver.error(arm, x, lam, target)) for x in (q, q + 1e-4)])

    def step() -> None:
        x, e = next(states)
        solver.step(arm, x, lam, target, e)

    return 1e6 * per_call(step, n)


def pinocchio_model(name: str) -> tuple[Any, Any, int]:
    """(model, data, flange frame id) from the arm's URDF file, extra joints locked at 0."""
    import pinocchio as pin

    model = pin.buildModelFromUrdf(str(robot_file(name)))
    chain = robot_chain(name)
    extra = [model.getJointId(j) for j in model.names[1:] if j not in chain.joint_names]
    if extra:
        model = pin.buildReducedModel(model, extra, pin.neutral(model))
    return model, model.createData(), model.getFrameId(ARMS[name][1])


def pinocchio_us(name: str, n: int) -> float:
    """Median time of pinocchio's FK + frame Jacobian in [us], after checking its kinematics."""
    import pinocchio as pin

    model, data, fid = pinocchio_model(name)
    chain = robot_chain(name)
    _, q, _, _ = problem(name)
    pin.framesForwardKinematics(model, data, q)
    J = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)
    err = max(np.abs(data.oMf[fid].homogeneous - chain.forward_kinematics(q)).max(),
              np.abs(J - chain.jacobian(q)).max())  # fmt: skip
    if err > 1e-10:
        raise RuntimeError(f"the pinocchio {name} model differs from rcmplan's by {err:.3g}")

    def peer() -> None:
        pin.forwardKinematics(model, data, q)
        pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)

    return 1e6 * per_call(peer, n)


def arm_rows(name: str) -> list[dict[str, Any]]:
    label = ARMS[name][0]
    n = 2000 if quick() else 20000
    ours = compiled_us(name, n)
    target = f"<= {FLOOR_US:g} us" if name == "panda" else ""
    figure = f"{label} control step, compiled, from Python"
    rows = [row(figure, ours, "us", "rcmplan PinvSolver.step (Python)",
                python_us(name, 100 if quick() else 500), target)]  # fmt: skip
    try:
        rows.append(row(figure, ours, "us", "pinocchio forwardKinematics + computeFrameJacobian",
                        pinocchio_us(name, n), "ratio <= 1"))  # fmt: skip
    except ImportError as exc:
        rows.append(row(f"pinocchio: not installed ({exc.name}); pip install 'rcmplan[bench]'",
                        math.nan, ""))  # fmt: skip
    return rows


def p3_p4(arm: Any) -> tuple[Any, np.ndarray]:
    """The p3-p4 phase of the default injection and the joints at p3."""
    eye = default_eye(arm)
    points = default_points(eye)
    phase = next(ph for ph in injection(arm, eye, points) if ph.name == "p3-p4")
    return phase, solve_pose(arm, rcm_target(points.p3, eye.port)).q


def phase_us(arm: Any, mode: str) -> float:
    """Time in the p3-p4 phase per record in [us], with the fast path `mode` ("on", "off")."""
    phase, q0 = p3_p4(arm)
    plant = KinematicPlant(arm)
    plant.reset(q0)
    ctl = Controller(plant, PinvSolver())
    use_path(mode)
    try:
        log = ctl.run([phase])
    finally:
        use_path(None)
    return 1e6 * ctl.phase_times[phase.name] / len(log)


def median_us(fn: Any, repeat: int) -> float:
    """Median of `repeat` calls of fn, each returning (seconds, count), in [us] per count."""
    fn()
    runs = [fn() for _ in range(repeat)]
    return 1e6 * statistics.median(t / c for t, c in runs)


def loop_rows(name: str, qp: bool = False) -> list[dict[str, Any]]:
    """The compiled arm loop per record (kernel alone; from Python) against the reference loop,
    and the target screen per target against the Python check, on one arm's p3-p4 phase; with
    `qp`, the kernel row alone with the QP controller (`QpSolver`, the default eye's limits)."""
    arm = shipped_arm(name)
    label, many = ARMS[name][0], not quick()
    phase, q0 = p3_p4(arm)
    targets = np.ascontiguousarray(phase.plan(q0))

    def controller() -> Controller:
        plant = KinematicPlant(arm)
        plant.reset(q0)
        ctl = Controller(plant, QpSolver(arm, default_eye(arm)) if qp else PinvSolver())
        ctl.lam = ctl._closest_lambda(q0, targets[0][3:])
        return ctl

    def loop(run: Any) -> tuple[float, int]:
        ctl = controller()
        pid = ctl.log.phase_id(phase.name)
        t = time.perf_counter()
        run(ctl, pid)
        return time.perf_counter() - t, len(ctl.log)

    def reference(ctl: Controller, pid: int) -> None:
        for k, target in enumerate(targets):
            ctl.converge(ctl.solver, target, pid, 0, k)

    def exact(ctl: Controller, pid: int) -> None:
        arm_phase.run_arm_phase_compiled(ctl, ctl.solver, targets, pid, 0)

    ctl = controller()
    setup = arm_phase._Setup(ctl, ctl.solver)
    rec = np.empty((20 * len(targets) + 100, setup.width))
    irec, info = np.empty((rec.shape[0], 2), dtype=np.int64), np.zeros(3, dtype=np.int64)
    head, plant = setup.head(targets), exact_plant()
    kernel, work = fast_cache.algorithm().run_targets, fast_cache.algorithm().work_arrays(len(q0))

    def kernel_run() -> tuple[float, int]:
        s, state = q0.copy(), np.array([ctl.lam, 0.0, 1e-3])
        t = time.perf_counter()
        kernel(*head, 0, 0, s, s.copy(), state, rec, irec, info, setup.fail, plant, work)
        return time.perf_counter() - t, int(info[0])

    ref_us = median_us(lambda: loop(reference), 5 if many else 2)
    if qp:
        return [row(f"{label} p3-p4 QP loop per record, compiled (kernel)",
                    median_us(kernel_run, 51 if many else 5), "us",
                    "rcmplan reference loop, same QP", ref_us)]  # fmt: skip
    target = f"<= {LOOP_FLOOR_US:g} us" if name == "panda" else ""
    free = np.ascontiguousarray(phase.plan(arm.home))

    def screen() -> tuple[float, int]:
        t = time.perf_counter()
        check_arm_targets(arm, free)
        return time.perf_counter() - t, len(free)

    def python_check() -> tuple[float, int]:
        t, seed = time.perf_counter(), None
        for x in free:
            seed = solve_pose(arm, x, seed).q
        return time.perf_counter() - t, len(free)

    return [
        row(f"{label} p3-p4 loop per record, compiled (kernel)",
            median_us(kernel_run, 201 if many else 21), "us", "rcmplan reference loop", ref_us,
            target),
        row(f"{label} p3-p4 loop per record, compiled (from Python, log included)",
            median_us(lambda: loop(exact), 51 if many else 5), "us", "rcmplan reference loop",
            ref_us),
        row(f"{label} target screen per target, compiled Newton IK",
            median_us(screen, 51 if many else 5), "us", "rcmplan solve_pose (Python Newton IK)",
            median_us(python_check, 5 if many else 2), "ratio <= 1"),
    ]  # fmt: skip


def rows() -> list[dict[str, Any]]:
    """The Panda's and the UR5's step rows, their p3-p4 loops (pinv, then the QP) and target
    screens, then the UR5's p3-p4 phase through the controller."""
    ur5 = shipped_arm("ur5")
    phase_us(ur5, "on")  # load the compiled loop and probe the arm (once per robot object)
    loop = row("UR5 p3-p4 phase per record through Controller.run (Controller.phase_times)",
               phase_us(ur5, "on"), "us", "rcmplan reference loop", phase_us(ur5, "off"),
               "ratio <= 1")  # fmt: skip
    arms = ("panda", "ur5")
    return [*arm_rows("panda"), *arm_rows("ur5"), *(r for a in arms for r in loop_rows(a)),
            *(r for a in arms for r in loop_rows(a, qp=True)), loop]  # fmt: skip


if __name__ == "__main__":
    from run import print_table

    print_table(rows())
