"""Why the thesis settings do not reproduce the thesis's behaviour: four measured experiments.

Run: python benchmarks/thesis_study.py   (kinematic plant, reference Python loop; about 1 min)

1. Step count: the pivot alignment (fig. 4.2) with the thesis setting at 250 to 1000 steps.
   On an exact model the RCM deviation is the linearisation residual of each step, so it falls
   with the square of the step size.
2. Gain scale: K = c * diag(1, 10, 12, 1, 2, 2) for several c with the thesis's tolerance
   0.0002 (m and rad alike): iterations per step and RCM deviation.
3. Model mismatch: the controller's Jacobian from thesis Table 2.1, the plant (standing in for
   the V-REP CAD model) with l5 and l6 off by a given amount; deviations measured on the plant.
4. The DLS spiral (fig. 4.7) with D = 0.1: the deviation at the end of each control step
   (what a loop that samples converged poses records) against the largest within the step.

Results, with the command and machine, are in docs/thesis.md.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from rcmplan import Iramis, IramisParameters
from rcmplan._validate import FloatArray
from rcmplan.analysis import thesis
from rcmplan.analysis.plots import step_starts
from rcmplan.control.augmented import extended_task
from rcmplan.control.log import RunLog
from rcmplan.control.phase import LoopSettings, Phase, interpolate
from rcmplan.control.solvers import DlsSolver, PinvSolver, Tolerance
from rcmplan.control.targets import pivot_target, solve_pose
from rcmplan.controller import Controller
from rcmplan.exceptions import RcmplanError
from rcmplan.robot.needle import angles_from_axis
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.scene.procedures import Spiral, Steps, spiral
from rcmplan.sim.kinematic import KinematicPlant

UM = 1e6
THESIS_K = np.array([1.0, 10.0, 12.0, 1.0, 2.0, 2.0])
NOMINAL = Iramis()


class ModelSolver(PinvSolver):
    """The thesis's pseudoinverse step computed on the nominal model, whatever the plant is."""

    def step(self, robot: Iramis, q: FloatArray, lam: float, target: FloatArray,
             error: FloatArray) -> tuple[FloatArray, float]:  # fmt: skip
        return super().step(NOMINAL, q, lam, target, error)


def pivot(scale: float, steps: int = 500, plant_robot: Iramis = NOMINAL) -> RunLog:
    """Fig. 4.2: lambda = 1, phi + 0.0048 rad and psi + 0.212 rad, thesis J_a and tolerance."""
    q = NOMINAL.home
    x0 = extended_task(plant_robot, q, 1.0)
    x1 = x0 + np.array([0.0, 0.0048, 0.212, 0.0, 0.0, 0.0])
    plant = KinematicPlant(plant_robot)
    plant.reset(plant_robot.actuators_from_joints(q))
    solver = ModelSolver(K=tuple(scale * THESIS_K), variant="thesis", tol=thesis.THESIS_TOL)
    ctl = Controller(plant, solver, settings=LoopSettings(2000, drift_correction=False))
    ctl.lam = 1.0
    try:
        return ctl.run([Phase("align", interpolate(x0, x1, steps))])
    except RcmplanError as exc:
        return exc.log  # type: ignore[no-any-return]


def deviation_um(log: RunLog) -> FloatArray:
    """Largest |p_rcm - trocar| per base-frame axis (x, y, z) in um."""
    return np.asarray(np.nanmax(np.abs(log.rcm_deviation()), axis=0) * UM)


def line(label: str, log: RunLog, steps: int) -> str:
    x, y, z = deviation_um(log)
    return f"{label:<34} {len(log) / steps:>6.2f}   {x:>9.3g} {y:>9.3g} {z:>9.3g}"


def main() -> None:
    """Print the four experiments."""
    # the model-mismatch solver is a subclass: the compiled runner declines it
    head = f"{'':<34} {'it/step':>6}   {'x [um]':>9} {'y [um]':>9} {'z [um]':>9}"
    print("1. step count (thesis setting, c = 1/12)\n" + head)
    for n in (250, 500, 1000):
        print(line(f"{n} steps", pivot(1 / 12, n), n))
    print("\n2. gain scale c, K = c * diag(1, 10, 12, 1, 2, 2), 500 steps\n" + head)
    for c in (1 / 8, 1 / 12, 0.04, 0.03, 0.02):
        print(line(f"c = {c:.3g}", pivot(c), 500))
    print("\n3. plant's l5 and l6 off Table 2.1 (controller keeps Table 2.1), c = 0.03\n" + head)
    p = IramisParameters()
    for off_mm in (0.0, 1.0, 2.0, 5.0):
        d = off_mm * 1e-3
        plant_robot = Iramis(dataclasses.replace(p, l5=p.l5 - d, l6=p.l6 + d))
        print(line(f"l5 - {off_mm:g} mm, l6 + {off_mm:g} mm", pivot(0.03, 500, plant_robot), 500))
    print("\n4. DLS spiral from p3, tolerance 0.1 mm, damping D [m]")
    print(f"{'':<12} {'it/step':>7} {'max in a step [um]':>19} {'max at step ends [um]':>22}")
    for damping in (0.1, 0.03, 0.01, 0.003):
        log, steps = dls_spiral(damping)
        norm = np.linalg.norm(log.rcm_deviation(), axis=1) * UM
        _, ends = step_starts(log)
        print(
            f"D = {damping:<8g} {len(log) / steps:>7.2f} {np.nanmax(norm):>19.4g} "
            f"{np.nanmax(norm[ends]):>22.4g}"
        )


def dls_spiral(damping: float) -> tuple[RunLog, int]:
    """Fig. 4.6/4.7 as `rcmplan.analysis.thesis.dls_spiral` runs it, with another damping."""
    eye = default_eye(NOMINAL)
    phases = spiral(NOMINAL, eye, default_points(eye), Spiral(), Steps())[2:]
    start = solve_pose(NOMINAL, pivot_target(eye.port[0], *angles_from_axis(eye.axis), eye.port))
    plant = KinematicPlant(NOMINAL)
    plant.reset(NOMINAL.actuators_from_joints(start.q))
    ctl = Controller(plant, DlsSolver(damping, Tolerance(1e-4, 1e-4)),
                     settings=LoopSettings(2000, drift_correction=True))  # fmt: skip
    ctl.lam = 1.0
    log = ctl.run(phases)
    inside = np.all(np.isfinite(log.trocar), axis=1)
    return log.select(inside), len(step_starts(log.select(inside))[0])


if __name__ == "__main__":
    main()
