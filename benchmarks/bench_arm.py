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
- Phase per record: the UR5's p3-p4 phase of the default injection from p3 on the kinematic
  plant (`Controller.phase_times`), the compiled arm loop (one compiled call per iteration, the
  plant in Python) against the reference loop.
"""

from __future__ import annotations

import math
from itertools import cycle
from typing import Any

import numpy as np

from _common import per_call, quick, row
from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.arm import FastArm
from rcmplan.control import Controller, PinvSolver, extended_task, rcm_target, solve_pose
from rcmplan.robot.arms import shipped_arm
from rcmplan.robot.library import robot_chain, robot_file
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.scene.procedures import injection
from rcmplan.sim import KinematicPlant

SEED = 20180507
ARMS = {"panda": ("Panda (7 joints)", "panda_link8"), "ur5": ("UR5 (6 joints)", "tool0")}
FLOOR_US = 3.0  # the compiled 7-DOF step from Python, median


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


def phase_us(arm: Any, mode: str) -> float:
    """Time in the p3-p4 phase per record in [us], with the fast path `mode` ("on", "off")."""
    eye = default_eye(arm)
    points = default_points(eye)
    phase = next(ph for ph in injection(arm, eye, points) if ph.name == "p3-p4")
    plant = KinematicPlant(arm)
    plant.reset(solve_pose(arm, rcm_target(points.p3, eye.port)).q)
    ctl = Controller(plant, PinvSolver())
    fast_cache.set_mode(mode)
    try:
        log = ctl.run([phase])
    finally:
        fast_cache.set_mode(None)
    return 1e6 * ctl.phase_times[phase.name] / len(log)


def rows() -> list[dict[str, Any]]:
    """The Panda's and the UR5's rows, then the UR5's p3-p4 phase."""
    ur5 = shipped_arm("ur5")
    phase_us(ur5, "on")  # load the compiled loop and probe the arm (once per robot object)
    loop = row("UR5 p3-p4 phase per record, compiled arm loop", phase_us(ur5, "on"), "us",
               "rcmplan reference loop", phase_us(ur5, "off"), "ratio <= 1")  # fmt: skip
    return [*arm_rows("panda"), *arm_rows("ur5"), loop]


if __name__ == "__main__":
    from run import print_table

    print_table(rows())
