"""The view seen by a real browser, for tests and benchmarks: Chromium (the system's, driven
by playwright; playwright's own browser download is not used), screenshots as arrays, and the
needle found on screen by its colour (`colors.NEEDLE`, used by nothing else in the scene).

Needs playwright (extra `dev`) and a Chromium on PATH (Debian: `apt-get install chromium`;
`scripts/check.sh` installs it). WebGL runs in software (SwiftShader) without a GPU.
"""

from __future__ import annotations

import io
import shutil
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rcmplan._validate import FloatArray
from rcmplan.exceptions import RcmplanError, require_extra
from rcmplan.view import colors

BROWSERS = ("chromium", "chromium-browser", "google-chrome")
ARGS = ("--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader")
Image = NDArray[np.uint8]


def chromium_path() -> str | None:
    """The system's Chromium, or None."""
    for name in BROWSERS:
        if path := shutil.which(name):
            return path
    return None


def launch(playwright: Any) -> Any:
    """A headless Chromium browser (the system's) from a started playwright."""
    path = chromium_path()
    if path is None:
        raise RcmplanError("no Chromium on PATH (Debian: apt-get install chromium)")
    return playwright.chromium.launch(executable_path=path, args=list(ARGS))


def start_playwright() -> Any:
    """A started sync playwright (call `.stop()` when done)."""
    return require_extra("playwright.sync_api", "dev").sync_playwright().start()


SCREENSHOT_TIMEOUT_MS = 120_000  # a software-rendered page on a loaded 2-core machine is slow


def screenshot(page: Any) -> Image:
    """The page as RGB pixels (height, width, 3)."""
    from PIL import Image as PilImage

    png = page.screenshot(timeout=SCREENSHOT_TIMEOUT_MS)
    return np.asarray(PilImage.open(io.BytesIO(png)).convert("RGB"), dtype=np.uint8)


def scene_region(image: Image) -> Image:
    """The part of a screenshot where only the 3D scene is drawn: left of viser's panel
    (the right third) and below its notifications (the top fifth)."""
    h, w = image.shape[:2]
    return image[h // 5 :, : (2 * w) // 3]


def needle_pixels(image: Image, tolerance: int = 40) -> NDArray[np.int64]:
    """(row, column) of the pixels drawn in the needle's colour, (k, 2)."""
    diff = np.abs(image.astype(int) - np.array(colors.NEEDLE)).max(axis=2)
    return np.argwhere(diff <= tolerance)


def needle_centre(image: Image) -> FloatArray:
    """Mean (row, column) of the needle's pixels; NaN if none is seen."""
    px = needle_pixels(image)
    return px.mean(axis=0) if len(px) else np.full(2, np.nan)


def wait_for(check: Callable[[], bool], timeout_s: float = 30.0, poll_s: float = 0.1) -> float:
    """Poll until check() is true; the seconds it took. TimeoutError after timeout_s."""
    start = time.perf_counter()
    while not check():
        if time.perf_counter() - start > timeout_s:
            raise TimeoutError(f"not reached within {timeout_s} s")
        time.sleep(poll_s)
    return time.perf_counter() - start


def slider_track(page: Any, label: str) -> Any:
    """The track of the viser slider labelled `label` (a locator)."""
    target = page.locator("label", has_text=label).first.get_attribute("for")
    return page.locator(f"[id='{target}'] .mantine-Slider-track").first


def click_track(page: Any, label: str, fraction: float) -> None:
    """Click the slider labelled `label` at a fraction of its track (0: left end)."""
    box = slider_track(page, label).bounding_box()
    page.mouse.click(box["x"] + fraction * box["width"], box["y"] + 0.5 * box["height"])


def project(camera: Any, point: FloatArray) -> FloatArray:
    """Canvas pixel (u right, v down) of a world point [m] seen by a viser client's camera
    (OpenCV convention: the camera looks along its +z, +y down; `fov` is vertical)."""
    from viser import transforms as tf

    R = tf.SO3(np.asarray(camera.wxyz)).as_matrix()
    x = R.T @ (np.asarray(point, dtype=float) - np.asarray(camera.position))
    f = 0.5 * camera.image_height / np.tan(0.5 * camera.fov)
    return np.array([0.5 * camera.image_width + f * x[0] / x[2],
                     0.5 * camera.image_height + f * x[1] / x[2]])  # fmt: skip


SCENE_CANVAS_JS = """() => {
  let best = null;
  for (const c of document.querySelectorAll("canvas")) {
    const r = c.getBoundingClientRect();
    if (best === null || r.width * r.height > best.w * best.h)
      best = {x: r.x, y: r.y, w: r.width, h: r.height};
  }
  return best;
}"""


def scene_canvas_origin(page: Any) -> tuple[float, float]:
    """Page position (x, y) [px] of the 3D scene's canvas: the page's largest (viser also
    adds a 0 x 0 canvas, which may come first in the document)."""
    box = page.evaluate(SCENE_CANVAS_JS)
    if box is None or box["w"] * box["h"] == 0:
        raise RuntimeError(f"the page shows no 3D scene canvas (largest canvas: {box})")
    return float(box["x"]), float(box["y"])


def drag(page: Any, start: FloatArray, end: FloatArray, steps: int = 20) -> None:
    """Press the mouse at the scene canvas's pixel `start`, move it to `end` in steps,
    release."""
    ox, oy = scene_canvas_origin(page)
    page.mouse.move(ox + start[0], oy + start[1])
    page.mouse.down()
    for k in range(1, steps + 1):
        p = start + (end - start) * k / steps
        page.mouse.move(ox + p[0], oy + p[1])
    page.mouse.up()
