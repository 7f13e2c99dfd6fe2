"""The 3D view without a browser: run folders read and refused, the scene record, the trace, the
robot drawn at the logged pose, the replay's timeline, and the command line."""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from rcmplan import Iramis
from rcmplan.analysis.report import write_outputs
from rcmplan.control.log import ARRAY_FIELDS
from rcmplan.exceptions import PortInUseError, RunFolderError
from rcmplan.job import run_scenario
from rcmplan.scene.record import SceneRecord, read_scene_record, scene_record
from rcmplan.scene.scenario import load_scenario
from rcmplan.view.colors import FREE_SPACE, deviation_colors
from rcmplan.view.run_folder import load_runs
from rcmplan.view.trace import Trace, simplify_trace, trace_of

SRC = str(Path(__file__).resolve().parents[1] / "src")


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("inject")
    write_outputs(run_scenario(load_scenario("default")), out, figures=False)
    return out


def copy_run(run_dir: Path, tmp_path: Path) -> Path:
    out = tmp_path / "run"
    shutil.copytree(run_dir, out)
    return out


# --- the scene record -------------------------------------------------------------------------
def test_the_scene_record_reads_back_the_eye_the_run_moved_in(robot) -> None:
    sc = load_scenario("default")
    eye = sc.eye(robot)
    rec = read_scene_record(json.loads(json.dumps(scene_record(sc, robot))))
    assert isinstance(rec, SceneRecord)
    np.testing.assert_array_equal(rec.eye_center, eye.center)
    np.testing.assert_array_equal(rec.trocar, eye.port)
    assert rec.retina_radius == eye.retina_radius and rec.trocar_radius == eye.trocar_radius
    assert list(rec.labelled_points()) == ["p1", "p2", "p3", "p4", "p5", "p6", "p7"]
    assert rec.needle_arc is None


def test_a_spiral_labels_only_the_axis_points_and_a_curved_needle_records_its_arc(robot) -> None:
    rec = read_scene_record(scene_record(load_scenario("spiral"), robot))
    assert list(rec.labelled_points()) == ["p1", "p2", "p3"]
    sc = load_scenario("curved")
    assert read_scene_record(scene_record(sc, robot)).needle_arc == sc.needle.arc()


@pytest.mark.parametrize(
    ("key", "value"),
    [("format", 2), ("eye_radius_m", -1.0), ("trocar_m", [0.0, 1.0]), ("points", None)],
)
def test_a_scene_block_with_a_wrong_key_is_refused_naming_it(robot, key, value) -> None:
    block = scene_record(load_scenario("default"), robot)
    block[key] = value
    with pytest.raises(ValueError, match=re.escape(key)):
        read_scene_record(block)


# --- run folders ------------------------------------------------------------------------------
def test_a_run_folder_loads_with_its_log_summary_and_scene(run_dir) -> None:
    (run,) = load_runs(run_dir)
    assert len(run.log) == run.summary["iterations"] > 100
    assert run.robot_name == "iramis"
    np.testing.assert_allclose(
        run.scene.trocar, run.log.trocar[np.isfinite(run.log.trocar[:, 0])][0]
    )


def test_a_run_of_a_robot_file_is_replayed_with_the_robot_of_that_file(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """The view builds the run's robot from summary.json's `robot_file` (its `robot` is the
    file's name, which names no shipped robot), so the arm is drawn, not the needle alone."""
    from rcmplan.view.replay import run_robot

    example = Path(__file__).parents[1] / "docs" / "examples" / "kinova.toml"
    write_outputs(run_scenario(load_scenario("default").with_robot(str(example))), tmp_path,
                  figures=False)  # fmt: skip
    (run,) = load_runs(tmp_path)
    robot, why = run_robot(run)
    assert (run.robot_name, run.robot_source) == ("kinova", str(example.resolve()))
    assert robot is not None and why == "" and robot.name == "kinova"
    assert len(robot.joint_names) == run.log.joints.shape[1] == 6


def test_the_summary_or_the_log_may_be_named_instead_of_the_folder(run_dir) -> None:
    for name in ("summary.json", "log.npz"):
        assert load_runs(run_dir / name)[0].folder == run_dir


def damage(folder: Path, how: str) -> Path:
    """Damage a copied run folder; returns the file that is now wrong."""
    npz, summary = folder / "log.npz", folder / "summary.json"
    if how == "truncated log":
        npz.write_bytes(npz.read_bytes()[: npz.stat().st_size // 2])
        return npz
    if how == "corrupt log":
        data = bytearray(npz.read_bytes())
        data[len(data) // 3 : len(data) // 3 + 64] = bytes(64)
        npz.write_bytes(bytes(data))
        return npz
    if how == "log of another version":
        with np.load(npz) as z:
            arrays = {k: z[k] for k in z.files if k != "lam"}
        np.savez(npz, **arrays)
        return npz
    if how == "fewer records than the summary":
        with np.load(npz) as z:
            arrays = {k: z[k][:-5] if k in ARRAY_FIELDS else z[k] for k in z.files}
        np.savez(npz, **arrays)
        return npz
    doc = json.loads(summary.read_text())
    if how == "summary of another version":
        doc.pop("scene")
        summary.write_text(json.dumps(doc))
    elif how == "truncated summary":
        summary.write_text(summary.read_text()[:200])
    elif how == "no log":
        npz.unlink()
        return npz
    return summary


@pytest.mark.parametrize(
    "how",
    ["truncated log", "corrupt log", "log of another version", "fewer records than the summary",
     "summary of another version", "truncated summary", "no log"],
)  # fmt: skip
def test_a_damaged_or_foreign_run_is_refused_naming_the_file(run_dir, tmp_path, how) -> None:
    bad = damage(copy_run(run_dir, tmp_path), how)
    with pytest.raises(RunFolderError) as info:
        load_runs(bad.parent)
    assert info.value.path == bad


def test_a_folder_that_is_not_a_run_is_refused_saying_what_a_run_folder_holds(tmp_path) -> None:
    for path in (tmp_path, tmp_path / "missing"):
        with pytest.raises(RunFolderError, match=re.escape("summary.json and log.npz")):
            load_runs(path)


@pytest.mark.parametrize(
    ("argv", "kind"),
    [(["reproduce"], "reproduce"), (["sweep", "--targets", "4", "--no-plots"], "sweep")],
)
def test_a_folder_of_many_runs_is_refused_naming_its_command(tmp_path, argv, kind) -> None:
    from rcmplan.cli import main

    assert main([*argv, "--out", str(tmp_path)]) == 0
    with pytest.raises(RunFolderError, match=re.escape(f"a folder of `rcmplan {kind}`: figures "
                                                       "of many runs, none to replay")):  # fmt: skip
        load_runs(tmp_path)


def test_a_comparison_folder_gives_one_run_per_method(tmp_path) -> None:
    from rcmplan.cli import main

    assert main(["compare", "--method", "pinv", "--method", "dls", "--out", str(tmp_path),
                 "--no-plots"]) == 0  # fmt: skip
    runs = load_runs(tmp_path)
    assert [r.label for r in runs] == ["pinv", "dls"]
    assert [r.summary["method"] for r in runs] == ["pinv", "dls"]


# --- what is drawn ----------------------------------------------------------------------------
def drawn_distances(tip: np.ndarray, trace: Trace) -> np.ndarray:
    """Each record's distance from the trace segment drawn through it (brute force)."""
    out = np.zeros(len(tip))
    pairs = zip(trace.records[:-1], trace.records[1:], strict=True)
    for (i, j), (a, b) in zip(pairs, trace.segments, strict=True):
        p = tip[i : j + 1]
        ab = b - a
        t = np.clip((p - a) @ ab / max(ab @ ab, 1e-300), 0.0, 1.0)
        out[i : j + 1] = np.maximum(out[i : j + 1], np.linalg.norm(p - a - t[:, None] * ab, axis=1))
    return out


def random_walk(n: int, seed: int) -> np.ndarray:
    return np.cumsum(np.random.default_rng(seed).normal(0.0, 1e-5, size=(n, 3)), axis=0)


def test_the_trace_draws_every_record_within_its_tolerance() -> None:
    tip = random_walk(5000, 3)
    trace = simplify_trace(tip, np.zeros(len(tip)), 2e-5, 1e-3, max_segments=100_000)
    far = drawn_distances(tip, trace)
    assert far.max() <= 2e-5
    assert trace.position_error_m == pytest.approx(far.max(), rel=1e-12)
    assert trace.longest_m <= 1e-3
    assert 10 < len(trace.deviation) < len(tip) / 3  # simplified, not every record
    assert trace.records[0] == 0 and trace.records[-1] == len(tip) - 1


def test_a_straight_move_with_a_dwell_is_a_few_segments_no_longer_than_allowed() -> None:
    line = np.linspace([0.0, 0.0, 0.0], [10e-3, 0.0, 0.0], 3000)
    tip = np.vstack([line, np.repeat(line[-1:], 500, axis=0), line[::-1]])  # in, dwell, out
    trace = simplify_trace(tip, np.full(len(tip), 1e-7), 1e-6, 1e-3)
    # 10 mm each way in segments of at most 1 mm: at least 20; halving gives at most twice that
    assert 20 <= len(trace.deviation) <= 40
    assert trace.longest_m <= 1e-3
    assert drawn_distances(tip, trace).max() <= 1e-6


def test_a_spent_budget_reports_the_error_left() -> None:
    tip = random_walk(5000, 4)
    trace = simplify_trace(tip, np.zeros(len(tip)), 1e-7, 1e-3, max_segments=20)
    assert len(trace.deviation) == 20
    far = drawn_distances(tip, trace)
    assert far.max() > 1e-7  # the tolerance is not met, and the trace says by how much
    assert trace.position_error_m == pytest.approx(far.max(), rel=1e-12)


def test_each_segment_carries_the_largest_deviation_it_draws_and_free_space_stays_grey() -> None:
    tip = np.linspace([0.0, 0.0, 0.0], [5e-3, 0.0, 0.0], 1001)
    dev = np.full(len(tip), 1e-7)
    dev[:100] = np.nan  # free space before the needle enters the eye
    dev[537] = 5e-6  # a one-record peak on a straight stretch
    trace = simplify_trace(tip, dev, 1e-6, 1e-3)
    assert np.nanmax(trace.deviation) == 5e-6
    assert {99, 100} <= set(trace.records.tolist())  # the entry is a vertex
    assert np.isnan(trace.deviation[0]) and np.nanmin(trace.deviation) == 1e-7
    with_peak = np.searchsorted(trace.records, 537, side="right") - 1
    assert trace.deviation[with_peak] == 5e-6
    assert trace.longest_m <= 1e-3


def test_the_view_trace_is_scaled_to_the_eye_and_describes_itself(run_dir) -> None:
    run = load_runs(run_dir)[0]
    from rcmplan.view.trace import rcm_deviation_norm

    trace = trace_of(run.log.tip, rcm_deviation_norm(run.log), run.scene.eye_radius)
    assert trace.position_error_m <= 1e-3 * run.scene.eye_radius
    text = trace.describe()
    assert f"{len(run.log):,} records as {len(trace.deviation):,} segments" in text


@pytest.mark.parametrize(("tol", "length", "budget"), [(0.0, 1e-3, 10), (1e-6, -1.0, 10),
                                                       (1e-6, 1e-3, 0)])  # fmt: skip
def test_bad_trace_settings_are_refused(tol: float, length: float, budget: int) -> None:
    with pytest.raises(ValueError, match="must be"):
        simplify_trace(random_walk(10, 1), np.zeros(10), tol, length, budget)


def test_deviation_colours_run_from_green_to_red_and_grey_in_free_space() -> None:
    rgb = deviation_colors(np.array([0.0, 1e-6, 2e-6, np.nan]), 1e-6)
    assert tuple(rgb[0]) == (40, 170, 80)
    assert tuple(rgb[1]) == tuple(rgb[2]) == (220, 40, 40)
    assert tuple(rgb[3]) == FREE_SPACE


class Recorder:
    """A stand-in for viser's scene and GUI that keeps every node it is given."""

    def __init__(self) -> None:
        self.nodes: dict[str, Node] = {}

    def __getattr__(self, name: str):
        def add(node_name: str = "", *args, **kwargs):
            node = Node(kind=name, **kwargs)
            self.nodes[node_name] = node
            return node

        return add


class Node:
    def __init__(self, **kwargs) -> None:
        self.__dict__.update(kwargs)


def test_iramis_links_are_posed_where_the_model_puts_its_frames(run_dir) -> None:
    pytest.importorskip("mujoco")
    from rcmplan.view.links_mujoco import MujocoLinks

    robot = Iramis()
    (run,) = load_runs(run_dir)
    links = MujocoLinks(Recorder(), robot)
    mj = links.mj
    for i in (0, len(run.log) // 2, len(run.log) - 1):
        links.show(run.log.joints[i], run.log.sliders[i])
        body = mj.mj_name2id(links.model, mj.mjtObj.mjOBJ_BODY, "frame6")
        T = robot.forward_kinematics(run.log.joints[i])
        np.testing.assert_allclose(links.frames[body].position, T[:3, 3], atol=1e-12)
        np.testing.assert_allclose(links.data.xmat[body].reshape(3, 3), T[:3, :3], atol=1e-12)
    assert links.geoms > 10


def test_an_arm_skeleton_ends_at_the_flange() -> None:
    from rcmplan.robot.registry import make_robot
    from rcmplan.view.links_chain import ChainLinks

    arm = make_robot("ur5")
    links = ChainLinks(Recorder(), arm)
    q = arm.home + 0.1
    links.show(q, q)
    np.testing.assert_allclose(links.lines.points[-1, 1], arm.chain.forward_kinematics(q)[:3, 3])


def test_urdf_meshes_hang_where_the_arm_chain_puts_its_flange() -> None:
    from rcmplan.robot.registry import make_robot
    from rcmplan.robot.shipped import flange_frame, robot_file
    from rcmplan.view.links_urdf import arm_urdf

    for name in ("ur5", "panda"):
        arm = make_robot(name)
        urdf = arm_urdf(robot_file(name), flange_frame(name))
        assert flange_frame(name) in urdf.link_map and "panda_hand" not in urdf.link_map
        q = arm.home + 0.05
        urdf.update_cfg(q)
        T_root_flange = urdf.get_transform(flange_frame(name), urdf.base_link)
        np.testing.assert_allclose(arm.chain.base @ T_root_flange, arm.chain.forward_kinematics(q),
                                   atol=1e-12)  # fmt: skip


def test_a_curved_needle_is_drawn_from_its_base_to_the_logged_tip(robot) -> None:
    from rcmplan.view.needle import needle_polyline

    sc = load_scenario("curved")
    curved = sc.needle.fit(robot)
    q = curved.home + np.array([0.0, 0.05, 0.0, -0.05, 0.0, 0.3])
    pts = needle_polyline(curved, q, np.zeros(3), np.zeros(3))
    np.testing.assert_allclose(pts[0], curved.needle_point(q, 0.0), atol=1e-15)
    np.testing.assert_allclose(pts[1], curved.needle_point(q, 1.0), atol=1e-15)
    np.testing.assert_allclose(pts[-1], curved.tip(q), atol=1e-15)


# --- the replay on a real server (no browser) --------------------------------------------------
@pytest.fixture
def replay(run_dir):
    pytest.importorskip("viser")
    from rcmplan.view.replay import ReplayView
    from rcmplan.view.server import start_server, stop_server

    server = start_server("127.0.0.1", 0)
    view = ReplayView(server, load_runs(run_dir))
    yield view
    view.close()
    stop_server(server)


def test_moving_the_time_slider_shows_the_record_at_that_time(replay) -> None:
    log = replay.current.log
    replay.timeline.seek(float(log.time[700]))
    state = replay.state()
    assert state["index"] == 700
    assert state["tip_m"] == log.tip[700].tolist()
    assert replay.state_panel.values["phase"].startswith(log.phase_names[log.phase[700]])


def test_play_reaches_the_last_record_and_pauses(replay) -> None:
    replay.timeline.speed.value = "10x"
    replay.timeline.toggle()
    deadline = time.monotonic() + 30.0
    while replay.timeline.playing and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not replay.timeline.playing
    assert replay.state()["index"] == len(replay.current.log) - 1
    assert replay.timeline.button.label == "Play"


# --- the command line -------------------------------------------------------------------------
def rcmplan(*args: str, **kw) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": SRC}
    return subprocess.Popen([sys.executable, "-m", "rcmplan", *args], env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, **kw)  # fmt: skip


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_view_prints_its_address_refuses_a_busy_port_and_stops_on_ctrl_c(run_dir) -> None:
    pytest.importorskip("viser")
    port = free_port()
    first = rcmplan("view", str(run_dir), "--port", str(port), "--no-browser")
    try:
        line = first.stdout.readline()
        assert f"http://127.0.0.1:{port}/" in line
        second = rcmplan("view", str(run_dir), "--port", str(port), "--no-browser")
        _out, err = second.communicate(timeout=60)
        assert second.returncode == 2
        assert f"port {port} on 127.0.0.1 is in use" in err and "Traceback" not in err
    finally:
        first.send_signal(signal.SIGINT)
        _out, err = first.communicate(timeout=30)
    assert first.returncode == 0, err
    assert "stopped by SIGINT" in err and "Traceback" not in err
    with socket.socket() as s:  # the port is free again
        s.bind(("127.0.0.1", port))


def test_view_of_a_bad_folder_exits_2_naming_it_without_a_traceback(run_dir, tmp_path) -> None:
    bad = damage(copy_run(run_dir, tmp_path), "truncated log")
    proc = rcmplan("view", str(bad.parent), "--no-browser")
    _out, err = proc.communicate(timeout=60)
    assert proc.returncode == 2
    assert str(bad) in err and "truncated" in err and "Traceback" not in err


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (["view", "--no-browser"], "one of the arguments RUN_DIR --live is required"),
        (["view", "--live", "some-run"], "argument RUN_DIR: not allowed with argument --live"),
    ],
)
def test_view_asks_for_a_folder_or_live(
    argv: list[str], said: str, capsys: pytest.CaptureFixture[str]
) -> None:
    from cli_usage import usage_error

    assert said in usage_error(argv, capsys)


def test_a_busy_port_is_refused_before_viser_moves_to_another() -> None:
    from rcmplan.view.server import check_port

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        with pytest.raises(PortInUseError, match=str(s.getsockname()[1])):
            check_port("127.0.0.1", s.getsockname()[1])


def test_live_view_stops_cleanly_when_ctrl_c_reaches_the_whole_process_group() -> None:
    pytest.importorskip("viser")
    port = free_port()
    proc = rcmplan("view", "--live", "--port", str(port), "--no-browser", start_new_session=True)
    try:
        assert f"live control of iramis at http://127.0.0.1:{port}/" in proc.stdout.readline()
    finally:
        os.killpg(proc.pid, signal.SIGINT)  # as a terminal's Ctrl-C: the control process too
        _out, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    assert "stopped by SIGINT" in err and "Traceback" not in err
    with socket.socket() as s:
        s.bind(("127.0.0.1", port))


def test_play_goes_on_past_a_frame_cut_short_by_visers_race(replay, monkeypatch) -> None:
    seek, calls = replay.timeline.seek, []

    def racing(t: float) -> None:
        calls.append(t)
        if len(calls) == 2:  # as viser's asyncio.Event.set raised once from the playback thread
            raise RuntimeError("deque mutated during iteration")
        seek(t)

    monkeypatch.setattr(replay.timeline, "seek", racing)
    replay.timeline.speed.value = "10x"
    replay.timeline.toggle()
    deadline = time.monotonic() + 30.0
    while replay.timeline.playing and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not replay.timeline.playing and replay.timeline.races == 1
    assert replay.state()["index"] == len(replay.current.log) - 1
