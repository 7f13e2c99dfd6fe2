"""What the command line takes as typed: negative eye-frame coordinates after --target, and a
shipped scenario's file printed by `rcmplan scenario --show NAME` as a starting point."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from rcmplan.cli import build_parser, main
from rcmplan.cli.inject import scenario_for
from rcmplan.robot.registry import make_robot
from rcmplan.scene.eye_text import to_base
from rcmplan.scene.scenario import load_scenario, scenario_names


@pytest.mark.parametrize(
    "argv",
    [
        ["--target", "-1,0,10.5", "--target", "-.5,-1,9"],
        ["--target=-1,0,10.5", "--target=-.5,-1,9"],
        ["--target", "-1,0,10.5", "--target=-.5,-1,9"],
    ],
)
def test_negative_targets_parse_as_typed_with_or_without_equals(argv: list[str]) -> None:
    args = build_parser().parse_args(["inject", *argv, "--no-plots"])
    assert args.target == ["-1,0,10.5", "-.5,-1,9"] and args.no_plots


def test_a_negative_number_with_an_exponent_is_a_value_too() -> None:
    args = build_parser().parse_args(["sweep", "--max-angle", "-1e-3"])
    assert args.max_angle == -1e-3


def test_an_unknown_option_is_still_refused(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        build_parser().parse_args(["inject", "--target", "-1,0,10.5", "-x"])
    assert "unrecognized arguments: -x" in capsys.readouterr().err


def test_negative_targets_land_where_the_eye_frame_puts_them() -> None:
    args = build_parser().parse_args(["inject", "--target", "-1,0,10.5", "--target", "0.5,-2,9"])
    sc = scenario_for(args)
    eye = sc.eye(make_robot(sc.robot))
    want = to_base(eye, np.array([[-1.0, 0.0, 10.5], [0.5, -2.0, 9.0]]))
    assert sc.visits == ("p4", "p5")
    np.testing.assert_allclose([sc.point_overrides["p4"], sc.point_overrides["p5"]], want)
    assert np.linalg.norm(sc.point_overrides["p4"] - eye.center) == pytest.approx(
        np.linalg.norm([-1.0e-3, 0.0, 10.5e-3])
    )


@pytest.mark.parametrize("name", scenario_names())
def test_show_prints_the_shipped_file_as_it_is(
    name: str, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    assert main(["scenario", "--show", name]) == 0
    text = capsys.readouterr().out
    shipped = resources.files("rcmplan.scenarios").joinpath(f"{name}.toml").read_text()
    assert text == shipped
    copy = tmp_path / "mine.toml"
    copy.write_text(text)
    assert load_scenario(copy) == load_scenario(name)  # a starting point that loads as is


def test_show_of_an_unknown_name_exits_2_naming_the_shipped_ones(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["scenario", "--show", "nope"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert "'nope'" in captured.err
    assert all(name in captured.err for name in scenario_names())
