"""A sweep's motion settings come from its scenario as inject's and compare's runs do: the RCM
bound, the RCM step tolerance and the [qp] options reach every target's controller and solver;
--robot, --method and --plant, when given, replace the scenario's."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

from rcmplan.cli import sweep as sweep_cli
from rcmplan.control.qp_limits import QpLimits
from rcmplan.exceptions import InvalidInputError
from rcmplan.scene.scenario import load_scenario
from rcmplan.sweep import task
from rcmplan.sweep.sampling import sample_region
from rcmplan.sweep.settings import MotionSettings, Region
from test_sweep_cli import parse

TIGHT = """name = "tight"
[steps]
position_mm = 0.9
angle_mrad = 10.0
[controller]
method = "{method}"
rcm_tolerance_um = 0.05
rcm_bound_um = 20.0
[qp]
travel_margin_mm = 0.3
"""


def scenario_file(folder: Path, method: str = "pinv") -> str:
    path = folder / f"tight-{method}.toml"
    path.write_text(TIGHT.format(method=method))
    return str(path)


def received(monkeypatch: pytest.MonkeyPatch, motion: MotionSettings) -> dict[str, Any]:
    """Run one target of the sweep's task with `motion`; the loop settings its controller
    received, the solver it built, and the result."""
    seen: dict[str, Any] = {}
    real_controller, real_solver = task.Controller, task.make_solver

    def controller(*args: Any, **kwargs: Any) -> Any:
        seen["loop"] = kwargs["settings"]
        return real_controller(*args, **kwargs)

    def make_solver(*args: Any, **kwargs: Any) -> Any:
        seen["solver"] = real_solver(*args, **kwargs)
        return seen["solver"]

    monkeypatch.setattr(task, "Controller", controller)
    monkeypatch.setattr(task, "make_solver", make_solver)
    sample = sample_region(Region(max_angle=math.radians(5), n_targets=2), motion)
    i = int(sample.reachable_ids[0])
    seen["result"] = task.run_target(motion, i, sample.points[i])
    return seen


def test_a_sweep_runs_each_target_with_the_scenarios_rcm_tolerance_and_bound(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    tight = sweep_cli.settings_from_args(parse(["--scenario", scenario_file(tmp_path)])).motion
    assert (tight.rcm_tolerance, tight.rcm_bound) == (pytest.approx(0.05e-6), pytest.approx(20e-6))
    default = sweep_cli.settings_from_args(parse([])).motion
    assert default.rcm_tolerance == load_scenario("default").loop.rcm_tolerance
    assert default.rcm_tolerance != tight.rcm_tolerance
    ran = received(monkeypatch, tight)
    assert ran["loop"].rcm_tolerance == tight.rcm_tolerance
    assert ran["loop"].rcm_bound == tight.rcm_bound
    # The shorter RCM steps move the same target in more iterations with a smaller deviation.
    loose = received(monkeypatch, replace(tight, rcm_tolerance=default.rcm_tolerance))
    assert ran["result"].status == loose["result"].status == "ok"
    assert ran["result"].iterations > loose["result"].iterations
    assert ran["result"].max_rcm_deviation_m < loose["result"].max_rcm_deviation_m


def test_a_sweep_builds_the_qp_with_the_scenarios_qp_options(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    motion = sweep_cli.settings_from_args(parse(["--scenario", scenario_file(tmp_path, "qp")]))
    assert dict(motion.motion.method_options) == {"travel_margin_mm": 0.3}
    solver = received(monkeypatch, motion.motion)["solver"]
    assert solver.limits.travel_margin == pytest.approx(0.3e-3) != QpLimits().travel_margin


def test_options_given_on_the_command_line_replace_the_scenarios_and_keep_its_tolerance(
    tmp_path: Path,
) -> None:
    args = parse(["--scenario", scenario_file(tmp_path), "--method", "dls", "--robot", "ur5"])
    motion = sweep_cli.settings_from_args(args).motion
    assert (motion.method, motion.robot) == ("dls", "ur5")
    assert motion.rcm_tolerance == pytest.approx(0.05e-6)


def test_the_method_options_are_checked_and_stored_sorted_and_hashable() -> None:
    motion = MotionSettings(method_options={"travel_margin_mm": 0.3, "contacts_mm": [[1, 2, 3]]})
    assert motion.method_options == (("contacts_mm", ((1, 2, 3),)), ("travel_margin_mm", 0.3))
    assert hash(motion) == hash(MotionSettings(method_options=motion.method_options))
    with pytest.raises(InvalidInputError, match="qp option"):
        MotionSettings(method_options={"travel_margin_furlongs": 1.0})
