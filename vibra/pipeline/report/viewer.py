"""The interactive 3-D view of a scene page: 3Dmol.js, vendored, fed the plan's view data.

3Dmol.js (BSD-3-Clause, https://3dmol.csb.pitt.edu, from its npm package ``3dmol``) ships in
``vibra/pipeline/report/assets/`` with its licence; `copy_assets` puts one copy in the report's
``assets/`` folder, so every page works from disk without a network. A scene's view data
(`vibra.pipeline.plan.views.mode_view`, stored as ``<scene>_view.json``) is inlined in its page:
the page builds an XYZ model with one displacement vector per atom, sets vibra's bonds, lets
3Dmol.js make the frames (``model.vibrate``) and animates them back and forth; a mode menu and
an amplitude slider rebuild the frames.
"""

from __future__ import annotations

import html
import json
from importlib import resources
from pathlib import Path
from typing import Any

from vibra._core.filesystem import atomic_write_bytes

__all__ = ["ASSETS", "ASSET_FILES", "VIEW_SUFFIX", "copy_assets", "view_html", "read_view"]

#: The report's folder of vendored scripts and their licences.
ASSETS = "assets"
#: The vendored files: the minified 3Dmol.js and its licences.
ASSET_FILES = ("3Dmol-min.js", "3Dmol-min.js.LICENSE.txt", "3Dmol-LICENSE.txt")
#: The name ending of a scene's view data among its outputs.
VIEW_SUFFIX = "_view.json"

_SCRIPT = """
(function () {
  var box = document.getElementById("view3d");
  var data = JSON.parse(document.getElementById("view-data").textContent);
  var menu = document.getElementById("view-mode");
  var amplitude = document.getElementById("view-amplitude");
  var button = document.getElementById("view-play");
  var styles = {  // a chain's masses: one colour per distinct mass (lightest carbon grey, then red, blue ...)
    molecule: {stick: {radius: 0.12}, sphere: {scale: 0.24}},
    network: {sphere: {radius: 0.9}, stick: {radius: 0.3, color: "#8a9bb0"}},
    chain: {sphere: {radius: 0.7}, stick: {radius: 0.12, color: "#999999"}}
  };
  var running = true;
  if (typeof $3Dmol === "undefined" || !$3Dmol.createViewer) {
    box.textContent = "The 3-D view needs assets/3Dmol-min.js next to this report.";
    return;
  }
  var viewer = $3Dmol.createViewer(box, {backgroundColor: "white", antialias: true, minimumZoomToDistance: 1});
  if (!viewer) {
    box.textContent = "The 3-D view needs WebGL, which this browser does not offer.";
    return;
  }
  window.vibraView = viewer;  // for the browser test (vibra's tests/test_report_browser.py)
  function xyz(k) {
    var vectors = data.modes[k].vectors, lines = [String(data.positions.length), data.modes[k].label];
    for (var i = 0; i < data.positions.length; i++) {
      var p = data.positions[i], v = vectors[i];
      lines.push([data.elements[i], p[0], p[1], p[2], v[0], v[1], v[2]].join(" "));
    }
    return lines.join("\\n");
  }
  function show(frame) {
    viewer.stopAnimate();
    viewer.removeAllModels();
    var model = viewer.addModel(xyz(Number(menu.value)), "xyz", {assignBonds: false});
    var atoms = model.selectedAtoms({});
    atoms.forEach(function (atom, i) { atom.index = i; atom.bonds = []; atom.bondOrder = []; });
    data.bonds.forEach(function (b) {
      atoms[b[0]].bonds.push(b[1]); atoms[b[0]].bondOrder.push(1);
      atoms[b[1]].bonds.push(b[0]); atoms[b[1]].bondOrder.push(1);
    });
    var style = JSON.parse(JSON.stringify(styles[data.style]));
    if (data.style === "network") {  // colour each residue by how far it moves, still to most (blue to red)
      var largest = 0;
      atoms.forEach(function (atom) {
        atom.b = Math.hypot(atom.dx, atom.dy, atom.dz);
        largest = Math.max(largest, atom.b);
      });
      style.sphere.colorscheme = {prop: "b", gradient: "rwb", min: largest || 1, max: 0};
    }
    model.setStyle({}, style);
    model.vibrate(10, Number(amplitude.value), true);
    if (frame) {  // fit, with room for the motion (a chain: fit its length to the box's width)
      var wide = data.style === "chain" ? 0.9 * box.clientWidth / Math.max(box.clientHeight, 1) : 0;
      viewer.zoomTo();
      viewer.zoom(wide || (data.style === "network" ? 1.2 : 0.75));
    }
    viewer.render();
    if (running) viewer.animate({loop: "backAndForth", interval: 50});
  }
  menu.addEventListener("change", function () { show(false); });
  amplitude.addEventListener("input", function () { show(false); });
  button.addEventListener("click", function () {
    running = !running;
    button.textContent = running ? "pause" : "play";
    show(false);
  });
  show(true);
})();
"""


def copy_assets(out_dir: Path) -> list[str]:
    """Copy the vendored 3Dmol.js and its licences into ``DIR/assets/`` (when missing or changed)."""
    folder = out_dir / ASSETS
    folder.mkdir(exist_ok=True)
    source = resources.files("vibra.pipeline.report").joinpath(ASSETS)
    written = []
    for name in ASSET_FILES:
        data = source.joinpath(name).read_bytes()
        target = folder / name
        try:
            same = target.read_bytes() == data
        except OSError:
            same = False
        if not same:
            atomic_write_bytes(target, data)
        written.append(f"{ASSETS}/{name}")
    return written


def read_view(path: Path) -> dict[str, Any] | None:
    """The view data stored at `path` (None when it is missing or does not parse)."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and data.get("modes") else None


def view_html(data: dict[str, Any], *, root: str = "..") -> str:
    """The HTML of one interactive view: the viewer box, its controls, the data and the script.

    Parameters
    ----------
    data : dict
        `vibra.pipeline.plan.views.mode_view`'s dict.
    root : str
        The report folder, relative to the page (where ``assets/`` is).
    """
    e = html.escape
    options = "".join(f"<option value='{k}'>{e(m['label'])}</option>" for k, m in enumerate(data["modes"]))
    payload = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    note = f"<p class='note'>{e(data['note'])}.</p>" if data.get("note") else ""
    return (f"<div class='viewer'><div id='view3d' class='view3d {e(data.get('style', ''), quote=True)}'></div>"
            "<div class='controls'>"
            f"<label>mode <select id='view-mode'>{options}</select></label>"
            "<label>amplitude <input id='view-amplitude' type='range' min='0.2' max='3' step='0.1' value='1'>"
            "</label><button id='view-play' type='button'>pause</button></div>"
            f"{note}<p class='note'>Drag to rotate, scroll to zoom; the largest motion is drawn at about a third "
            "of the shortest bond at amplitude 1.</p></div>"
            f"<script src='{root}/{ASSETS}/3Dmol-min.js'></script>"
            f"<script type='application/json' id='view-data'>{payload}</script>"
            f"<script>{_SCRIPT}</script>")
