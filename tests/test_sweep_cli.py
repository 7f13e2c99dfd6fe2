"""`rcmplan sweep`: outputs, JSON, resume, bad input."""

from __future__ import annotations

import argparse
import json
import socket
from pathlib import Path

import pytest

from rcmplan.cli import sweep as sweep_cli
from rcmplan.exceptions import InvalidInputError, RcmplanError
from rcmplan.sweep.checkpoint import Checkpoint
from rcmplan.sweep.errors import CheckpointError, EmptyRegionError, SchedulerError
from rcmplan.sweep.fundus import CAUSE_KEYS
from rcmplan.sweep.settings import MotionSettings, SweepSettings


def parse(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    sweep_cli.register(parser.add_subparsers(dest="command"))
    return parser.parse_args(["sweep", *argv])


def run(argv: list[str]) -> int:
    args = parse(argv)
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
    by_cause = summary["targets"]["by_cause"]  # keys are identifiers, like the statuses'
    assert list(by_cause) == list(CAUSE_KEYS) and all(k.isidentifier() for k in by_cause)
    assert sum(by_cause.values()) == 8
    assert len((tmp_path / "targets.csv").read_text().splitlines()) == 9
    for name in ("reachability", "rcm_deviation", "iterations"):
        assert (tmp_path / "figures" / f"{name}.png").stat().st_size > 0
    assert (tmp_path / "checkpoint" / "header.json").exists()
    listed = summary["figures"]  # the figures under the key every command lists them in
    assert set(listed) == {"reachability", "rcm_deviation", "iterations"}
    assert all(Path(listed[k]) == tmp_path / "figures" / f"{k}.png" for k in listed)


def test_no_plots_lists_no_figures_in_the_summary(tmp_path: Path) -> None:
    assert run([*SMALL, "--out", str(tmp_path), "--no-plots"]) == 0
    assert json.loads((tmp_path / "summary.json").read_text())["figures"] == {}
    assert not (tmp_path / "figures").exists()


def test_a_rerun_into_the_same_folder_starts_afresh_as_every_command_does(
    tmp_path: Path, capsys
) -> None:
    args = [*SMALL, "--out", str(tmp_path), "--no-plots", "--json"]
    assert run(args) == 0
    first = json.loads(capsys.readouterr().out)
    assert run(args) == 0  # no --resume: the old checkpoint is discarded, every target runs again
    again = json.loads(capsys.readouterr().out)
    assert again["targets"]["resumed_from_checkpoint"] == 0
    assert again["targets_run_now"] == first["targets_run_now"] == 8
    assert json.loads((tmp_path / "summary.json").read_text())["status"] == "ok"


def test_resume_continues_the_checkpoint_and_runs_nothing_again(tmp_path: Path, capsys) -> None:
    args = [*SMALL, "--out", str(tmp_path), "--no-plots", "--json"]
    assert run(args) == 0
    capsys.readouterr()
    assert run([*args, "--resume"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["targets"]["resumed_from_checkpoint"] == summary["targets"]["run"] == 8
    assert summary["targets_run_now"] == 0
    assert summary["resumed"] == {"requested": True, "resumed_from_checkpoint": 8, "started_afresh": False,
                                  "message": ""}  # fmt: skip
    assert "nothing to resume" not in capsys.readouterr().err


@pytest.mark.parametrize("left", ["nothing", "a header alone"])
def test_resume_with_nothing_to_resume_says_so_and_starts_afresh(
    tmp_path: Path, capsys, left: str
) -> None:
    cp = tmp_path / "checkpoint"
    if left == "a header alone":  # a sweep stopped before its first chunk finished
        settings = sweep_cli.settings_from_args(parse(SMALL))
        Checkpoint.open(cp, settings, resume=False)
    assert run([*SMALL, "--out", str(tmp_path), "--no-plots", "--json", "--resume"]) == 0
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert err[-1].startswith(f"rcmplan sweep: nothing to resume: {cp}")
    assert err[-1].endswith("the sweep starts afresh")
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary == json.loads(captured.out)
    resumed = summary["resumed"]
    assert resumed["requested"] is True and resumed["started_afresh"] is True
    assert resumed["resumed_from_checkpoint"] == summary["targets"]["resumed_from_checkpoint"] == 0
    assert resumed["message"] == err[-1].removeprefix("rcmplan sweep: ")
    why = "holds no finished results" if left == "a header alone" else "is no checkpoint"
    assert why in resumed["message"]
    assert summary["targets_run_now"] == summary["targets"]["run"] == 8


def test_a_sweep_without_resume_records_that_it_started_afresh(tmp_path: Path, capsys) -> None:
    assert run([*SMALL, "--out", str(tmp_path), "--no-plots"]) == 0
    assert "nothing to resume" not in capsys.readouterr().err
    resumed = json.loads((tmp_path / "summary.json").read_text())["resumed"]
    assert resumed == {
        "requested": False,
        "resumed_from_checkpoint": 0,
        "started_afresh": True,
        "message": "",
    }


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
def test_bad_input_raises_a_clear_error_and_leaves_its_summary(
    tmp_path: Path, argv: list[str], error: type
) -> None:
    with pytest.raises(error) as raised:
        run([*argv, "--out", str(tmp_path)])
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["command"] == "sweep" and summary["status"] == raised.value.status
    assert summary["message"].startswith(type(raised.value).__name__)


def test_a_resumed_sweep_with_nothing_left_reports_no_rate(tmp_path: Path, capsys) -> None:
    args = [*SMALL, "--out", str(tmp_path), "--no-plots"]
    assert run(args) == 0
    capsys.readouterr()
    assert run([*args, "--resume"]) == 0
    rate = next(line for line in capsys.readouterr().out.splitlines() if "per second" in line)
    assert "every target came from the checkpoint" in rate


def test_a_sweep_of_other_settings_replaces_the_old_one_and_resume_names_the_mismatch(
    tmp_path: Path,
) -> None:
    assert run([*SMALL, "--out", str(tmp_path), "--no-plots"]) == 0
    other = ["--targets", "9", "--max-angle", "15", "--workers", "1", "--out", str(tmp_path),
             "--no-plots"]  # fmt: skip
    with pytest.raises(CheckpointError, match=r"other sweep settings.*without --resume"):
        run([*other, "--resume"])
    refused = json.loads((tmp_path / "summary.json").read_text())
    assert refused["status"] == "checkpoint_error" and "CheckpointError" in refused["message"]
    assert run(other) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["targets"]["sampled"] == 9 and summary["targets"]["resumed_from_checkpoint"] == 0


def test_a_rerun_never_removes_a_folder_that_is_no_checkpoint(tmp_path: Path) -> None:
    keep = tmp_path / "mine"
    keep.mkdir()
    (keep / "notes.txt").write_text("keep me")
    with pytest.raises(CheckpointError, match="not removed"):
        run([*SMALL, "--out", str(tmp_path), "--checkpoint", str(keep)])
    assert (keep / "notes.txt").exists()


def test_overwrite_is_gone_a_rerun_overwrites(capsys) -> None:
    with pytest.raises(SystemExit):
        run(["--overwrite"])
    assert "unrecognized arguments: --overwrite" in capsys.readouterr().err


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


def test_sweep_moves_the_scenarios_robot_or_the_one_named(tmp_path: Path) -> None:
    from rcmplan.scene.scenario import load_scenario

    assert MotionSettings.from_scenario(load_scenario("ur5")).robot == "ur5"
    assert MotionSettings.from_scenario(load_scenario("default")).robot == "iramis"
    argv = ["--targets", "2", "--max-angle", "5", "--workers", "1", "--no-plots",
            "--robot", "ur5", "--out", str(tmp_path)]  # fmt: skip
    assert run(argv) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["settings"]["motion"]["robot"] == "ur5"
    assert summary["targets"]["by_status"]["ok"] == summary["targets"]["run"] == 2
    assert summary["max_rcm_deviation_m"]["max"] <= 1e-6
    iramis = SweepSettings(motion=MotionSettings())
    ur5 = SweepSettings(motion=MotionSettings(robot="ur5"))
    assert iramis.digest() != ur5.digest()  # a checkpoint of one robot never resumes the other


def test_a_sweep_runs_with_the_scenarios_rcm_bound_and_reports_it(tmp_path: Path) -> None:
    # The same two targets under a 45 um bound (the default) and under 0.05 um, below what one
    # of their motions deviates: only the second ends a run with RcmBoundError, counted under
    # its own status (the one `rcmplan inject` reports for that stop), not as "error".
    found = {}
    for bound_um in (45.0, 0.05):
        scenario = tmp_path / f"bound-{bound_um}.toml"
        scenario.write_text(f'name = "bounded"\n[controller]\nrcm_bound_um = {bound_um}\n'
                            "rcm_tolerance_um = 0.5\n")  # fmt: skip
        out = tmp_path / f"out-{bound_um}"
        argv = ["--targets", "2", "--max-angle", "5", "--workers", "1", "--no-plots",
                "--scenario", str(scenario), "--out", str(out)]  # fmt: skip
        assert run(argv) == 0
        summary = json.loads((out / "summary.json").read_text())
        motion = summary["settings"]["motion"]
        assert motion["rcm_bound"] == pytest.approx(bound_um * 1e-6)
        assert motion["rcm_tolerance"] == pytest.approx(0.5e-6)
        assert summary["units"]["settings.motion.rcm_bound"] == "m"
        chunks = sorted((out / "checkpoint").glob("chunk-*.json"))
        messages = [r["message"] for c in chunks for r in json.loads(c.read_text())["results"]]
        found[bound_um] = (summary["targets"]["by_status"],
                           sum("RcmBoundError" in m for m in messages))  # fmt: skip
    assert found[45.0] == ({**found[45.0][0], "ok": 2}, 0)
    bounded = found[0.05][0]
    assert bounded["rcm_bound_exceeded"] >= 1 and found[0.05][1] == bounded["rcm_bound_exceeded"]
    assert bounded["error"] == 0


def test_a_killed_worker_costs_the_sweep_a_new_pool_and_not_its_results(tmp_path: Path) -> None:
    """A worker process killed mid-sweep (as the system's out-of-memory killer would): the
    unfinished chunks run again on a new pool, the sweep ends ok with the same results as an
    unbroken one, and its summary says the pool broke."""
    import csv
    import os
    import signal
    import subprocess
    import sys
    import time

    def argv(out: str) -> list[str]:
        return [sys.executable, "-m", "rcmplan", "sweep", "--targets", "2000", "--workers", "2",
                "--no-plots", "--out", str(tmp_path / out)]  # fmt: skip

    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1] / "src")}
    proc = subprocess.Popen(argv("broken"), env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE)  # fmt: skip
    deadline = time.monotonic() + 300
    while len(workers := forkserver_children(proc.pid)) < 2:
        assert proc.poll() is None and time.monotonic() < deadline, "no workers within 300 s"
        time.sleep(0.05)
    time.sleep(1.0)
    os.kill(min(workers), signal.SIGKILL)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err.decode()[-2000:]
    doc = json.loads((tmp_path / "broken" / "summary.json").read_text())
    assert doc["status"] == "ok" and "the pool broke 1 time (signal SIGKILL" in doc["executor"]
    subprocess.run(argv("whole"), env=env, check=True, capture_output=True, timeout=600)

    def rows(out: str) -> list[list[str]]:  # targets.csv without its wall-time column
        with open(tmp_path / out / "targets.csv", newline="") as fh:
            return [row[:-1] for row in csv.reader(fh)]

    assert rows("broken") == rows("whole")


def forkserver_children(pid: int) -> set[int]:
    """The pool's workers among pid's descendants: the forkserver's children."""
    from procstat import children_of

    servers = [p for p in children_of(pid) if b"forkserver" in cmdline(p) and children_of(p)]
    return {c for s in servers for c in children_of(s)}


def cmdline(pid: int) -> bytes:
    """The process's command line; empty once it has ended."""
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return b""
