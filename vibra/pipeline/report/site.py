"""The report's pages: ``index.html`` (a thumbnail grid by kind), one page per scene
(`vibra.pipeline.report.scenepage`), ``references.html`` (the sources, `vibra.sources`), and the
vendored 3Dmol.js in ``assets/``. Every link is relative: the folder works opened from disk."""

from __future__ import annotations

import html
from pathlib import Path
from typing import Sequence

from vibra._core.filesystem import atomic_write_text
from vibra.charts import plain_math
from vibra.pipeline.report.frame import SCENES, grouped, images, page, page_name, scene_href
from vibra.pipeline.report.outcome import SceneOutcome
from vibra.pipeline.report.scenepage import scene_page
from vibra.pipeline.report.viewer import VIEW_SUFFIX, copy_assets
from vibra.sources import SOURCES
from vibra._core.text import counted

__all__ = ["index_page", "references_page", "write_site"]


_count = counted  # "1 scene", "3 scenes": the one plural rule (`vibra._core.text`)


def _card(o: SceneOutcome) -> str:
    e = html.escape
    pictures = images(o)
    if pictures:
        top = f"<img src='{e(pictures[0][0], quote=True)}' alt='' loading='lazy'>"
    else:
        top = "<div class='none'>failed</div>" if o.status == "failed" else "<div class='none'>no figure</div>"
    extras = [_count(len(pictures), "figure")]
    if any(f.endswith(VIEW_SUFFIX) for f in o.outputs):
        extras.append("3-D view")
    if o.status == "failed":
        extras = ["<span class='failed'>failed</span>"]
    return (f"<a class='card' href='{e(scene_href(o.name), quote=True)}'>{top}"
            f"<span>{e(plain_math(o.title))}<br><small>{' · '.join(extras)}</small></span></a>")


def index_page(scenes: Sequence[SceneOutcome]) -> str:
    """``index.html``: how many scenes, then one thumbnail grid per kind, each card a scene's page."""
    failed = sum(1 for o in scenes if o.status == "failed")
    n_images = sum(len(images(o)) for o in scenes)
    parts = ["<h1>vibra report</h1>",
             f"<p class='lead'>{_count(len(scenes), 'scene')}, {_count(n_images, 'figure')}"
             + (f", <span class='failed'>{failed} failed</span>" if failed else "")
             + ". Pick a scene for its figures, its modes in 3-D and its frequencies.</p>"]
    for heading, members in grouped(scenes):
        anchor = heading.lower().replace(" ", "-")
        parts.append(f"<h2 id='{anchor}'>{html.escape(heading)}</h2><div class='grid'>"
                     + "".join(_card(o) for o in members) + "</div>")
    return page("vibra report", "\n".join(parts), scenes)


def references_page(scenes: Sequence[SceneOutcome]) -> str:
    """``references.html``: the sources the scenes and checks cite, and the software of the pages."""
    e = html.escape
    items = "".join(f"<li>{e(s.full())}<br><small class='note'>{e(s.about)}</small></li>" for s in SOURCES.values())
    body = ("<h1>References</h1><p class='lead'>The documents whose equations and examples the scenes "
            "reproduce and the tests check against.</p>"
            f"<ol class='refs'>{items}</ol><h2>Software in these pages</h2>"
            "<p>The interactive views use 3Dmol.js (Rego and Koes, <i>3Dmol.js: molecular visualization with "
            "WebGL</i>, Bioinformatics 31, 1322-1324, 2015), BSD-3-Clause licence: "
            "<a href='assets/3Dmol-LICENSE.txt'>assets/3Dmol-LICENSE.txt</a>.</p>")
    return page("References", body, scenes, here="references")


def write_site(out_dir: Path, scenes: Sequence[SceneOutcome]) -> Path:
    """Write every page of the report for `scenes` (atomically, each); return ``index.html``.

    Scene pages of scenes no longer listed are removed, so no page links to a gone scene.
    """
    copy_assets(out_dir)
    folder = out_dir / SCENES
    folder.mkdir(exist_ok=True)
    names = {page_name(o.name) for o in scenes}
    for old in folder.glob("*.html"):
        if old.name not in names and old.is_file():
            old.unlink(missing_ok=True)
    for o in scenes:
        atomic_write_text(folder / page_name(o.name), scene_page(o, scenes, out_dir))
    atomic_write_text(out_dir / "references.html", references_page(scenes))
    return atomic_write_text(out_dir / "index.html", index_page(scenes))
