"""rcmplan against peer libraries on the same iRAM!S chain and the same problems.

Run alone: python benchmarks/bench_peers.py. Needs the `bench` extra (pin,
roboticstoolbox-python). Each row: figure, value, unit, peer, peer_value, ratio, target.
- FK + Jacobian: the rcmplan control step (X_ext, J_a and the 6x6 solve) against pinocchio's
  computeFrameJacobian + updateFramePlacement on a Model built from `Iramis().dh_links()`.
- RCM point solve: X_ext(q0..q4, lambda) = target from the same start (tips within 1 mm of
  a point 8 mm inside the trocar), rcmplan's compiled Algorithm 1 (Newton on J_a, through the
  sliders) against scipy least_squares(method="lm") given the compiled residual and Jacobian;
  both to |error| <= 1e-8 per component. Two settings of Algorithm 1, each named in its row:
  steps as Newton gives them (LoopSettings(rcm_tolerance=None), as LM takes them: the like-for-
  like solve), and each step shortened to leave the needle within the controller's default
  RCM tolerance of the trocar (LoopSettings().rcm_tolerance, 0.8 um: a controller's path, so
  many more iterations per target, with the iteration cap of the row). Rows of iterations per
  target beside the times: Algorithm 1's Newton steps, LM's Jacobian evaluations.
- Tip IK (3 equations, 5 joints): rcmplan's compiled tip-pseudoinverse loop against
  roboticstoolbox's ETS.ikine_LM and the C++ ETS.ik_LM, position-only mask; goals are tips of
  random joints within 3 mm and 0.1 rad of home (all within slider travel), start at home.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from _common import per_call, quick, row
from rcmplan import Iramis
from rcmplan.compiled import cache as fast_cache
from rcmplan.compiled.records import FAIL_WIDTH, robot_params
from rcmplan.compiled.runner import FastIramis
from rcmplan.control import extended_task, rcm_target, solve_pose
from rcmplan.control.phase import LoopSettings
from rcmplan.scene.eye import default_eye
from rcmplan.sim.mujoco.compiled import exact_plant

SEED = 20180507


def pinocchio_chain(robot: Iramis) -> tuple[Any, Any, int]:
    """(model, data, tip frame id): joint i placed by the constant part of DH link i - 1."""
    import pinocchio as pin

    model, parent, placement = pin.Model(), 0, pin.SE3.Identity()
    for i, lk in enumerate(robot.dh_links()):
        joint = pin.JointModelRZ() if lk.joint == "revolute" else pin.JointModelPZ()
        parent = model.addJoint(parent, joint, placement, f"q{i}")
        model.appendBodyToJoint(parent, pin.Inertia.Random(), pin.SE3.Identity())
        Rz = pin.SE3(pin.utils.rotate("z", lk.theta), np.zeros(3))
        Tz = pin.SE3(np.eye(3), np.array([0.0, 0.0, lk.d]))
        Tx = pin.SE3(np.eye(3), np.array([lk.a, 0.0, 0.0]))
        Rx = pin.SE3(pin.utils.rotate("x", lk.alpha), np.zeros(3))
        placement = Rz * Tz * Tx * Rx  # Rz(q) and Tz(q) commute with Rz(theta) Tz(d)
    fid = model.addFrame(pin.Frame("tip", parent, 0, placement, pin.FrameType.OP_FRAME))
    return model, model.createData(), fid


def pinocchio_rows() -> list[dict[str, Any]]:
    import pinocchio as pin

    robot, fast = Iramis(), FastIramis()
    model, data, fid = pinocchio_chain(robot)
    rng = np.random.default_rng(SEED)
    for q in rng.uniform(-1.0, 1.0, (50, 6)) * 0.5:
        pin.framesForwardKinematics(model, data, q)
        err = np.abs(data.oMf[fid].homogeneous - robot.forward_kinematics(q)).max()
        J = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)
        err = max(err, np.abs(J - robot.jacobian(q)).max())
        if err > 1e-12:
            raise RuntimeError(f"the pinocchio chain differs from Iramis by {err:.3g}")
    q = rng.uniform(-0.5, 0.5, 6)
    target, K, out = extended_task(robot, q + 1e-3, 0.5), np.ones(6), np.empty(6)
    n = 2000 if quick() else 20000
    ours = per_call(lambda: fast.step(q, 0.4, target, K, "exact", out), n)

    def peer() -> None:
        pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)
        pin.updateFramePlacement(model, data, fid)

    theirs = per_call(peer, n)
    return [
        row("FK + Jacobian from Python: rcmplan control step", 1e6 * ours, "us",
            "pinocchio FK + frame Jacobian", 1e6 * theirs, "ratio <= 1"),
    ]  # fmt: skip


def rcm_problems(robot: Iramis, n: int) -> tuple[np.ndarray, list[np.ndarray]]:
    """A start pose on the trocar axis and n RCM targets (tip points around it), RCM at trocar."""
    eye = default_eye(robot)
    start = solve_pose(robot, rcm_target(eye.port + 8e-3 * eye.axis, eye.port))
    rng = np.random.default_rng(SEED)
    tips = eye.port + 8e-3 * eye.axis + rng.uniform(-1e-3, 1e-3, (n, 3))
    return np.array([*start.q[:5], start.lam]), [rcm_target(t, eye.port) for t in tips]


class CompiledSolve:
    """Algorithm 1 on one target from x0 = (q0..q4, lambda), buffers allocated once.

    Args:
        method: 0 for the J_a pseudoinverse (RCM targets (6,)), 3 for the tip (points (3,)).
        rcm_tolerance: The step bound [m] (`LoopSettings.rcm_tolerance`); None: unbounded.
        max_iterations: Iteration cap per target (`LoopSettings.max_iterations`).
    """

    def __init__(
        self, robot: Iramis, method: int, x0: np.ndarray, rcm_tolerance: float | None = None,
        max_iterations: int = 100,
    ) -> None:  # fmt: skip
        self.run, self.plant = fast_cache.algorithm().run_targets, exact_plant()
        self.s0 = robot.actuators_from_joints(np.array([*x0[:5], 0.0]))
        self.state0 = np.array([x0[5], 0.0, 1e-3])
        self.rec = np.empty((max_iterations + 1, 35))
        self.irec = np.empty((max_iterations + 1, 2), dtype=np.int64)
        self.info, self.fail = np.zeros(3, dtype=np.int64), np.empty(FAIL_WIDTH)
        tol = np.full(6, 1e-8)
        bounds = np.array([0.1, rcm_tolerance or 0.0])  # singular floor; step bound (0: none)
        self.args = (robot_params(robot), None, method, np.ones(6), 0.0, tol, max_iterations,
                     method != 3, bounds, None, None)  # fmt: skip

    def __call__(self, target: np.ndarray) -> int:
        """Solve; returns the iterations (raises if the loop stopped early)."""
        status = self.run(*self.args, target, 0, 0, self.s0.copy(), np.empty(6),
                          self.state0.copy(), self.rec, self.irec, self.info, self.fail,
                          self.plant)  # fmt: skip
        if status != 0:
            raise RuntimeError(f"compiled solve stopped with status {status}")
        return int(self.info[0])


BOUNDED_CAP = 5000  # iterations per target allowed to the step-bounded solve


def scipy_rows() -> list[dict[str, Any]]:
    from scipy.optimize import least_squares

    robot, fast = Iramis(), FastIramis()
    x0, targets = rcm_problems(robot, 10 if quick() else 50)

    def residual(x: np.ndarray, t: np.ndarray) -> np.ndarray:
        return fast.task(np.array([*x[:5], 0.0]), x[5]) - t

    def jac(x: np.ndarray, t: np.ndarray) -> np.ndarray:
        return fast.augmented_jacobian(np.array([*x[:5], 0.0]), x[5])

    bound = LoopSettings().rcm_tolerance
    free, bounded = CompiledSolve(robot, 0, x0), CompiledSolve(robot, 0, x0, bound, BOUNDED_CAP)
    times: dict[str, list[float]] = {"free": [], "bounded": [], "lm": []}
    iters: dict[str, list[int]] = {"free": [], "bounded": [], "lm": []}
    worst = 0.0
    for t in targets:
        t2 = np.ascontiguousarray(t[None, :])
        for name, solve, n in (("free", free, 50), ("bounded", bounded, 3)):
            iters[name].append(solve(t2))
            times[name].append(per_call(lambda t2=t2, solve=solve: solve(t2), n, 3))
        kw = {"method": "lm", "jac": jac, "args": (t,), "xtol": 1e-15, "ftol": 1e-15}
        times["lm"].append(per_call(lambda t=t, kw=kw: least_squares(residual, x0, **kw), 3, 3))
        sol = least_squares(residual, x0, **kw)
        worst = max(worst, float(np.abs(sol.fun).max()))
        iters["lm"].append(int(sol.njev))
    if worst > 1e-8:
        raise RuntimeError(f"scipy LM stopped at |error| = {worst:.3g}")
    us = {k: 1e6 * float(np.median(v)) for k, v in times.items()}
    it = {k: float(np.median(v)) for k, v in iters.items()}
    n, lm = len(targets), "scipy least_squares lm"
    steps = f"each step within {1e6 * bound:g} um RCM (LoopSettings default), cap {BOUNDED_CAP}"
    return [
        row(f"RCM point solve to 1e-8, compiled Algorithm 1, steps unbounded "
            f"(rcm_tolerance=None), median of {n}", us["free"], "us", lm, us["lm"], "ratio <= 1"),
        row("  same: iterations (Newton steps / LM Jacobians), median", it["free"], "",
            lm, it["lm"]),
        row(f"RCM point solve to 1e-8, compiled Algorithm 1, {steps}, median of {n}",
            us["bounded"], "us", lm, us["lm"]),
        row("  same: iterations (Newton steps / LM Jacobians), median", it["bounded"], "",
            lm, it["lm"]),
    ]  # fmt: skip


def rtb_rows() -> list[dict[str, Any]]:
    import roboticstoolbox as rtb

    robot = Iramis()
    links = [
        rtb.RevoluteDH(d=lk.d, a=lk.a, alpha=lk.alpha, offset=lk.theta)
        if lk.joint == "revolute"
        else rtb.PrismaticDH(theta=lk.theta, a=lk.a, alpha=lk.alpha, offset=lk.d, qlim=[-1, 1])
        for lk in robot.dh_links()
    ]
    ets = rtb.DHRobot(links, name="iRAM!S").ets()
    rng = np.random.default_rng(SEED)
    q0 = np.zeros(6)
    goals = rng.uniform(-1.0, 1.0, (10 if quick() else 50, 6)) * [0.003, 0.1, 0.003, 0.1, 0.003, 0]
    if np.abs(ets.fkine(goals[0]).A - robot.forward_kinematics(goals[0])).max() > 1e-12:
        raise RuntimeError("the roboticstoolbox chain differs from Iramis")
    mask = np.array([1.0, 1, 1, 0, 0, 0])
    solve, ours, lm, ik = CompiledSolve(robot, 3, np.zeros(6)), [], [], []
    for g in goals:
        T = robot.forward_kinematics(g)
        tip = np.ascontiguousarray(T[None, :3, 3])
        ours.append(per_call(lambda tip=tip: solve(tip), 50, 3))
        kw = {"q0": q0, "mask": mask, "tol": 1e-17, "joint_limits": False, "slimit": 1}
        lm.append(per_call(lambda T=T, kw=kw: ets.ikine_LM(T, **kw), 3, 3))
        ik.append(per_call(lambda T=T, kw=kw: ets.ik_LM(T, **kw), 20, 3))
        for sol in (ets.ikine_LM(T, **kw), ets.ik_LM(T, **kw)):
            if not sol[1] if isinstance(sol, tuple) else not sol.success:
                raise RuntimeError("roboticstoolbox did not converge")
    med = 1e6 * float(np.median(ours))
    return [
        row("tip IK to 1e-8 m (compiled tip pseudoinverse), median", med, "us",
            "rtb ETS.ikine_LM", 1e6 * float(np.median(lm)), "ratio <= 1"),
        row("tip IK to 1e-8 m (compiled tip pseudoinverse), median", med, "us",
            "rtb ETS.ik_LM (C++)", 1e6 * float(np.median(ik)), "ratio <= 1"),
    ]  # fmt: skip


def rows() -> list[dict[str, Any]]:
    """Every peer comparison; a missing peer gives a row saying so."""
    out = []
    for name, fn in (("pinocchio", pinocchio_rows), ("scipy", scipy_rows), ("rtb", rtb_rows)):
        try:
            out += fn()
        except ImportError as exc:
            out.append(row(f"{name}: not installed ({exc.name}); pip install 'rcmplan[bench]'",
                           math.nan, ""))  # fmt: skip
    return out


if __name__ == "__main__":
    from run import print_table

    print_table(rows())
