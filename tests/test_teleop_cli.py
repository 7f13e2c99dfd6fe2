"""`rcmplan teleop`: outputs and summary.json, the default session's push past the retina
margin, bad input files refused before motion, and SIGTERM keeping the partial session."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from procstat import cpu_seconds
from rcmplan.cli import main
from rcmplan.cli.teleop import FILTERS
from rcmplan.control.log import RunLog
from rcmplan.teleop import FILTERS as TELEOP_FILTERS
from rcmplan.teleop import SyntheticSurgeon, write_track
from rcmplan.teleop.motion_plan import MotionPlan, Move
from rcmplan.teleop.trace import Trace
from rcmplan.view.run_folder import load_run
from sigdigits import overlong

SRC = str(Path(__file__).resolve().parents[1] / "src")
SHORT = MotionPlan(2.0, (Move(0.8, 1.0, (10e-3, 5e-3, 0.0)),), released=((0.0, 0.6),))
FIGURES = ("input_vs_tip", "tremor_psd", "rcm_deviation", "retina_distance")


@pytest.fixture(scope="module")
def short_csv(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("input") / "hand.csv"
    return write_track(SyntheticSurgeon(plan=SHORT, seed=4).track(), path)


def test_the_cli_offers_the_filters_the_pipeline_has() -> None:
    assert FILTERS == TELEOP_FILTERS


def test_a_replay_file_writes_log_trace_summary_and_figures(short_csv, tmp_path, capsys) -> None:
    assert main(["teleop", "--input", str(short_csv), "--out", str(tmp_path)]) == 0
    doc = json.loads((tmp_path / "summary.json").read_text())
    assert doc["status"] == "ok" and doc["input"] == "hand.csv" and doc["filter"] == "wflc"
    assert doc["intended_source"] != "input"  # a CSV file carries no intended motion
    log = RunLog.load_npz(tmp_path / "log.npz")
    trace = Trace.load_npz(tmp_path / "teleop.npz")
    assert len(log) == len(trace) == doc["periods"] == 2001
    assert (tmp_path / "log.csv").read_text().startswith("time_s,phase,solver")
    for name in FIGURES:
        assert (tmp_path / "figures" / f"{name}.png").stat().st_size > 1000
    printed = capsys.readouterr().out
    assert "tip tremor RMS" in printed
    assert overlong(printed) == []  # every figure through analysis.units.fmt
    # the 3D view reads the session as it reads any run: its eye and trocar from the scene block
    run = load_run(tmp_path)
    assert len(run.log) == doc["periods"]
    assert run.scene.trocar_radius == doc["scene"]["trocar_radius_m"] > 0


def test_the_default_session_pushes_past_the_margin_and_the_needle_stops_at_it(
    tmp_path, capsys
) -> None:
    assert main(["teleop", "--out", str(tmp_path), "--json", "--no-plots"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["status"] == "ok" and doc["input"] == "synthetic"
    assert doc["fixture_active_s"]["retina"] > 0.5  # the hand asked past the margin
    assert doc["retina_min_distance_m"] >= doc["retina_margin_m"] - 1e-9
    assert doc["limit_violations"] == dict.fromkeys(doc["limit_violations"], 0)
    assert doc["released_past_fixture"]  # released once while pushing: the needle held
    assert doc["simulated_time_s"] == pytest.approx(20.0)
    assert not (tmp_path / "figures").exists()


def set_field(rows: list[str], row: int, column: int, value: str) -> None:
    """Set one value of data row `row` (0-based, after the header line)."""
    fields = rows[row + 1].rstrip("\n").split(",")
    fields[column] = value
    rows[row + 1] = ",".join(fields) + "\n"


@pytest.mark.parametrize(
    ("edit", "text"),
    [
        (lambda rows: set_field(rows, 4, 2, "nan"), "row 4 position"),
        (lambda rows: set_field(rows, 8, 0, "0.0"), "row 8 time_s"),
        (lambda rows: set_field(rows, 12, 1, "0.5"), "row 12 position_m"),  # a 50 m/s jump
        (lambda rows: rows.__setitem__(0, "time_s,x_m,y_m,z_m\n"), "missing: clutch"),
    ],
)
def test_a_bad_file_is_refused_before_motion_naming_the_row(
    short_csv, tmp_path, capsys, edit, text
) -> None:
    rows = short_csv.read_text().splitlines(keepends=True)
    edit(rows)
    bad = tmp_path / "bad.csv"
    bad.write_text("".join(rows))
    out = tmp_path / "out"
    assert main(["teleop", "--input", str(bad), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert text in err and "bad.csv" in err
    doc = json.loads((out / "summary.json").read_text())
    assert doc["status"] == "invalid_input_stream"
    assert not (out / "log.npz").exists()


def test_sigterm_writes_the_partial_session_and_exits_143(tmp_path) -> None:
    from rcmplan.teleop.session import Session
    from rcmplan.teleop.settings import TeleopSettings

    out = tmp_path / "out"
    # The default 20 s session on the UR5: the whole command took 11.9 s of CPU time in one
    # measurement, the session most of it. The signal goes once the process has used 1 s of
    # CPU time after the session's last import (reported by -X importtime): CPU time, not wall
    # time, so that a loaded machine does not make the signal land before the first record.
    # Building the session here first compiles the UR5's QP step into numba's cache, so the
    # command's build only loads it.
    Session(TeleopSettings(robot="ur5"))
    env = {**os.environ, "PYTHONPATH": SRC, "MUJOCO_GL": "egl"}
    proc = subprocess.Popen([sys.executable, "-X", "importtime", "-m", "rcmplan", "teleop",
                             "--robot", "ur5", "--no-plots", "--out", str(out)], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True)  # fmt: skip
    assert proc.stderr is not None
    for line in proc.stderr:
        if line.rsplit("|", 1)[-1].strip() == "rcmplan.compiled.qp_period":
            break
    start = cpu_seconds(proc.pid)
    assert start is not None, "the session ended before its last import was reported"
    deadline = time.monotonic() + 60.0
    while (cpu_seconds(proc.pid) or math.inf) < start + 1.0 and time.monotonic() < deadline:
        time.sleep(0.01)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 143, err
    doc = json.loads((out / "summary.json").read_text())
    assert doc["status"] == "interrupted"
    assert "SIGTERM" in doc["message"]
    log = RunLog.load_npz(out / "log.npz")
    assert 0 < len(log) < 20001
    assert len(Trace.load_npz(out / "teleop.npz")) == len(log)
    assert np.all(np.isfinite(log.tip))
