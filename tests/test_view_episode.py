"""The replay of a subretinal episode without a browser: the B-scan shown at a replayed time is
the one of the volume whose estimate the controller held at that time, a real B-scan of that
acquisition (its own segmentation finds the true ILM), and a damaged bscans.npz is refused."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from episode_folder import SHORT, write_episode
from rcmplan.exceptions import RunFolderError
from rcmplan.subretinal.episode_bscans import read_bscans
from rcmplan.subretinal.ioct import IoctModel
from rcmplan.subretinal.segment import segment_bscan
from rcmplan.subretinal.trace import NeedleHold
from rcmplan.view.run_folder import load_runs

pytest.importorskip("viser", reason="the view needs viser (extra `view`)")


@pytest.fixture(scope="module")
def episode_dir(tmp_path_factory) -> Path:
    return write_episode(tmp_path_factory.mktemp("episode"))


@pytest.fixture
def replay(episode_dir):
    from rcmplan.view.replay import ReplayView
    from rcmplan.view.server import start_server, stop_server

    server = start_server("127.0.0.1", 0)
    view = ReplayView(server, load_runs(episode_dir))
    yield view
    view.close()
    stop_server(server)


def test_the_bscan_at_a_time_is_the_volume_the_controller_held_then(episode_dir) -> None:
    frames = read_bscans(episode_dir / "bscans.npz")
    with np.load(episode_dir / "episode.npz") as z:
        t, predicted = z["t_s"], z["predicted_m"]
    # With `hold` the controller's prediction is the newest estimate it had received: the frame
    # found for each period's time must carry that estimate.
    k = np.array([frames.frame_at(float(ti)) for ti in t])
    assert k.min() == 0 and k.max() == len(frames) - 1  # every frame is some period's
    np.testing.assert_array_equal(frames.estimate_m[k], predicted)
    assert np.all(frames.arrival_s[k] <= t)
    later = np.minimum(k + 1, len(frames) - 1)
    assert np.all((frames.arrival_s[later] > t) | (k == len(frames) - 1))
    np.testing.assert_allclose(frames.arrival_s - frames.t_acq_s, SHORT.latency_s, atol=1e-12)
    assert frames.frame_at(float(frames.arrival_s[0]) - 1e-6) == -1


def test_each_frame_is_a_bscan_of_its_acquisition(episode_dir) -> None:
    frames = read_bscans(episode_dir / "bscans.npz")
    ioct = IoctModel(volume_rate_hz=SHORT.ioct_rate_hz, latency_s=SHORT.latency_s)
    assert frames.images.shape[1:] == (ioct.depth_px, ioct.lateral_px)
    radius = load_runs(episode_dir)[0].scene.retina_radius
    for k in range(0, len(frames), 5):  # the stored (quantised) image segments as rendered
        seg = segment_bscan(frames.image_db(k), ioct, radius, NeedleHold().diameter_m)
        assert seg.ilm_offset_m is not None
        assert abs(seg.ilm_offset_m - frames.truth_m[k]) < 3 * ioct.axial_pixel_m
        assert abs(seg.ilm_offset_m - frames.segmented_m[k]) < ioct.axial_pixel_m
    # the needle enters the scan: far above the ILM at first, in the tissue during the hold
    depth = frames.tip_m[:, 1] - frames.ilm_at_tip_m
    assert depth[0] < -150e-6 and depth.max() > 0.3 * SHORT.standoff_m


def test_the_replay_shows_that_bscan_when_the_timeline_moves(replay) -> None:
    from rcmplan.view.bscan_panel import frame_rgb

    panel, log = replay.bscan, replay.current.log
    assert panel is not None
    for i in (0, len(log) // 2, len(log) - 1):
        replay.timeline.seek(float(log.time[i]))
        state = replay.state()
        assert state["index"] == i
        k = panel.frames.frame_at(float(log.time[i]))
        assert state["bscan_frame"] == k
        np.testing.assert_array_equal(panel.image.image, frame_rgb(panel.frames, k))
        assert panel.text.values["volume"].startswith(f"{k + 1} of {len(panel.frames)}:")


def test_a_damaged_bscans_file_is_refused_naming_it(episode_dir, tmp_path) -> None:
    import shutil

    folder = shutil.copytree(episode_dir, tmp_path / "run")
    data = (folder / "bscans.npz").read_bytes()
    (folder / "bscans.npz").write_bytes(data[: len(data) // 2])
    with pytest.raises(RunFolderError, match=r"bscans\.npz.*truncated or damaged"):
        load_runs(folder)


def test_the_eye_moves_with_the_trocar_in_a_drifting_episode(tmp_path, replay) -> None:
    from dataclasses import replace

    from rcmplan.cli.subretinal import write_outputs
    from rcmplan.view.replay import ReplayView
    from rcmplan.view.server import start_server, stop_server

    drift = replace(SHORT, eye_drift_m=500e-6, eye_drift_time_s=2.0, seed=2)
    assert write_outputs(drift, tmp_path, figures=False)["status"] == "ok"
    server = start_server("127.0.0.1", 0)
    view = ReplayView(server, load_runs(tmp_path))
    try:
        log, start = view.current.log, view.current.run.scene.trocar
        inside = np.flatnonzero(np.isfinite(log.trocar[:, 0]))
        moved = np.linalg.norm(log.trocar[inside] - start, axis=1)
        assert moved.max() > 50e-6  # the eye did move in this episode
        for i in (inside[0], inside[np.argmax(moved)], inside[-1]):
            view.show(int(i))
            np.testing.assert_allclose(view.state()["eye_offset_m"], log.trocar[i] - start)
            np.testing.assert_allclose(view.drawing.eye.position, log.trocar[i] - start)
    finally:
        view.close()
        stop_server(server)
    # The still eye of the short episode: no offset anywhere.
    replay.show(len(replay.current.log) - 1)
    assert replay.state()["eye_offset_m"] == [0.0, 0.0, 0.0]
