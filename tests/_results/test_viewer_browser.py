"""The interactive views in a real browser (issue 46, item 5): Chromium, driven by Playwright.

(a) A notebook output: three ``_repr_html_`` outputs, ``modes.show(system)`` of a molecule and a
chain and ``bands.show(crystal)``, written into one HTML file as Jupyter would show them in three
cells: each modes view starts its own
WebGL canvas (element ids of their own), draws (non-blank pixels), and choosing another mode
changes the frames (the model's frame coordinates; a paused view shows the rest positions,
the same for every mode); the crystal's bands are drawn and a click picks another mode; 3Dmol.js is inlined (once per
output), so the page makes no request beyond its own file.

(b) A crystal's report page (``vibra report`` on a small diamond scene): the band structure is
drawn (SVG), the 3-D view draws, clicking a point of the bands changes the animation, the page's
frames are the ones `vibra.crystals.animation.frame_positions` computes from the same data (whose
agreement with phonopy's modulation tests/_results/test_viewer.py checks), and nothing leaves the folder.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from urllib.parse import urlparse

import numpy as np
import pytest
from helpers.browser import SKIP_REASON, chromium, pixels
from playwright.sync_api import Page, sync_playwright

import vibra
from vibra import crystals, molecules
from vibra.crystals.animation import frame_positions
from vibra.pipeline.report import report

CHROMIUM = chromium()
SCREEN = {"width": 1100, "height": 900}
#: The page's frames and numpy's: the same double-precision sums (sines and cosines of the same
#: angles, products of numbers read from the same JSON), so agreement to 1e-9 Å (positions ~10 Å).
FRAME_ATOL = 1e-9

pytestmark = pytest.mark.skipif(CHROMIUM is None, reason=SKIP_REASON)

CRYSTAL_SCENE = """
kind = "crystal"
title = "Diamond, nearest-neighbour springs"
units = "ASE"

[system]
builder = "diamond"
a = 5.431
masses = 28.0855
stiffness = 9.4
transverse = 1.0

[compute]
npoints = 80
mesh = [4, 4, 4]

[draw]
bands = true
"""


def _watch(page: Page) -> tuple[list[str], list[str]]:
    """(errors, requests): console errors and page errors, and every URL the page asked for."""
    errors: list[str] = []
    requests: list[str] = []
    page.on("console", lambda message: errors.append(message.text) if message.type == "error" else None)
    page.on("pageerror", lambda error: errors.append(str(error)))
    page.on("request", lambda request: requests.append(request.url))
    return errors, requests


def _offline(requests: list[str], folder: Path) -> None:
    for url in requests:
        parsed = urlparse(url)
        assert parsed.scheme in ("file", "data", "blob"), f"a network request: {url}"
        if parsed.scheme == "file":
            assert folder.resolve() in Path(parsed.path).resolve().parents, f"{url}: outside the folder"


def _canvas_frames(page: Page, selector: str, count: int = 3) -> list[np.ndarray]:
    canvas = page.locator(selector)
    canvas.wait_for(state="visible", timeout=30_000)
    canvas.scroll_into_view_if_needed()
    shots = []
    for _ in range(count):
        shots.append(pixels(canvas.screenshot()))
        time.sleep(0.3)
    return shots


def test_notebook_outputs_in_chromium(tmp_path: Path) -> None:
    water = molecules.molecule("water")
    chain = vibra.System.from_springs(np.arange(8.0)[:, None], [1.0, 2.0] * 4,
                                      [[i, i + 1] for i in range(7)], 1.0)
    salt = crystals.rock_salt(5.64, [22.99, 35.45], 1.0, units="ASE")
    cells = [water.modes().show(water)._repr_html_(), chain.modes().show(chain)._repr_html_(),
             salt.band_structure(npoints=40).show(salt)._repr_html_()]
    page_file = tmp_path / "notebook" / "outputs.html"
    page_file.parent.mkdir()
    page_file.write_text("<!DOCTYPE html><html><head><meta charset='utf-8'></head><body>"
                         + "".join(f"<div class='output'>{cell}</div>" for cell in cells) + "</body></html>",
                         encoding="utf-8")
    assert CHROMIUM is not None
    with sync_playwright() as driver:
        browser = driver.chromium.launch(executable_path=CHROMIUM)
        try:
            page = browser.new_page(viewport=SCREEN)
            page.set_default_timeout(90_000)  # three WebGL views in software on a loaded machine
            errors, requests = _watch(page)
            page.goto(page_file.as_uri(), wait_until="load")
            roots = page.locator(".vibra-view")
            assert roots.count() == 3
            ids = page.eval_on_selector_all(".vibra-view", "rs => rs.map(r => r.id)")
            assert len(set(ids)) == 3
            page.evaluate(f"document.getElementById('{ids[2]}').vibra.viewer.stopAnimate()")  # one animation at a time
            for n in range(2):  # the two modes views
                selector = f"#{ids[n]} .view3d canvas"
                assert page.locator(selector).count() == 1  # each output drew into its own box
                shots = _canvas_frames(page, selector)
                assert shots[0].std() > 5.0, f"output {n}: the 3-D view is blank"
                assert max(float(np.abs(s - shots[0]).mean()) for s in shots[1:]) > 0.0, f"output {n}: no motion"
                page.click(f"#{ids[n]} .view-play")  # pause: the frame shown holds still
                before = page.evaluate(f"document.getElementById('{ids[n]}').vibra.viewer.getModel().frames"
                                       ".map(f => f.map(a => [a.x, a.y, a.z]))")
                page.select_option(f"#{ids[n]} .view-mode", index=page.locator(f"#{ids[n]} .view-mode option").count() - 1)
                after = page.evaluate(f"document.getElementById('{ids[n]}').vibra.viewer.getModel().frames"
                                      ".map(f => f.map(a => [a.x, a.y, a.z]))")
                assert np.abs(np.asarray(after) - np.asarray(before)).max() > 1e-3, f"output {n}: same frames"
                page.click(f"#{ids[n]} .view-play")  # play again: the new frames, drawn
                assert pixels(page.locator(selector).screenshot()).std() > 5.0, f"output {n}: blank after the menu"
                page.click(f"#{ids[n]} .view-play")  # and pause it: one animation at a time
            # the crystal's output: its bands drawn, its supercell drawn, a click picks another mode
            api = f"document.getElementById('{ids[2]}').vibra"
            assert page.locator(f"#{ids[2]} .bands svg polyline").count() >= 6
            assert _canvas_frames(page, f"#{ids[2]} .view3d canvas", count=1)[0].std() > 5.0, "the crystal is blank"
            before = page.evaluate(f"{api}.picked")
            x, y = page.evaluate(f"{api}.where(0, 3)")  # Gamma, the lowest optical branch
            page.mouse.click(x, y)
            assert page.evaluate(f"{api}.picked") == [0, 3] != before
            page.screenshot(path=str(tmp_path / "notebook.png"), full_page=True)
            _offline(requests, page_file.parent)
            assert len(requests) == 1  # the page itself: 3Dmol.js and the view script are inlined
            assert errors == [], errors
        finally:
            browser.close()


def test_crystal_page_in_chromium(tmp_path: Path) -> None:
    scene = tmp_path / "diamond.toml"
    scene.write_text(CRYSTAL_SCENE, encoding="utf-8")
    out = tmp_path / "report"
    result = report([scene], out, progress=False, window_size=(480, 320))
    assert not result.failed, [o.error for o in result.failed]
    data = json.loads((out / "diamond_view.json").read_text(encoding="utf-8"))
    assert CHROMIUM is not None
    with sync_playwright() as driver:
        browser = driver.chromium.launch(executable_path=CHROMIUM)
        try:
            page = browser.new_page(viewport=SCREEN)
            errors, requests = _watch(page)
            page.goto((out / "scenes" / "diamond.html").as_uri(), wait_until="load")
            assert page.locator(".vibra-view .bands svg polyline").count() >= 6  # 6 branches, one run or more
            root = page.locator(".vibra-view").first
            uid = root.get_attribute("id")
            api = f"document.getElementById('{uid}').vibra"
            shots = _canvas_frames(page, f"#{uid} .view3d canvas")
            assert shots[0].std() > 5.0, "the crystal's 3-D view is blank"
            assert max(float(np.abs(s - shots[0]).mean()) for s in shots[1:]) > 0.0, "the crystal does not move"
            start = page.evaluate(f"{api}.picked")
            assert start == data["start"]
            frames = np.asarray(page.evaluate(f"{api}.frames"))
            ours, _ = frame_positions(data, *start)
            np.testing.assert_allclose(frames, ours, rtol=0, atol=FRAME_ATOL)
            # click another point: a third of the way along the path, the lowest branch
            target = (len(data["points"]) // 3, 0)
            assert data["bands"]["values"][data["points"][target[0]]["index"]][0] > 0.1
            x, y = page.evaluate(f"{api}.where({target[0]}, {target[1]})")
            page.mouse.click(x, y)
            assert page.evaluate(f"{api}.picked") == list(target)
            clicked = np.asarray(page.evaluate(f"{api}.frames"))
            assert clicked.shape != frames.shape or np.abs(clicked - frames).max() > 1e-3
            ours, imaginary = frame_positions(data, *target)
            np.testing.assert_allclose(clicked, ours, rtol=0, atol=FRAME_ATOL)
            assert not imaginary and "one period" in page.inner_text(f"#{uid} .picked")
            assert page.evaluate(f"{api}.viewer.getModel().getNumFrames()") == data["frames"]
            shots = _canvas_frames(page, f"#{uid} .view3d canvas")
            assert shots[0].std() > 5.0, "blank after the click"
            page.screenshot(path=str(tmp_path / "crystal.png"), full_page=True)
            _offline(requests, out)
            assert errors == [], errors
        finally:
            browser.close()
