"""report.html in a real browser (headless Chromium): no horizontal scrolling, every figure
decoded. scripts/check.sh installs Chromium and sets RCMPLAN_REQUIRE_BROWSER, so in CI this
test runs; elsewhere it is skipped when no Chromium is installed."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from rcmplan.analysis.report import write_outputs
from rcmplan.job import run_scenario
from rcmplan.scene.scenario import load_scenario

PROBE = (
    "<script>window.addEventListener('load', () => {"
    "const d = document.documentElement;"
    "document.body.dataset.overflowPx = String(d.scrollWidth - d.clientWidth);"
    "document.body.dataset.brokenImages = String([...document.images]"
    ".filter(i => !i.complete || i.naturalWidth === 0).length);"
    "document.body.dataset.images = String(document.images.length);});</script>"
)


def chromium() -> str:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if path := shutil.which(name):
            return path
    if os.environ.get("RCMPLAN_REQUIRE_BROWSER"):
        pytest.fail("no Chromium on PATH, and RCMPLAN_REQUIRE_BROWSER is set (scripts/check.sh)")
    pytest.skip("no Chromium on PATH (scripts/check.sh installs it)")


def body_attributes(page: Path, width_px: int) -> dict[str, str]:
    probed = page.with_name("probed.html")
    probed.write_text(page.read_text().replace("</body>", PROBE + "</body>"))
    cmd = [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
           "--disable-background-networking", "--disable-component-update", "--disable-sync",
           f"--window-size={width_px},900", "--dump-dom", probed.as_uri()]  # fmt: skip
    dom = subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=True).stdout
    body = re.search(r"<body([^>]*)>", dom)
    assert body is not None, dom[:500]
    return dict(re.findall(r'data-([a-z-]+)="([^"]*)"', body.group(1)))


@pytest.fixture(scope="module", params=["default", "grazing-spiral"])
def report(request, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp(request.param)
    write_outputs(run_scenario(load_scenario(request.param)), out)
    return out / "report.html"


def test_the_probe_sees_a_page_wider_than_the_window(tmp_path) -> None:
    page = tmp_path / "wide.html"
    page.write_text("<html><body><div style='width:3000px'>wide</div></body></html>")
    assert int(body_attributes(page, 800)["overflow-px"]) > 0


@pytest.mark.parametrize("width_px", [1200, 720])
def test_report_fits_the_window_and_every_figure_decodes(report, width_px) -> None:
    attrs = body_attributes(report, width_px)
    assert attrs["images"] == "3"
    assert attrs["broken-images"] == "0"
    assert attrs["overflow-px"] == "0"
