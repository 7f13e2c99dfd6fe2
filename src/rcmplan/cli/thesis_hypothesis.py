"""A reading of the thesis's V-REP setup that reproduces its chapter 4 figures (docs/thesis.md).

- Pivot and p3 -> p7: K = 0.03 diag(1, 10, 12, 1, 2, 2) (about 3 iterations per step, the
  thesis's 1350 points for 500 steps), the thesis's J_a, tolerance 0.0002 and no drift
  correction, computed on Table 2.1 while the robot it drives (standing in for V-REP's CAD
  model) has l5 5 mm shorter and l6 5 mm longer. The RCM is measured on the driven robot, as
  V-REP measured it.
- DLS spiral: D = 0.003 m with the 0.1 mm tolerance (V-REP's damping 0.1 read in another scale).

Neither the V-REP model's dimensions nor V-REP's damping scale is given in the thesis; this is
a consistent reading, not a confirmed one. The model-mismatch runs use the reference Python
loop (the compiled loop computes its steps on the plant's own model).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from rcmplan._validate import FloatArray
from rcmplan.analysis import thesis
from rcmplan.analysis.metrics import overall, phase_metrics
from rcmplan.control.augmented import extended_task
from rcmplan.control.phase import LoopSettings, Phase, interpolate
from rcmplan.control.solvers import DlsSolver, PinvSolver, Solver, Tolerance
from rcmplan.control.targets import pivot_target, rcm_target, solve_pose
from rcmplan.controller import Controller
from rcmplan.exceptions import RcmplanError
from rcmplan.robot.iramis import Iramis
from rcmplan.robot.model import RobotModel
from rcmplan.robot.needle import angles_from_axis
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.scene.procedures import Spiral, Steps, line_targets, spiral
from rcmplan.sim.kinematic import KinematicPlant

GAIN = tuple(0.03 * k for k in (1.0, 10.0, 12.0, 1.0, 2.0, 2.0))
MODEL_ERROR_M = 5e-3
SPIRAL_DAMPING_M = 0.003


class TableSolver(PinvSolver):
    """The thesis's pseudoinverse step computed on Table 2.1, whatever robot it drives."""

    def step(self, robot: RobotModel, q: FloatArray, lam: float, target: FloatArray,
             error: FloatArray) -> tuple[FloatArray, float]:  # fmt: skip
        return super().step(Iramis(), q, lam, target, error)


def driven_robot() -> Iramis:
    """The robot the controller drives: Table 2.1 with l5 - 5 mm and l6 + 5 mm."""
    p = Iramis().params
    return Iramis(dataclasses.replace(p, l5=p.l5 - MODEL_ERROR_M, l6=p.l6 + MODEL_ERROR_M))


def run(name: str, robot: Iramis, solver: Solver, phases: list[Phase], q: FloatArray,
        lam: float, drift: bool) -> thesis.Outcome:  # fmt: skip
    """One run on a kinematic plant of `robot`, reference loop, measured like the thesis's."""
    plant = KinematicPlant(robot)
    plant.reset(robot.actuators_from_joints(q))
    ctl = Controller(
        plant,
        solver,
        settings=LoopSettings(2000, drift_correction=drift, rcm_bound=None, rcm_tolerance=None),
    )
    ctl.lam = lam
    start, status = time.perf_counter(), "ok"
    try:  # TableSolver is a subclass: the compiled runner declines it, the Python loop runs
        log = ctl.run(phases)
    except RcmplanError as exc:
        log, status = exc.log, f"{type(exc).__name__}: {exc}"
    wall = time.perf_counter() - start
    rcm = [p for p in phase_metrics(log) if p.inside_eye]
    dev = overall(rcm)["max_rcm_deviation_m"]
    its, steps = sum(p.iterations for p in rcm), sum(p.steps for p in rcm)
    return thesis.Outcome(name, "hypothesis", status, dev, its, steps, wall, log)


def pivot() -> thesis.Outcome:
    """Fig. 4.2 on the driven robot: phi + 0.0048 rad, psi + 0.212 rad in 500 steps."""
    robot = driven_robot()
    q = robot.home
    x0 = extended_task(robot, q, 1.0)
    x1 = x0 + np.array([0.0, 0.0048, 0.212, 0.0, 0.0, 0.0])
    solver = TableSolver(K=GAIN, variant="thesis", tol=thesis.THESIS_TOL)
    return run("pivot", robot, solver, [Phase("align", interpolate(x0, x1, 500))], q, 1.0, False)


def move_p3_p7() -> thesis.Outcome:
    """Figs. 4.4, 4.5 on the driven robot, its eye placed where its own needle is."""
    robot = driven_robot()
    eye = default_eye(robot)
    pts = default_points(eye)
    pose = solve_pose(robot, rcm_target(pts.p3, eye.port))
    solver = TableSolver(K=GAIN, variant="thesis", tol=thesis.THESIS_TOL)
    phases = [Phase("p3-p7", line_targets(pts.p3, pts.p7, eye.port, Steps()))]
    return run("p3-p7", robot, solver, phases, pose.q, pose.lam, False)


def dls_spiral() -> thesis.Outcome:
    """Figs. 4.6, 4.7: the thesis experiment's spiral phases from its start pose, with
    D = 0.003 m and the 0.1 mm tolerance."""
    robot = Iramis()
    eye = default_eye(robot)
    phases = spiral(robot, eye, default_points(eye), Spiral(), Steps())[2:]
    start = solve_pose(robot, pivot_target(eye.port[0], *angles_from_axis(eye.axis), eye.port))
    solver = DlsSolver(SPIRAL_DAMPING_M, Tolerance(1e-4, 1e-4))
    return run("spiral", robot, solver, phases, start.q, 1.0, True)


EXPERIMENTS = {"pivot": pivot, "p3-p7": move_p3_p7, "spiral": dls_spiral}
