"""The 3D view (`rcmplan view`): a 54,000-record MuJoCo run opened and played, scrubbing, and
live control while the view redraws.

Run alone: MUJOCO_GL=egl python benchmarks/bench_view.py [--run DIR] [--parts]
A MuJoCo injection (`rcmplan inject --plant mujoco`, 53,989 records) is run first (5-30 s)
unless --run (or RCMPLAN_BENCH_VIEW_RUN) names one. Browser figures use the system's Chromium
with software WebGL (SwiftShader) on the same cores as the server; the machine's load average
is printed beside them. Rows follow benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from _common import quick, row
from rcmplan.view import colors

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import browser_probe as probe
from rcmplan.view.replay import ReplayView
from rcmplan.view.run_folder import load_runs
from rcmplan.view.server import address, start_server, stop_server

SEED = 20180507
# Installed before the page loads: times the click on the timeline (pointerdown), the update
# the page sends (posted to viser's websocket worker), each batch of scene and panel messages
# the worker hands to the page, the panel's text change, and the end of every frame (a task
# posted from an animation-frame callback runs once the frame's callbacks, the scene's render
# among them, have run). viser applies a batch in the next frame and draws it in that frame.
SCRUB_JS = """(() => {
  const now = () => performance.now();
  const ev = window.__scrub = [];
  const W = window.Worker;
  window.Worker = function (...args) {
    const w = new W(...args);
    w.addEventListener('message', (e) => {
      if (e.data && e.data.type === 'message_batch') ev.push(['batch', now()]);
    });
    return w;
  };
  window.Worker.prototype = W.prototype;
  const post = W.prototype.postMessage;
  W.prototype.postMessage = function (m, ...rest) {
    if (m && m.type === 'send') ev.push(['sent', now()]);
    return post.call(this, m, ...rest);
  };
  const ch = new MessageChannel();
  ch.port1.onmessage = () => ev.push(['frame_end', now()]);
  const tick = () => {
    ev.push(['frame', now()]); ch.port2.postMessage(0); requestAnimationFrame(tick);
  };
  requestAnimationFrame(tick);
  document.addEventListener('pointerdown', () => ev.push(['down', now()]), true);
  const watch = () => new MutationObserver((ms) => {
    if (ms.some((m) => (m.target.textContent || '').includes('(record '))) ev.push(['text', now()]);
  }).observe(document.body, {subtree: true, childList: true, characterData: true});
  if (document.body) watch(); else document.addEventListener('DOMContentLoaded', watch);
})();"""
COUNT_JS = """() => {
  window.__updates = 0;
  new MutationObserver((ms) => {
    if (ms.some((m) => (m.target.textContent || '').includes('(record '))) window.__updates++;
  }).observe(document.body, {subtree: true, childList: true, characterData: true});
}"""


def browser_missing() -> str:
    """Why the browser figures cannot be measured here ("" when they can)."""
    if probe.chromium_path() is None:
        return "no Chromium on PATH"
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "playwright is not installed (extra `dev`)"
    return ""


def mujoco_run(out: Path) -> Path:
    """`rcmplan inject --plant mujoco` into out; the run folder."""
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    cmd = [sys.executable, "-m", "rcmplan", "inject", "--plant", "mujoco", "--no-plots",
           "--out", str(out)]  # fmt: skip
    subprocess.run(cmd, check=True, env=env, stdout=subprocess.DEVNULL)
    return out


def load_note() -> str:
    one, five, _ = os.getloadavg()
    return f"load average {one:.1f} (1 min), {five:.1f} (5 min) on {os.cpu_count()} cores"


def open_rows(run_dir: Path) -> tuple[list[dict[str, Any]], Any, ReplayView]:
    """Read the run, build the scene, and the peer: the report's tip-path figure (matplotlib)."""
    t = time.perf_counter()
    runs = load_runs(run_dir)
    t_load = time.perf_counter() - t
    server = start_server("127.0.0.1", 0)
    t = time.perf_counter()
    view = ReplayView(server, runs)
    t_build = time.perf_counter() - t
    n = len(runs[0].log)
    return [
        row(f"open a {n:,}-record MuJoCo run: read and check log.npz + summary.json",
            t_load, "s", "", None, ""),
        row("open: build the scene (links, eye, trace, panels) on a running server",
            t_build, "s", "report's tip-path figure, matplotlib (same log)",
            tip_figure_s(runs[0]), "<= 2 s with the next rows"),
    ], server, view  # fmt: skip


def tip_figure_s(run: Any) -> float:
    """Seconds to draw the report's tip-path figure of the same log (the peer: a static view)."""
    from rcmplan.analysis import plots
    from rcmplan.robot.iramis import Iramis
    from rcmplan.scene.scenario import load_scenario

    eye = load_scenario("default").eye(Iramis())
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        plots.tip_path(run.log, eye, {}, Path(tmp) / "tip.png")
        return time.perf_counter() - t


def cold_start_s(run_dir: Path) -> float:
    """`rcmplan view RUN --no-browser` from process start to its address line."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    t = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-m", "rcmplan", "view", str(run_dir), "--no-browser", "--port", "0"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
    )  # fmt: skip
    line = proc.stdout.readline() if proc.stdout else ""
    elapsed = time.perf_counter() - t
    proc.send_signal(signal.SIGINT)
    proc.communicate(timeout=30)
    if "http://" not in line:
        raise RuntimeError(f"no address line from rcmplan view: {line!r}")
    return elapsed


def scrub_server_ms(view: ReplayView, n: int) -> list[float]:
    """Server-side time [ms] of showing random records (robot, needle, panels, messages)."""
    rng = np.random.default_rng(SEED)
    out = []
    for i in rng.integers(0, len(view.current.log), n):
        t = time.perf_counter()
        view.show(int(i))
        out.append(1e3 * (time.perf_counter() - t))
    return out


def render_pose_ms(view: ReplayView, n: int) -> float:
    """The peer: MuJoCo offscreen render of a logged pose, as `rcmplan render` draws one [ms]."""
    from rcmplan.sim.mujoco.plant import MujocoPlant
    from rcmplan.sim.mujoco.render import SceneRenderer

    plant = MujocoPlant(mode="kinematic")
    renderer = SceneRenderer(plant.scene()[0], 640, 480)
    rng = np.random.default_rng(SEED)
    times = []
    for i in rng.integers(0, len(view.current.log), n):
        t = time.perf_counter()
        plant.reset(view.current.log.sliders[int(i)])
        renderer.render(plant.scene()[1])
        times.append(1e3 * (time.perf_counter() - t))
    renderer.close()
    return statistics.median(times)


class Scrubs:
    """Times [ms after the click] of scrubs on one page, per stage (see SCRUB_JS): the update
    sent by the page, received by the server, its reply on the page, the panel's new text, and
    the scene drawn (the end of the frame that applies the reply)."""

    STAGES = ("sent", "server", "reply", "text", "drawn")

    def __init__(self) -> None:
        self.times: dict[str, list[float]] = {k: [] for k in self.STAGES}
        self.received: list[float] = []  # server wall-clock times [s] of the updates

    def hook(self, on_index: Callable[[int], None]) -> Callable[[int], None]:
        """on_index, noting when the server receives each update."""

        def noted(i: int) -> None:
            self.received.append(time.time())
            on_index(i)

        return noted

    def add(self, events: list[list[float]], origin_ms: float) -> None:
        """One click's page events (SCRUB_JS), the page's time origin [ms since the epoch]."""
        at = {k: [e[1] for e in events if e[0] == k] for k in ("down", "sent", "batch", "text")}
        down = at["down"][0]
        text = next(t for t in at["text"] if t > down)
        reply = max(t for t in at["batch"] if down < t <= text)  # carried the panel's text
        starts = [e[1] for e in events if e[0] == "frame" and e[1] >= reply]
        drawn = min(e[1] for e in events if e[0] == "frame_end" and e[1] >= starts[0])
        server = 1e3 * self.received[-1] - origin_ms
        for k, t in zip(self.STAGES, (at["sent"][0], server, reply, text, max(text, drawn)),
                        strict=True):  # fmt: skip
            self.times[k].append(t - down)

    def median(self, stage: str) -> float:
        return statistics.median(self.times[stage])


def scrub_page(browser: Any, url: str, scrubs: Scrubs, ready: Callable[[Any], bool]) -> float:
    """Click the timeline at random places on a 1200x800 page, timing each scrub; the seconds
    from loading the page to its first frame with `ready` true."""
    page = browser.new_page(viewport={"width": 1200, "height": 800})
    page.add_init_script(SCRUB_JS)
    t = time.perf_counter()
    page.goto(url)
    page.wait_for_selector("canvas", timeout=60_000)
    probe.wait_for(lambda: ready(page), 120, 0.05)
    first = time.perf_counter() - t
    time.sleep(1.0)  # past viser's settle frames after loading
    rng = np.random.default_rng(SEED)
    for f in rng.uniform(0.05, 0.95, 8 if quick() else 20):
        page.evaluate("() => { window.__scrub.length = 0; }")
        origin = page.evaluate("() => performance.timeOrigin")
        probe.click_track(page, "time [s]", float(f))
        time.sleep(0.4)
        scrubs.add(page.evaluate("() => window.__scrub"), origin)
    page.close()
    return first


def minimal_scrubs(browser: Any) -> tuple[Scrubs, float]:
    """The peer: viser's floor on this browser and machine, a page with nothing but a timeline
    slider, one needle-coloured line it moves and one line of text, scrubbed and timed the same
    way."""
    server = start_server("127.0.0.1", 0)
    scrubs = Scrubs()
    line = np.array([[[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]]])
    needle = server.scene.add_line_segments("/needle", line, colors.NEEDLE, thickness=4.0,
                                            thickness_units="screen")  # fmt: skip
    text = server.gui.add_markdown("")
    slider = server.gui.add_slider("time [s]", min=0.0, max=1.0, step=1e-3, initial_value=0.0)

    def show(i: int) -> None:
        with server.atomic():
            needle.position = (0.5 * i / 1000, 0.0, 0.0)
            text.content = f"time (record {i})"

    on_index = scrubs.hook(show)
    slider.on_update(lambda _e: on_index(round(1000 * slider.value)))
    try:
        first = scrub_page(browser, address(server, "127.0.0.1"), scrubs, seen)
    finally:
        stop_server(server)
    return scrubs, first


def view_scrubs(browser: Any, server: Any, view: ReplayView) -> tuple[Scrubs, float]:
    """Scrubs of the run's view (its timeline's updates timed on the server too)."""
    scrubs = Scrubs()
    view.timeline.on_index = scrubs.hook(view.timeline.on_index)
    return scrubs, scrub_page(browser, address(server, "127.0.0.1"), scrubs, seen)


def seen(page: Any) -> bool:
    """The needle's colour is on screen (the view's needle; the floor page's line)."""
    return len(probe.needle_pixels(probe.screenshot(page))) > 30


def browser_rows(server: Any, view: ReplayView) -> list[dict[str, Any]]:
    """First frame, playback and scrub latency in a real browser (software WebGL)."""
    pw = probe.start_playwright()
    browser = probe.launch(pw)
    try:
        scrubs, first = view_scrubs(browser, server, view)
        floor, floor_first = minimal_scrubs(browser)
        page = browser.new_page(viewport={"width": 1200, "height": 800})
        page.goto(address(server, "127.0.0.1"))
        page.wait_for_selector("canvas", timeout=60_000)
        probe.wait_for(lambda: seen(page), 120, 0.05)
        page.evaluate(COUNT_JS)
        page.get_by_role("button", name="Play").click()
        probe.wait_for(lambda: view.timeline.playing, 30.0, 0.01)
        shows, dom, t = view.shows, page.evaluate("() => window.__updates"), time.perf_counter()
        time.sleep(2.0)
        played_hz = (view.shows - shows) / (time.perf_counter() - t)
        dom_hz = (page.evaluate("() => window.__updates") - dom) / (time.perf_counter() - t)
        page.get_by_role("button", name="Pause").click()
        page.close()
    finally:
        browser.close()
        pw.stop()
    return [
        row("open: page load to the first frame drawn (1200x800, software WebGL)", first, "s",
            "the floor page", floor_first, "<= 2 s"),
        row("play at 1x: records shown per second (server)", played_hz, "1/s", "", None,
            ">= 30/s"),
        row("play at 1x: panel updates per second in the browser", dom_hz, "1/s", "", None, ""),
        row(f"scrub in the browser: click on the timeline to the scene drawn, 1200x800 "
            f"(median of {len(scrubs.times['drawn'])})", scrubs.median("drawn"), "ms",
            "viser's floor here: a page with only a slider, a line and a line of text",
            floor.median("drawn"), "<= 50 ms"),
        *[row(f"scrub in the browser, stage: click to {what}", scrubs.median(k), "ms",
              "the floor page", floor.median(k), "")
          for k, what in (("sent", "the update sent (the slider's next animation frame)"),
                          ("server", "the update received by the server"),
                          ("reply", "the scene and panel update received by the page"),
                          ("text", "the panel's text changed"))],
    ]  # fmt: skip


# What to hide per part: handles to make invisible (a frame added at a node's name replaces
# that node, so the eye's spheres and the markers go with it).
PARTS = {
    "robot": lambda v: list(getattr(v.links, "frames", {}).values()),
    "trace": lambda v: [t for t in v.traces if t is not None],
    "retina": lambda v: [v.server.scene.add_frame("/eye/retina", show_axes=False)],
    "eye wall": lambda v: [v.server.scene.add_frame("/eye/sclera", show_axes=False)],
    "markers and labels": lambda v: [v.server.scene.add_frame("/points", show_axes=False)],
}


def parts_rows(runs: list[Any]) -> list[dict[str, Any]]:
    """Scrub in the browser with one part of the scene hidden at a time (`--parts`): what each
    part costs a scrub, beside the whole scene and the floor page, in one browser."""
    pw = probe.start_playwright()
    browser = probe.launch(pw)
    medians: dict[str, float] = {}
    try:
        for part in ("none", *PARTS):
            server = start_server("127.0.0.1", 0)
            view = ReplayView(server, runs)
            try:
                for handle in PARTS[part](view) if part in PARTS else []:
                    handle.visible = False
                medians[part] = view_scrubs(browser, server, view)[0].median("drawn")
            finally:
                view.close()
                stop_server(server)
        floor = minimal_scrubs(browser)[0].median("drawn")
    finally:
        browser.close()
        pw.stop()
    return [
        row(f"scrub in the browser, click to scene drawn, {what}", medians[part], "ms",
            "viser's floor page", floor, "<= 50 ms")
        for part, what in (("none", "the whole scene"),
                           *((p, f"the {p} hidden") for p in PARTS))
    ]  # fmt: skip


def scripted_drag(
    push: Callable[[np.ndarray], None], centre: np.ndarray, stop: threading.Event, seconds: float
) -> None:
    """Push a target (base frame) circling the start point (2 mm radius, 5 mm/s) for
    `seconds`."""
    t0 = time.perf_counter()
    while not stop.is_set() and (t := time.perf_counter() - t0) < seconds:
        a = 2.5 * t  # rad/s: 5 mm/s on a 2 mm circle
        push(centre + 2e-3 * np.array([np.sin(a), 1.0 - np.cos(a), 0.0]))
        time.sleep(0.01)


def control_alone(seconds: float, realtime: bool) -> float:
    """Missed fraction of the control with no view (the peer)."""
    from rcmplan.teleop import LiveInput
    from rcmplan.view.live import live_settings
    from rcmplan.view.live_control import run_live

    s = live_settings("default", None, "kinematic", realtime)
    inp, stop, out = LiveInput(s.to_master(s.start_tip)), threading.Event(), {}
    inp.push(s.to_master(s.start_tip))
    th = threading.Thread(target=lambda: out.setdefault("st", run_live(s, inp, stop)))
    th.start()
    scripted_drag(lambda p: inp.push(s.to_master(p)), s.start_tip, threading.Event(), seconds)
    stop.set()
    th.join()
    return float(out["st"].missed / out["st"].slots)


def live_run(seconds: float, browser: bool) -> dict[str, Any]:
    """Missed fraction, redraw rate and the largest RCM deviation during a scripted drag with
    the view redrawing (and, with `browser`, a Chromium page rendering it)."""
    from rcmplan.view.live import LiveView, live_settings

    server = start_server("127.0.0.1", 0)
    view = LiveView(server, live_settings("default", None, "kinematic"))
    pw = chromium = None
    try:
        if browser:
            pw = probe.start_playwright()
            chromium = probe.launch(pw)
            page = chromium.new_page(viewport={"width": 1200, "height": 800})
            page.goto(address(server, "127.0.0.1"))
            probe.wait_for(lambda: len(probe.needle_pixels(probe.screenshot(page))) > 30, 120)
        time.sleep(0.5)
        s0, u0, t0 = view.state(), view.updates, time.perf_counter()

        def move(p: np.ndarray) -> None:  # as a browser's drag: the gizmo moves, the view sends
            view.gizmo.position = p
            view.send()

        scripted_drag(move, view.settings.start_tip, threading.Event(), seconds)
        s1, u1, t1 = view.state(), view.updates, time.perf_counter()
    finally:
        view.close()
        if chromium is not None:
            chromium.close()
            pw.stop()
        stop_server(server)
    return {
        "missed": (s1["missed"] - s0["missed"]) / max(1, s1["slots"] - s0["slots"]),
        "view_hz": (u1 - u0) / (t1 - t0),
        "rcm_um": 1e6 * s1["max_rcm_deviation_m"],
        "scheduling": view.latest.scheduling if view.latest else "",
    }


def live_rows() -> list[dict[str, Any]]:
    seconds = 2.0 if quick() else 4.0
    normal = control_alone(seconds, realtime=False)
    alone = control_alone(seconds, realtime=True)
    headless = live_run(seconds, browser=False)
    missing = browser_missing()
    shown = live_run(seconds, browser=True) if not missing else {
        "missed": float("nan"), "view_hz": float("nan"), "rcm_um": float("nan"),
        "scheduling": headless["scheduling"],
    }  # fmt: skip
    return [
        row("live, 1 kHz control alone (no view): missed periods during a drag, real-time "
            "thread", 100 * alone, "%", "the same, normal scheduling", 100 * normal, "<= 5 %"),
        row("live: missed periods, view redrawing (no browser)", 100 * headless["missed"], "%",
            "the control alone, normal scheduling", 100 * normal, "<= 5 %"),
        row("live: view redraws per second (no browser)", headless["view_hz"], "1/s", "", None,
            ">= 30/s"),
        row("live: largest RCM deviation during the drag, kinematic plant", headless["rcm_um"],
            "um", "", None, "<= 1 um"),
        row("live: missed periods with a Chromium page rendering it (software WebGL, same "
            "cores)", 100 * shown["missed"], "%", "the control alone, normal scheduling",
            100 * normal, "<= 5 %"),
        row("live: view redraws per second with the browser", shown["view_hz"], "1/s", "", None,
            ">= 30/s"),
        row("live: largest RCM deviation during the drag with the browser", shown["rcm_um"],
            "um", "", None, "<= 1 um"),
        row("live: the control thread's scheduling", shown["scheduling"], "", "", None, ""),
    ]  # fmt: skip


def rows(run_dir: Path | None = None) -> list[dict[str, Any]]:
    """Every figure of the view."""
    given = run_dir or os.environ.get("RCMPLAN_BENCH_VIEW_RUN")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(given) if given else mujoco_run(Path(tmp) / "mujoco")
        out, server, view = open_rows(folder)
        try:
            n = 50 if quick() else 200
            times = scrub_server_ms(view, n)
            out += [
                row("open: `rcmplan view RUN` process start to its address line",
                    cold_start_s(folder), "s", "", None, "<= 2 s"),
                row(f"scrub: scene update on the server (median of {n} random records)",
                    statistics.median(times), "ms", "MuJoCo offscreen render of the pose, "
                    "640x480 (`rcmplan render`'s way)", render_pose_ms(view, 20), "<= 50 ms"),
                row(f"scrub: scene update on the server (95th percentile of {n})",
                    float(np.percentile(times, 95)), "ms", "", None, "<= 50 ms"),
            ]  # fmt: skip
            missing = browser_missing()
            out += browser_rows(server, view) if not missing else [
                row(f"browser figures: not measured ({missing})", "skipped", "", "", None, "")
            ]  # fmt: skip
        finally:
            view.close()
            stop_server(server)
    out += live_rows()
    out.append(row("machine", load_note(), "", "", None, ""))
    return out


if __name__ == "__main__":
    from run import print_table

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=Path, help="a MuJoCo run folder (default: make one)")
    ap.add_argument(
        "--parts",
        action="store_true",
        help="only the browser scrub with each part of the scene hidden in turn",
    )
    args = ap.parse_args()
    if args.parts:
        if args.run is None:
            ap.error("--parts needs --run DIR")
        print_table(parts_rows(load_runs(args.run)))
    else:
        print_table(rows(args.run))
