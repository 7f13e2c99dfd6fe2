"""One command surface: every run command has the shared options it must have, each made by
its one helper in `rcmplan.cli.common` (same type, choices, metavar and default rule), and
every run command writes the same layout (summary.json, the log, figures/)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import pytest

from rcmplan.cli import build_parser, command_parsers, main
from rcmplan.cli.common import robot_arg
from rcmplan.control.methods import METHODS
from rcmplan.sim.registry import PLANTS

SHARED = frozenset({"scenario", "robot", "method", "plant", "out", "json", "no_plots"})
# The shared options each run command has; what one leaves out, and why.
RUN_COMMANDS = {
    "inject": SHARED,
    "spiral": SHARED,
    "compare": SHARED,
    "sweep": SHARED,
    "teleop": SHARED - {"method"},  # the QP step at every 1 kHz period is the session
    "subretinal": SHARED - {"scenario", "method"},  # its own layered retina; the QP depth limit
    "render": SHARED - {"no_plots"},  # images are its output
    "reproduce": frozenset({"out", "json", "no_plots"}),  # the thesis's robot and settings
}


def options(parser: argparse.ArgumentParser) -> dict[str, argparse.Action]:
    return {a.dest: a for a in parser._actions}


def test_every_command_with_an_output_folder_is_a_run_command_listed_here() -> None:
    with_out = {name for name, p in command_parsers(build_parser()).items() if "out" in options(p)}
    assert with_out == set(RUN_COMMANDS)


@pytest.mark.parametrize("command", sorted(RUN_COMMANDS))
def test_every_run_command_has_the_shared_options_it_must_have(command: str) -> None:
    assert SHARED & set(options(command_parsers(build_parser())[command])) == RUN_COMMANDS[command]


@pytest.mark.parametrize("command", sorted(command_parsers(build_parser())))
def test_every_shared_option_is_made_by_its_one_helper(command: str) -> None:
    parser = command_parsers(build_parser())[command]
    found = options(parser)
    if "scenario" in found:
        assert found["scenario"].metavar == "NAME|FILE.toml"
        assert "rcmplan scenario --list" in (found["scenario"].help or "")
    if "robot" in found:
        assert found["robot"].type is robot_arg and found["robot"].metavar == "NAME|FILE.toml"
    if "method" in found:
        assert tuple(found["method"].choices or ()) == METHODS
    if "plant" in found:
        assert found["plant"].choices and set(found["plant"].choices) <= set(PLANTS)
    if "out" in found:
        assert found["out"].default == f"rcmplan-out/{command}" and found["out"].metavar == "DIR"
        assert f"(rcmplan-out/{command})" in " ".join(parser.format_help().split())
    for flag in ("json", "no_plots"):
        if flag in found:
            assert isinstance(found[flag], argparse._StoreTrueAction)


@pytest.mark.parametrize("command", ["inject", "compare", "sweep", "teleop", "subretinal"])
def test_robot_takes_a_name_or_a_robot_file_and_refuses_anything_else(
    command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    kinova = "docs/examples/kinova.toml"
    here = Path(__file__).resolve().parents[1]
    args = build_parser().parse_args([command, "--robot", str(here / kinova)])
    assert args.robot.endswith(kinova)
    assert build_parser().parse_args([command, "--robot", "ur5"]).robot == "ur5"
    with pytest.raises(SystemExit):
        build_parser().parse_args([command, "--robot", "nope"])
    assert "invalid robot 'nope'" in capsys.readouterr().err


@pytest.mark.parametrize("command", ["inject", "compare", "sweep", "render"])
def test_a_method_outside_the_list_is_refused_by_the_parser(
    command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit):
        build_parser().parse_args([command, "--method", "free text"])
    assert "invalid choice: 'free text'" in capsys.readouterr().err


def test_teleop_takes_its_robot_and_plant_from_a_scenario_unless_named() -> None:
    from rcmplan.cli.teleop import settings_of

    def settings(*argv: str) -> Any:
        return settings_of(build_parser().parse_args(["teleop", *argv]))

    plain = settings()
    assert (plain.robot, plain.plant) == ("iramis", "kinematic")
    ur5 = settings("--scenario", "ur5")
    assert (ur5.robot, ur5.plant) == ("ur5", "kinematic")
    named = settings("--scenario", "ur5", "--robot", "panda", "--plant", "mujoco")
    assert (named.robot, named.plant) == ("panda", "mujoco")


def test_teleop_refuses_a_scenario_it_cannot_run_before_any_motion(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["teleop", "--scenario", "curved", "--out", str(tmp_path)]) == 2
    assert "scenario needle = 'curved'" in capsys.readouterr().err
    assert json.loads((tmp_path / "summary.json").read_text())["status"] == "invalid_input"
    assert not (tmp_path / "log.npz").exists()


def test_reproduce_writes_summary_json_and_its_figures_in_figures(tmp_path: Path) -> None:
    assert main(["reproduce", "--out", str(tmp_path)]) == 0
    doc = json.loads((tmp_path / "summary.json").read_text())
    assert doc["command"] == "reproduce" and doc["status"] == "ok"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["figures", "summary.json"]
    keys = [r["experiment"] for r in doc["experiments"]]
    assert sorted(Path(p).name for p in doc["figures"].values()) == sorted(f"{k}.png" for k in keys)
    assert all((tmp_path / "figures" / f"{k}.png").stat().st_size > 0 for k in keys)


def test_a_comparison_written_by_an_older_version_still_opens_in_the_view(tmp_path: Path) -> None:
    from rcmplan.view.run_folder import load_runs

    assert main(["compare", "--method", "pinv", "--out", str(tmp_path), "--no-plots"]) == 0
    (tmp_path / "summary.json").rename(tmp_path / "compare.json")  # the former layout
    assert [r.label for r in load_runs(tmp_path)] == ["pinv"]
