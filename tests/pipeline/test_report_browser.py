"""The report in a real browser (issue 32, item 4): Chromium, driven by Playwright for Python.

A small report (one chain, one molecule, one network) is built into a temporary folder and every
page is opened from disk: no console error, every image, link and script resolves to a file of
the folder (and every image decodes), the interactive 3-D view starts (a WebGL canvas) and
animates (its pixels change between frames), and a 1280x1080 screenshot of each page is kept
(in ``$VIBRA_SCREENSHOTS`` when set, as CI does, else in the test's temporary folder).

Playwright's Python driver is in the ``test`` extra, so the README's test command runs this
test (issue 48). The browser is the distribution's Chromium (``apt-get install chromium``; the
``chromium`` or ``chromium-browser`` executable on the path, or the one ``$VIBRA_CHROMIUM``
names), else one Playwright installed itself (``playwright install chromium``). Skipped, saying
so, only where there is no Chromium executable at all.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from urllib.parse import unquote, urlparse

import numpy as np
import pytest
from helpers.browser import SKIP_REASON, chromium, pixels as _pixels
from playwright.sync_api import sync_playwright

from vibra.pipeline.report import report

ROOT = Path(__file__).resolve().parents[2]
CHROMIUM = chromium()
SCENES = [ROOT / "chains" / "diatomic.toml", ROOT / "molecules" / "h2o.toml",
          ROOT / "networks" / "ubiquitin" / "ubiquitin-anm.toml"]
SCREEN = {"width": 1280, "height": 1080}

pytestmark = pytest.mark.skipif(CHROMIUM is None, reason=SKIP_REASON)

_LINKS = """() => Array.from(document.querySelectorAll("img[src], script[src], a[href], link[href]"))
    .map(e => e.src || e.href)"""
_IMAGES = """() => Promise.all(Array.from(document.images).map(img => {
    img.loading = "eager";
    return img.decode().then(() => [img.src, img.naturalWidth], () => [img.src, 0]);
}))"""


def _local_file(url: str, out: Path) -> Path:
    parsed = urlparse(url)
    assert parsed.scheme == "file", f"{url}: not a file of the report (the report works offline)"
    path = Path(unquote(parsed.path)).resolve()
    assert path.is_file() and out.resolve() in path.parents, f"{url}: no such file in the report"
    return path


def test_report_pages_in_chromium(tmp_path: Path) -> None:
    out = tmp_path / "report"
    result = report(SCENES, out, progress=False, window_size=(480, 320))
    assert not result.failed, [o.error for o in result.failed]
    shots = Path(os.environ.get("VIBRA_SCREENSHOTS") or tmp_path / "screenshots")
    shots.mkdir(parents=True, exist_ok=True)
    pages = [out / "index.html", out / "references.html", *sorted((out / "scenes").glob("*.html"))]
    assert len(pages) == 2 + len(SCENES)
    assert CHROMIUM is not None
    with sync_playwright() as driver:
        browser = driver.chromium.launch(executable_path=CHROMIUM)
        try:
            views = 0
            for path in pages:
                page = browser.new_page(viewport=SCREEN)
                errors: list[str] = []
                page.on("console", lambda message: errors.append(message.text) if message.type == "error" else None)
                page.on("pageerror", lambda error: errors.append(str(error)))
                page.on("requestfailed", lambda request: errors.append(f"failed to load {request.url}"))
                page.goto(path.as_uri(), wait_until="load")
                for url in page.evaluate(_LINKS):
                    _local_file(url, out)
                for url, width in page.evaluate(_IMAGES):
                    assert width > 0, f"{path.name}: image {url} does not decode"
                if page.locator(".vibra-view .view-mode").count():  # a crystal's view: tests/_results/test_viewer_browser.py
                    canvas = page.locator(".view3d canvas").first
                    canvas.wait_for(state="visible", timeout=30_000)
                    canvas.scroll_into_view_if_needed()
                    frames = []
                    for _ in range(4):
                        frames.append(_pixels(canvas.screenshot()))
                        time.sleep(0.4)
                    assert frames[0].std() > 5.0, f"{path.name}: the 3-D view is blank"
                    changed = max(float(np.abs(f - frames[0]).mean()) for f in frames[1:])
                    assert changed > 0.0, f"{path.name}: the 3-D view does not animate"
                    page.select_option(".view-mode", index=page.locator(".view-mode option").count() - 1)
                    page.eval_on_selector(".view-amplitude", "e => { e.value = '2.5'; "
                                          "e.dispatchEvent(new Event('input')); }")
                    page.click(".view-play")  # pause, then play: the frames are rebuilt each time
                    page.click(".view-play")
                    assert _pixels(canvas.screenshot()).std() > 5.0, f"{path.name}: blank after the controls"
                    views += 1
                    page.evaluate("window.scrollTo(0, 0)")
                if path.name == "index.html":
                    height = page.evaluate("document.documentElement.scrollHeight")
                    assert height < 3 * SCREEN["height"], f"index.html is {height} px tall"
                page.screenshot(path=str(shots / f"{path.parent.name}-{path.stem}.png"))
                assert errors == [], f"{path.name}: {errors}"
                page.close()
            assert views == len(SCENES)  # the chain, the molecule and the network each have a view
        finally:
            browser.close()
