"""The 3D view in a real browser (headless Chromium driven by playwright): the scene is drawn,
scrubbing the timeline moves the needle on screen, a subretinal episode's B-scan changes with
the timeline, and in live mode dragging the target moves the tip with the RCM held. scripts/check.sh installs Chromium and playwright and sets
RCMPLAN_REQUIRE_BROWSER, so in CI these tests run; elsewhere they are skipped without them."""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np
import pytest

import browser_probe as probe
from episode_folder import write_episode
from rcmplan.analysis.report import write_outputs
from rcmplan.job import run_scenario
from rcmplan.scene.scenario import load_scenario
from rcmplan.view.replay import ReplayView
from rcmplan.view.run_folder import load_runs
from rcmplan.view.server import address, start_server, stop_server

pytest.importorskip("viser", reason="the view needs viser (extra `view`)")


def require(ok: bool, why: str) -> None:
    if ok:
        return
    if os.environ.get("RCMPLAN_REQUIRE_BROWSER"):
        pytest.fail(f"{why}, and RCMPLAN_REQUIRE_BROWSER is set (scripts/check.sh)")
    pytest.skip(f"{why} (scripts/check.sh installs it)")


@pytest.fixture(scope="module")
def browser():
    require(probe.chromium_path() is not None, "no Chromium on PATH")
    try:
        pw = probe.start_playwright()
    except ImportError:
        require(False, "playwright is not installed")
    chromium = probe.launch(pw)
    yield chromium
    chromium.close()
    pw.stop()


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    """A short inject: the default injection on the kinematic plant."""
    out = tmp_path_factory.mktemp("inject")
    write_outputs(run_scenario(load_scenario("default")), out, figures=False)
    return out


@pytest.fixture
def replay(run_dir):
    server = start_server("127.0.0.1", 0)
    view = ReplayView(server, load_runs(run_dir))
    yield server, view
    view.close()
    stop_server(server)


def open_page(browser, server):
    page = browser.new_page(viewport={"width": 1200, "height": 800})
    page.goto(address(server, "127.0.0.1"))
    page.wait_for_selector("canvas", timeout=30_000)
    probe.wait_for(lambda: len(probe.needle_pixels(probe.screenshot(page))) > 30, 60.0, 0.5)
    return page


def test_the_scene_is_drawn_and_scrubbing_the_timeline_moves_the_needle(browser, replay):
    server, view = replay
    page = open_page(browser, server)
    first = probe.screenshot(page)
    scene = probe.scene_region(first).astype(float).mean(axis=2)
    assert scene.var() > 100.0  # not a blank canvas: links, eye, needle, labels
    assert view.state()["index"] == 0

    probe.click_track(page, "time [s]", 0.5)  # scrub to the middle of the run
    probe.wait_for(lambda: view.state()["index"] > 0.3 * len(view.current.log), 20.0)
    tip_moved = np.linalg.norm(np.subtract(view.state()["tip_m"], view.current.log.tip[0]))
    assert tip_moved > 5e-3  # the record shown now has the needle elsewhere

    def needle_moved() -> bool:
        shot = probe.screenshot(page)
        shift = np.linalg.norm(probe.needle_centre(shot) - probe.needle_centre(first))
        return bool(shift > 10.0)  # pixels

    probe.wait_for(needle_moved, 20.0, 0.3)
    later = probe.screenshot(page)
    changed = np.abs(probe.scene_region(later).astype(int) - probe.scene_region(first)).max(axis=2)
    assert (changed > 30).mean() > 1e-3
    page.close()


def test_playing_runs_the_timeline_to_the_end_and_pauses(browser, replay):
    server, view = replay
    page = open_page(browser, server)
    view.timeline.speed.value = "2x"
    page.get_by_role("button", name="Play").click()
    probe.wait_for(lambda: view.state()["playing"], 10.0)
    probe.wait_for(lambda: not view.state()["playing"], 30.0)
    state = view.state()
    assert state["index"] == len(view.current.log) - 1
    # it played through records, not one jump: records between the first and the last (how
    # many depends on the machine's redraw rate; 7 were seen on 2 loaded cores)
    assert state["shows"] > 2
    page.close()


def bscan_image(page):
    """The B-scan image element of an episode's replay (under its label in the panel)."""
    return page.locator("p:text-is('B-scan') + div img").first


def test_an_episode_replay_shows_its_bscan_and_the_timeline_changes_it(browser, tmp_path):
    from PIL import Image

    from rcmplan.view.colors import SEG_ILM

    server = start_server("127.0.0.1", 0)
    view = ReplayView(server, load_runs(write_episode(tmp_path / "episode")))
    try:
        page = open_page(browser, server)
        image = bscan_image(page)
        image.wait_for(timeout=30_000)
        first_src, first = image.get_attribute("src"), view.state()["bscan_frame"]
        before = np.asarray(Image.open(io.BytesIO(image.screenshot())).convert("RGB"))
        assert first == 0
        green = np.abs(before.astype(int) - SEG_ILM).max(axis=2) < 40
        assert green.sum() > 50  # the segmented ILM is drawn over the image

        probe.click_track(page, "time [s]", 0.8)
        probe.wait_for(lambda: (view.state()["bscan_frame"] or 0) > first, 20.0)
        probe.wait_for(lambda: image.get_attribute("src") != first_src, 20.0, 0.2)
        after = np.asarray(Image.open(io.BytesIO(image.screenshot())).convert("RGB"))
        assert after.shape == before.shape
        assert (np.abs(after.astype(int) - before).max(axis=2) > 30).mean() > 0.05
        page.close()
    finally:
        view.close()
        stop_server(server)


def test_dragging_the_live_target_moves_the_tip_with_the_rcm_held(browser):
    from rcmplan.view.live import LiveView, live_settings

    server = start_server("127.0.0.1", 0)
    view = LiveView(server, live_settings("default", None, "kinematic"))
    try:
        page = open_page(browser, server)
        (client,) = server.get_clients().values()
        camera = client.camera
        centre = np.array(view.gizmo.position)
        reach = 0.7 * view.gizmo_scale  # a point on an arrow of the gizmo
        ends = [probe.project(camera, centre + reach * axis) for axis in np.eye(3)]
        start = probe.project(camera, centre)
        k = int(np.argmax([np.linalg.norm(e - start) for e in ends]))  # the longest arrow
        along = (ends[k] - start) / np.linalg.norm(ends[k] - start)
        probe.drag(page, ends[k], ends[k] - 60.0 * along)  # 60 px back along the arrow

        def followed() -> bool:
            s = view.state()
            moved = np.linalg.norm(np.subtract(s["goal_m"], centre))
            return bool(s["pushes"] > 0 and moved > 1e-3
                        and np.linalg.norm(np.subtract(s["tip_m"], s["goal_m"])) < 1e-6)  # fmt: skip

        probe.wait_for(followed, 30.0)
        state = view.state()
        goal = np.subtract(state["goal_m"], centre)
        assert abs(goal[k]) > 1e-3 and np.abs(np.delete(goal, k)).max() < 1e-9  # along one axis
        assert state["max_rcm_deviation_m"] <= 1e-6
        assert state["retina_distance_m"] > 0.0
        page.get_by_label("clutch engaged").click()  # released in the page: the needle holds
        probe.wait_for(lambda: view.state()["status"].startswith("released"), 30.0)
        assert view.clutch.value is False
        page.close()
    finally:
        view.close()
        stop_server(server)
