"""`rcmplan sweep`: outputs, JSON, resume, bad input."""

from __future__ import annotations

import argparse
import json
import socket
from pathlib import Path

import pytest

from rcmplan.cli import sweep as sweep_cli
from rcmplan.exceptions import InvalidInputError, RcmplanError
from rcmplan.sweep.errors import CheckpointError, EmptyRegionError, SchedulerError


def run(argv: list[str]) -> int:
    parser = argparse.ArgumentParser()
    sweep_cli.register(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["sweep", *argv])
    return int(args.run(args))


def unused_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


SMALL = ["--targets", "8", "--max-angle", "15", "--workers", "1"]


def test_sweep_writes_summary_targets_checkpoint_and_maps(tmp_path: Path, capsys) -> None:
    assert run([*SMALL, "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "max RCM deviation" in out and "converged" in out
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["targets"]["sampled"] == 8
    assert summary["targets"]["run"] == summary["targets"]["reachable"]
    assert len((tmp_path / "targets.csv").read_text().splitlines()) == 9
    for name in ("reachability", "rcm_deviation", "iterations"):
        assert (tmp_path / "figures" / f"{name}.png").stat().st_size > 0
    assert (tmp_path / "checkpoint" / "header.json").exists()


def test_a_rerun_needs_resume_and_then_runs_nothing_again(tmp_path: Path, capsys) -> None:
    args = [*SMALL, "--out", str(tmp_path), "--no-plots", "--json"]
    assert run(args) == 0
    with pytest.raises(CheckpointError, match="--resume"):
        run(args)
    capsys.readouterr()
    assert run([*args, "--resume"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["targets"]["resumed_from_checkpoint"] == summary["targets"]["run"]


def test_gain_search_reports_the_best_settings(tmp_path: Path, capsys) -> None:
    args = [*SMALL, "--out", str(tmp_path), "--gain-search", "optimize", "--subsample", "2",
            "--max-evaluations", "4"]  # fmt: skip
    assert run(args) == 0
    assert "gain search (optimize)" in capsys.readouterr().out
    gains = json.loads((tmp_path / "summary.json").read_text())["gain_search"]
    assert gains["best"]["feasible"] is True
    assert (tmp_path / "figures" / "gains.png").exists()


@pytest.mark.parametrize(
    ("argv", "error"),
    [
        (["--targets", "3", "--max-angle", "80"], EmptyRegionError),
        (["--targets", "0"], RcmplanError),
        (["--scheduler", f"tcp://127.0.0.1:{unused_port()}", "--timeout", "1"], SchedulerError),
        (["--timeout", "-1"], InvalidInputError),
        (["--timeout", "nan"], InvalidInputError),
        (["--timeout", "inf"], InvalidInputError),
    ],
)
def test_bad_input_raises_a_clear_error(tmp_path: Path, argv: list[str], error: type) -> None:
    with pytest.raises(error):
        run([*argv, "--out", str(tmp_path)])


def test_a_resumed_sweep_with_nothing_left_reports_no_rate(tmp_path: Path, capsys) -> None:
    args = [*SMALL, "--out", str(tmp_path), "--no-plots"]
    assert run(args) == 0
    capsys.readouterr()
    assert run([*args, "--resume"]) == 0
    rate = next(line for line in capsys.readouterr().out.splitlines() if "per second" in line)
    assert "every target came from the checkpoint" in rate


def test_a_sweep_of_other_settings_into_an_old_folder_names_overwrite(tmp_path: Path) -> None:
    assert run([*SMALL, "--out", str(tmp_path), "--no-plots"]) == 0
    other = ["--targets", "9", "--max-angle", "15", "--workers", "1", "--out", str(tmp_path),
             "--no-plots"]  # fmt: skip
    with pytest.raises(CheckpointError, match="--overwrite"):
        run(other)
    assert run([*other, "--overwrite"]) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["targets"]["sampled"] == 9 and summary["targets"]["resumed_from_checkpoint"] == 0


def test_overwrite_refuses_to_remove_a_folder_that_is_no_checkpoint(tmp_path: Path) -> None:
    keep = tmp_path / "mine"
    keep.mkdir()
    (keep / "notes.txt").write_text("keep me")
    with pytest.raises(CheckpointError, match="not removed"):
        run([*SMALL, "--out", str(tmp_path), "--checkpoint", str(keep), "--overwrite"])
    assert (keep / "notes.txt").exists()


def test_every_number_in_the_sweep_summary_has_a_unit(tmp_path: Path) -> None:
    assert run([*SMALL, "--out", str(tmp_path), "--no-plots"]) == 0
    s = json.loads((tmp_path / "summary.json").read_text())
    counts = {
        "sampled",
        "reachable",
        "unreachable",
        "misses_retina",
        "run",
        "targets_run_now",
        "resumed_from_checkpoint",
        "n_targets",
        "seed",
        "max_iterations",
        "total",
    }

    def walk(obj: object, path: str) -> None:
        if isinstance(obj, dict):
            for k, v in obj.items():
                walk(v, f"{path}.{k}" if path else k)
        elif isinstance(obj, list):
            for v in obj:
                walk(v, path)
        elif isinstance(obj, int | float) and not isinstance(obj, bool):
            key = path.rsplit(".", 1)[-1]
            ok = (
                key in counts
                or key.endswith(("_m", "_s", "_rad", "_per_s"))
                or path in s["units"]
                or path.split(".")[0] in s["units"]
                or path.startswith(("targets.by_", "max_rcm_deviation_m", "tip_error_m"))
            )
            assert ok, path

    walk({k: v for k, v in s.items() if k != "units"}, "")


def test_sweep_runs_each_target_on_the_chosen_plant(tmp_path: Path) -> None:
    argv = ["--targets", "2", "--max-angle", "5", "--workers", "1", "--plant", "mujoco-kinematic",
            "--out", str(tmp_path), "--no-plots"]  # fmt: skip
    assert run(argv) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["settings"]["motion"]["plant"] == "mujoco-kinematic"
    assert summary["targets"]["by_status"]["ok"] == summary["targets"]["run"] > 0


def test_an_unknown_sweep_plant_is_refused() -> None:
    from rcmplan.sweep.settings import MotionSettings

    with pytest.raises(RcmplanError, match="plant"):
        MotionSettings(plant="vrep")
