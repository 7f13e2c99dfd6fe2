"""The DQ Robotics peer of the QP benchmark (benchmarks/peers/dqrobotics_rcm.py): its model is
the iRAM!S kinematics, its RCM and retina rows are exact first-order models, and on a visit it
holds the limits it states."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from rcmplan.analysis.limits import violations

from fd import fd_jacobian

for _module in ("dqrobotics", "quadprog"):
    pytest.importorskip(_module, reason=f"the DQ Robotics peer needs {_module} (dev extra)")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from peers.dqrobotics_rcm import DqRcmController, trocar_moment  # noqa: E402
from peers.visits import Visits, visits  # noqa: E402


@pytest.fixture(scope="module")
def task() -> Visits:
    return visits(("p4",))


def random_states(task: Visits, rng: np.random.Generator, n: int = 5) -> np.ndarray:
    """Joints near the p3 pose (within 2 mm and 0.1 rad), roll included."""
    q = np.tile(task.q0, (n, 1))
    q += rng.uniform(-1.0, 1.0, (n, 6)) * [2e-3, 0.1, 2e-3, 0.1, 2e-3, 0.5]
    return q


def test_dq_model_is_the_iramis_kinematics(task: Visits, rng: np.random.Generator) -> None:
    """The DH model built for DQ Robotics puts the tip and needle axis where Iramis does, and
    its translation Jacobian is Iramis's tip Jacobian."""
    robot = task.robot
    peer = DqRcmController(robot, task.eye)
    for q in random_states(task, rng):
        needle = peer.needle(q)
        np.testing.assert_allclose(needle.tip, robot.tip(q), atol=1e-15)
        np.testing.assert_allclose(needle.axis, robot.needle_axis(q), atol=1e-15)
        np.testing.assert_allclose(needle.Jt[1:4, :5], robot.tip_jacobian(q)[:, :5], atol=1e-14)


def test_trocar_moment_is_the_line_distance_and_its_jacobian_matches_fd(
    task: Visits, rng: np.random.Generator
) -> None:
    """|m_c| is the trocar's distance to the needle line, and d m_c / d(q0..q4) from DQ's line
    Jacobian matches finite differences of (tip - c) x axis computed by Iramis."""
    robot = task.robot
    peer = DqRcmController(robot, task.eye)
    c = task.eye.port + np.array([3e-6, -2e-6, 1e-6])  # off the line at every state

    def moment(q5: np.ndarray, roll: float) -> np.ndarray:
        q = np.append(q5, roll)
        return np.cross(robot.tip(q) - c, robot.needle_axis(q))

    for q in random_states(task, rng):
        needle = peer.needle(q)
        m_c, J = trocar_moment(needle.Jl, needle.line, needle.axis, c)
        base, tip = robot.needle_base(q), robot.tip(q)
        u = (tip - base) / np.linalg.norm(tip - base)
        d = (c - base) - np.dot(c - base, u) * u
        assert abs(np.linalg.norm(m_c) - np.linalg.norm(d)) < 1e-15
        np.testing.assert_allclose(m_c, moment(q[:5], q[5]), atol=1e-15)
        np.testing.assert_allclose(J, fd_jacobian(lambda x, r=q[5]: moment(x, r), q[:5]),
                                   atol=1e-9)  # fmt: skip


def test_the_peer_holds_its_limits_on_a_visit(task: Visits) -> None:
    """p3 -> p4 -> p3: every target done, the RCM within 0.5 um (plus rcmplan's first-order
    slack), no travel, retina, lambda or singular violation by rcmplan's counter; the slider
    steps exceed 10 um only by the second-order term of the linear ds/dq map (below 0.1 nm)."""
    peer = DqRcmController(task.robot, task.eye)
    run = peer.run(task.q0, task.phases)
    log = run.log(task.robot)
    assert len(run) > 1000
    v = violations(log, task.robot, task.eye)
    assert (v.travel, v.lam, v.rcm, v.retina, v.singular) == (0, 0, 0, 0, 0)
    assert np.max(log.line_distance()) < 0.5e-6 + 1e-8
    assert v.worst["speed"] < 1e-10
    # the last target of each phase is reached: p4 on the retina, then p3
    for k, phase in enumerate(task.phases):
        last = np.flatnonzero(run.phase == k)[-1]
        goal = peer.goal(phase.targets[-1])
        np.testing.assert_allclose(log.tip[last], goal.tip, atol=1e-7)
