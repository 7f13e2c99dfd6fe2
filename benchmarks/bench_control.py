"""RCM control figures on the kinematic plant, against the thesis's reported figures.

Run alone: python benchmarks/bench_control.py
Each row: figure, value, unit, peer, peer_value, ratio, target.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

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
)
from rcmplan.controller import Controller
from rcmplan.job import run_scenario
from rcmplan.scene.eye import default_eye, default_points
from rcmplan.scene.procedures import Steps, line_targets
from rcmplan.scene.scenario import load_scenario
from rcmplan.sim import KinematicPlant

THESIS_ALIGN_S = 180.0  # "about 3 minutes" for the alignment (section 4.1.2)
THESIS_ALIGN_DEV = 30e-6  # +-30 um x drift
THESIS_MOVE_S = 120.0  # "roughly 2 minutes" for p3 -> p7


def _run(solver: Any, phases: list[Phase], q: np.ndarray, lam: float, drift: bool = True) -> tuple:
    robot = Iramis()
    plant = KinematicPlant(robot)
    plant.reset(robot.actuators_from_joints(q))
    ctl = Controller(plant, solver, settings=LoopSettings(drift_correction=drift))
    ctl.lam = lam
    t0 = time.perf_counter()
    log = ctl.run(phases)
    wall = time.perf_counter() - t0
    dev = float(np.nanmax(np.linalg.norm(log.rcm_deviation(), axis=1)))
    line = float(np.nanmax(log.line_distance()))
    return log, dev, line, wall


def _row(figure: str, value: float, unit: str, peer: str = "", peer_value: float | None = None,
         target: str = "") -> dict[str, Any]:  # fmt: skip
    ratio = None if peer_value in (None, 0) else value / peer_value  # type: ignore[operator]
    return {"figure": figure, "value": value, "unit": unit, "peer": peer,
            "peer_value": peer_value, "ratio": ratio, "target": target}  # fmt: skip


def alignment_rows() -> list[dict[str, Any]]:
    """Fig. 4.2: lambda = 1, phi + 0.0048 rad, psi + 0.212 rad in 500 steps."""
    robot = Iramis()
    x0 = extended_task(robot, robot.home, 1.0)
    phase = Phase("align", interpolate(x0, x0 + np.array([0, 0.0048, 0.212, 0, 0, 0]), 500))
    rows = []
    for solver in (PinvSolver(), DlsSolver()):
        log, dev, _, wall = _run(solver, [phase], robot.home, 1.0)
        n = solver.name
        rows += [
            _row(
                f"alignment {n}: max RCM deviation", dev * 1e6, "um", "thesis pinv", 30.0, "<= 1 um"
            ),
            _row(f"alignment {n}: iterations per step", len(log) / 500, "", "thesis", 1350 / 500),
            _row(f"alignment {n}: wall time", wall, "s", "thesis", THESIS_ALIGN_S),
        ]
    return rows


def retina_move_rows() -> list[dict[str, Any]]:
    """Figs. 4.4, 4.5: p3 -> p7 and p4 -> p6; drift correction on and off."""
    robot = Iramis()
    eye = default_eye(robot)
    pts = default_points(eye)
    rows = []
    for a, b in (("p3", "p7"), ("p4", "p6")):
        pa, pb = pts.as_dict()[a], pts.as_dict()[b]
        pose = solve_pose(robot, rcm_target(pa, eye.port))
        phase = Phase(f"{a}-{b}", line_targets(pa, pb, eye.port, Steps()))
        for drift in (True, False):
            _, dev, line, wall = _run(PinvSolver(), [phase], pose.q, pose.lam, drift)
            tag = f"{a}->{b} pinv, drift correction {'on' if drift else 'off'}"
            rows += [
                _row(f"{tag}: max |p_rcm - trocar|", dev * 1e6, "um", "thesis", 30.0, "<= 1 um"),
                _row(f"{tag}: max trocar-to-needle distance", line * 1e6, "um"),
            ]
        rows.append(_row(f"{a}->{b} pinv: wall time", wall, "s", "thesis p3->p7", THESIS_MOVE_S))
    return rows


def injection_rows() -> list[dict[str, Any]]:
    """The default injection, every method, without plotting."""
    rows = []
    base = load_scenario("default")
    for method in ("pinv", "pinv-thesis", "dls"):
        r = run_scenario(base.with_method(method))
        s = r.summary()
        rows += [
            _row(f"injection {method}: max RCM deviation", s["max_rcm_deviation_m"] * 1e6, "um",
                 target="<= 1 um"),
            _row(f"injection {method}: max tip error", s["max_tip_error_m"] * 1e6, "um",
                 target="<= 1 um"),
            _row(f"injection {method}: wall time", s["wall_time_s"], "s", "thesis, alignment alone",
                 THESIS_ALIGN_S, "< 1 s"),
        ]  # fmt: skip
    return rows


def rows() -> list[dict[str, Any]]:
    """Every control figure."""
    return alignment_rows() + retina_move_rows() + injection_rows()


def main() -> None:
    """Print the rows as a table."""
    for r in rows():
        ratio = "" if r["ratio"] is None else f"{r['ratio']:.3g}"
        peer = "" if r["peer_value"] is None else f"{r['peer']} {r['peer_value']:.4g}"
        head = f"{r['figure']:<62} {r['value']:>12.4g} {r['unit']:<3}"
        print(f"{head} {peer:<30} {ratio:>10} {r['target']}")


if __name__ == "__main__":
    main()
