"""summary.json says which code moved the robot in each phase, from what ran, not from what
the configuration suggests."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from rcmplan.job import execution_paths, run_scenario
from rcmplan.scene.scenario import load_scenario

from paths import use_path


@pytest.fixture(autouse=True)
def mode_restored() -> Iterator[None]:
    yield
    use_path(None)


def summary(mode: str, method: str = "pinv") -> dict:
    use_path(mode)
    result = run_scenario(load_scenario("default").with_method(method))
    assert result.ok, result.message
    return result.summary()


def test_the_reference_path_says_so() -> None:
    s = summary("off")
    assert s["execution_path"] == "reference"
    assert s["compiled_phases"] == []


def test_the_compiled_path_names_every_phase_it_ran() -> None:
    pytest.importorskip("numba")
    s = summary("on")
    assert s["execution_path"] == "compiled"
    assert s["compiled_phases"] == [p["name"] for p in s["phases"]]


def test_the_qp_runs_every_phase_compiled_its_free_steps_too() -> None:
    pytest.importorskip("numba")
    s = summary("on", "qp")
    assert s["execution_path"] == "compiled"
    assert s["compiled_phases"] == [p["name"] for p in s["phases"]]


def test_free_phases_without_a_kernel_make_the_run_mixed() -> None:
    pytest.importorskip("numba")
    from rcmplan import Iramis
    from rcmplan.control import PinvSolver
    from rcmplan.control.limited_tip import LimitedTipSolver
    from rcmplan.controller import Controller
    from rcmplan.scene.eye import default_eye, default_points
    from rcmplan.scene.procedures import injection
    from rcmplan.sim import KinematicPlant

    use_path("on")
    robot = Iramis()
    eye = default_eye(robot)

    class OwnTip(LimitedTipSolver):
        """A user's own free-space solver: no compiled kernel (solvers are matched by type)."""

    free = OwnTip(tip_speed=0.01)
    ctl = Controller(KinematicPlant(robot), PinvSolver(), free)
    ctl.run(injection(robot, eye, default_points(eye)))
    assert ctl.phase_paths["approach"] == "reference" and ctl.phase_paths["p3-p4"] == "compiled"
    assert execution_paths(ctl.phase_paths)["execution_path"] == "mixed"


@pytest.mark.parametrize(
    ("paths", "overall"),
    [({}, "reference"), ({"a": "compiled"}, "compiled"), ({"a": "reference"}, "reference"),
     ({"a": "compiled", "b": "reference"}, "mixed"), ({"a": "mixed"}, "mixed")],
)  # fmt: skip
def test_the_overall_path_follows_the_phases(paths: dict[str, str], overall: str) -> None:
    assert execution_paths(paths)["execution_path"] == overall


def test_a_run_stopped_inside_compiled_code_names_the_phase_it_stopped_in() -> None:
    pytest.importorskip("numba")
    from dataclasses import replace

    use_path("on")
    scenario = load_scenario("default")
    scenario = replace(scenario, loop=replace(scenario.loop, max_iterations=1))
    s = run_scenario(scenario).summary()
    assert s["status"] == "no_convergence" and "phase 'align'" in s["message"]
    assert s["compiled_phases"] == ["approach", "align"] and s["execution_path"] == "compiled"
