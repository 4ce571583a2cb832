"""The interactive 3-D view of a scene page: 3Dmol.js, vendored, fed the plan's view data.

3Dmol.js (BSD-3-Clause, https://3dmol.csb.pitt.edu, from its npm package ``3dmol``) ships in
``vibra/pipeline/report/assets/`` with its licence, beside vibra's own ``vibra-view.js``;
`copy_assets` puts one copy of each in the report's ``assets/`` folder, so every page works from
disk without a network. A scene's view data (`vibra.pipeline.plan.views.mode_view` for modes,
`vibra.crystals.animation.band_view` for a crystal's bands, stored as ``<scene>_view.json``) is
inlined in its page by `vibra._results.display.viewer_html`, the one HTML and script that
notebooks use too (`modes.show(system)`, `bands.show(crystal)`): modes vibrate with a mode menu
and an amplitude slider; a crystal's band structure is drawn, and a clicked point (q, branch)
is animated on a supercell.
"""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path
from typing import Any

from vibra._core.filesystem import atomic_write_bytes
from vibra._results.display import SCRIPT, THREEDMOL, viewer_html

__all__ = ["ASSETS", "ASSET_FILES", "VIEW_SUFFIX", "copy_assets", "view_html", "view_heading", "read_view"]

#: The report's folder of vendored scripts and their licences.
ASSETS = "assets"
#: The shipped files: the minified 3Dmol.js, its licences, and vibra's script that drives it.
ASSET_FILES = (THREEDMOL, "3Dmol-min.js.LICENSE.txt", "3Dmol-LICENSE.txt", SCRIPT)
#: The name ending of a scene's view data among its outputs.
VIEW_SUFFIX = "_view.json"


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
    return data if isinstance(data, dict) and (data.get("modes") or data.get("points")) else None


def view_heading(data: dict[str, Any]) -> str:
    """The page's heading above the view."""
    return "The bands and their modes in 3-D" if data.get("kind") == "crystal" else "The modes in 3-D"


def view_html(data: dict[str, Any], *, root: str = "..") -> str:
    """The HTML of one interactive view (`vibra._results.display.viewer_html`, scripts from ``assets/``).

    Parameters
    ----------
    data : dict
        The view data (`mode_view`'s or `band_view`'s dict).
    root : str
        The report folder, relative to the page (where ``assets/`` is).
    """
    return viewer_html(data, assets=f"{root}/{ASSETS}")
