"""The QP holds its retina margin on the true kinematics, as it holds its RCM box
(`rcm_step.retina_lift`): a grazing path on an arm whose linearised barrier let each step's
second-order part carry the tip past the margin."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from rcmplan.analysis.limits import excess, violations
from rcmplan.control.qp import QpSolver
from rcmplan.controller import Controller
from rcmplan.robot.registry import make_robot
from rcmplan.scene.scenario import load_scenario
from rcmplan.sim import KinematicPlant

from logcheck import assert_same_log
from paths import use_path

# The Kinova Jaco 2 with its needle along the flange's z (the home its search chose): riding
# the margin of the grazing spiral, each QP step's second-order part took the tip past it, in
# 109 records of the compiled run and the reference's alike, before the hold.
JACO_Z = """[robot]
name = "jaco-z"
urdf = "package://example-robot-data/kinova_description/robots/kinova.urdf"
flange = "j2s6s200_end_effector"
home = [0.43072220572976727, 2.1257375254510467, 4.8215351907011925, 0.5411800607078334,
        1.0471975511962002, 1.7967668521241829]
"""
RUN_TOL = 1e-11  # [m], [rad]: the compiled-path tests' tolerance


@pytest.fixture(scope="module")
def grazing(tmp_path_factory: pytest.TempPathFactory) -> tuple:
    path = Path(tmp_path_factory.mktemp("robot")) / "jaco-z.toml"
    path.write_text(JACO_Z)
    scenario = load_scenario("grazing-spiral")
    robot = make_robot(str(path))
    eye = scenario.eye(robot)
    phases = scenario.phases(robot)
    return robot, eye, phases[: [p.name for p in phases].index("spiral") + 1]


def run(grazing: tuple, mode: str) -> tuple:
    robot, eye, phases = grazing
    use_path(mode)
    try:
        solver = QpSolver(robot, eye)
        ctl = Controller(KinematicPlant(robot), solver)
        return ctl.run(phases), ctl, solver
    finally:
        use_path(None)


def test_the_qp_holds_the_retina_margin_on_a_grazing_spiral_on_both_paths(grazing: tuple) -> None:
    (ref_log, ref, solver), (log, fast, _) = run(grazing, "off"), run(grazing, "on")
    assert set(ref.phase_paths.values()) == {"reference"}
    assert set(fast.phase_paths.values()) == {"compiled"}
    assert_same_log(ref_log, log, RUN_TOL, nonempty=True)
    robot, eye, _ = grazing
    found = violations(log, robot, eye, solver.limits)
    assert found.retina == 0 and found.total == 0, found.counts
    # The spiral rides the margin: without the tries the tip passed it by more than the
    # check's 10 nm slack, here it stays within it.
    past = excess(log, robot, eye, solver.limits, solver.dt)["retina"]  # -inf: not checked
    assert np.count_nonzero(past > -1e-6) > 100  # records within 1 um of the margin
    assert past.max() <= 1e-8
