"""rcmplan's QP controller beside a DQ Robotics controller on the same RCM-constrained task.

Run: python benchmarks/bench_qp_peers.py [--states N]   (or python benchmarks/run.py)

The task: the default injection's visits p3 -> p4..p7 -> p3 from the exact p3 pose, 1 ms
period, kinematic plant (`peers/visits.py`). rcmplan runs `Controller` with `make_qp` (its
public path: whatever runner the controller picks, compiled when one applies); the peer is
`peers/dqrobotics_rcm.py` (DQ_SerialManipulatorDH kinematics, DQ line Jacobian RCM rows,
DQ_QuadprogSolver), with limits of the same sizes.

Figures, each measured in this run:
- the control step (kinematics, QP assembly and solve): median over N states sampled evenly
  from each controller's own run, each step timed once (rcmplan: `QpSolver.step`, which builds
  and solves the state's QP and maps the solution to joint steps);
- the loop per iteration: the visit phases' wall time over their records (rcmplan:
  `Controller.phase_times`; the peer: its own loop);
- control iterations, the largest trocar-to-needle-line distance, and the records breaking a
  limit by rcmplan's own counter (`rcmplan.analysis.limits.violations`) for both.
Without dqrobotics (the `bench` extra), or if the peer stops short of a target, its rows say
it was skipped, and why.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import time
from typing import Any

import numpy as np

from _common import quick, row
from peers.visits import Visits, visits
from rcmplan.analysis.limits import violations
from rcmplan.control.log import RunLog
from rcmplan.control.qp import make_qp
from rcmplan.control.targets import rcm_target
from rcmplan.controller import Controller
from rcmplan.sim import KinematicPlant

PEER = "DQ Robotics + quadprog"
KINDS = ("travel", "speed", "lam", "rcm", "retina", "singular")


class Measured:
    """One controller's figures on the task: step times [s] (sampled states), loop time per
    iteration [s], its log (rcmplan's RunLog), and the number of states it was timed on."""

    def __init__(
        self, step_s: np.ndarray, per_iteration_s: float, log: RunLog,
        compiled_s: np.ndarray | None = None,
    ) -> None:  # fmt: skip
        self.step_s, self.per_iteration_s, self.log = step_s, per_iteration_s, log
        self.compiled_s = compiled_s  # rcmplan's compiled step called from Python, or None


def sample(n_records: int, n: int) -> np.ndarray:
    """Up to n record indices spread evenly over the run."""
    return np.unique(np.linspace(0, n_records - 1, min(n, n_records)).astype(int))


def measure_rcmplan(task: Visits, n_states: int) -> Measured:
    """rcmplan's QP through Controller (public path) on the visits, then `QpSolver.step` timed
    on states sampled from that run (a fresh solver: no state is solved twice in a row)."""
    robot, eye = task.robot, task.eye
    plant = KinematicPlant(robot)
    plant.reset(robot.actuators_from_joints(task.q0))
    controller = Controller(plant, make_qp(robot, eye))
    log = controller.run(task.phases)
    per_iteration = sum(controller.phase_times.values()) / len(log)
    solver = make_qp(robot, eye)
    no_error = np.zeros(6)
    times, states = [], []
    for i in sample(len(log), n_states):
        target = rcm_target(log.target_tip[i], log.trocar[i])
        q, lam = log.joints[i], float(log.lam[i])
        t = time.perf_counter()
        solver.step(robot, q, lam, target, no_error)
        times.append(time.perf_counter() - t)
        states.append((q, lam, target))
    return Measured(np.array(times), per_iteration, log, compiled_times(solver, states))


def compiled_times(solver: Any, states: list[Any]) -> np.ndarray | None:
    """Time [s] of rcmplan's compiled QP step called once per state from Python, as the peer's
    step is: `qp_period.period_step` (kinematics, assembly, DAQP's C solve, the RCM box held,
    the joints' step), or None without numba."""
    try:
        from rcmplan.compiled.qp_period import period_step

        step = period_step(solver)
        if step is None:
            raise RuntimeError("the compiled period step does not apply to this solver")
        step(*states[0])  # compile or load the kernels
    except Exception as exc:  # numba or the DAQP binding unavailable: say so, keep the rest
        print(f"bench_qp_peers: compiled QP step skipped: {exc}", file=sys.stderr)
        return None
    times = []
    for q, lam, target in states:
        t = time.perf_counter()
        step(q, lam, target)
        times.append(time.perf_counter() - t)
    return np.array(times)


def measure_dq(task: Visits, n_states: int) -> Measured:
    """The DQ Robotics controller on the visits, then its step timed on sampled states."""
    from peers.dqrobotics_rcm import DqRcmController

    peer = DqRcmController(task.robot, task.eye)
    run = peer.run(task.q0, task.phases)
    log = run.log(task.robot)
    times = []
    for i in sample(len(run), n_states):
        goal = peer.goal(rcm_target(run.target_tip[i], run.trocar[i]))
        t = time.perf_counter()
        peer.step(run.joints[i], goal)
        times.append(time.perf_counter() - t)
    return Measured(np.array(times), run.wall_time / len(run), log)


def dq_missing() -> str | None:
    """Why the DQ Robotics peer cannot run here, or None."""
    for module in ("dqrobotics", "quadprog"):
        if importlib.util.find_spec(module) is None:
            return f"{module} not installed (pip install -e '.[bench]')"
    return None


def limit_text(log: RunLog, task: Visits) -> tuple[int, str]:
    """rcmplan's violation count for a log, and its kinds with the worst excess of each."""
    v = violations(log, task.robot, task.eye)
    parts = [f"{k} {getattr(v, k)} (worst +{1e9 * v.worst[k]:.3g} nm)" for k in KINDS
             if getattr(v, k)]  # fmt: skip
    return v.total, ", ".join(parts) or "none"


def rows(n_states: int = 2000) -> list[dict[str, Any]]:
    """Every figure of rcmplan's QP beside the DQ Robotics peer."""
    names: tuple[str, ...] = ("p4", "p5", "p6", "p7")
    if quick():
        n_states, names = 300, ("p4",)
    task = visits(names)
    where = "visits p3 -> " + "..".join(dict.fromkeys([names[0], names[-1]])) + " -> p3"
    ours = measure_rcmplan(task, n_states)
    missing, peer = dq_missing(), None
    if missing is None:
        try:
            peer = measure_dq(task, n_states)
        except RuntimeError as exc:  # a target not done within its iteration cap
            missing = f"stopped: {exc}"
    if missing:
        print(f"bench_qp_peers: DQ Robotics peer skipped: {missing}", file=sys.stderr)
    label = PEER if peer else f"{PEER}: skipped, {missing}"

    def peer_value(f: Any) -> float | None:
        return None if peer is None else float(f(peer))

    def step(m: Measured) -> float:
        return 1e6 * float(np.median(m.step_s))

    def loop(m: Measured) -> float:
        return 1e6 * m.per_iteration_s

    def rcm(m: Measured) -> float:
        return 1e6 * float(np.nanmax(m.log.line_distance()))

    total, kinds = limit_text(ours.log, task)
    peer_kinds = "" if peer is None else f"; peer: {limit_text(peer.log, task)[1]}"
    out = []
    if ours.compiled_s is not None:
        out.append(row(
            f"QP control step, compiled (qp_period.period_step: kinematics, assembly, DAQP C "
            f"solve, RCM box held, joints' step; one call from Python per state), median of "
            f"{len(ours.compiled_s)} states, {where}",
            1e6 * float(np.median(ours.compiled_s)), "us", label, peer_value(step),
            "<= 30 us, ratio <= 0.33"))  # fmt: skip
    out += [
        row(f"QP control step, reference Python (kinematics + assembly + solve), median of "
            f"{len(ours.step_s)} states, {where}", step(ours), "us", label, peer_value(step)),
        row(f"control loop per iteration, {where}", loop(ours), "us", label, peer_value(loop)),
        row(f"max RCM deviation (trocar to needle line), {where}; bound 0.5 um", rcm(ours),
            "um", label, peer_value(rcm)),
        row(f"control iterations, {where}", len(ours.log), "", label,
            peer_value(lambda m: len(m.log))),
        row(f"records breaking a limit (rcmplan's counter): {kinds}{peer_kinds}", total, "",
            label, peer_value(lambda m: limit_text(m.log, task)[0])),
    ]  # fmt: skip
    out[-1]["ratio"] = None  # counts of violations: no ratio
    return out


def main() -> None:
    """Print the table."""
    from run import print_table

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--states", type=int, default=2000, help="states each step is timed on")
    args = parser.parse_args()
    print_table(rows(args.states))


if __name__ == "__main__":
    main()
