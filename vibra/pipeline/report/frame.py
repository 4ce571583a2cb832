"""What every report page shares: the style sheet, the contents sidebar, the scene groups, captions.

Pages are plain HTML with relative links only (no CDN, no server): the report works opened
from disk. The sidebar lists the scenes by kind (`GROUPS`), each linking to its page.
"""

from __future__ import annotations

import html
import re
from typing import Sequence

from vibra.charts import plain_math
from vibra.pipeline.report.outcome import SceneOutcome
from vibra.pipeline.scene.kinds import REPORT_ORDER, SCENE_KINDS
from vibra.pipeline.scene.specs import SAFE_NAME

__all__ = ["GROUPS", "SCENES", "IMAGE_SUFFIXES", "page", "grouped", "page_name", "scene_href", "short_caption",
           "images"]

#: Scene kind -> heading of its group (`SceneKind.heading`), in the order the report shows them
#: (`REPORT_ORDER`, then any other kind); "" collects the scenes of no known kind.
GROUPS = tuple((name, SCENE_KINDS[name].heading) for name in sorted(
    SCENE_KINDS, key=lambda name: (REPORT_ORDER + tuple(SCENE_KINDS)).index(name))) + (("", "Other scenes"),)
#: The folder of the scene pages, inside the report folder.
SCENES = "scenes"
IMAGE_SUFFIXES = (".png", ".gif")

_CSS = """
*{box-sizing:border-box}
body{margin:0;font-family:system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;color:#1f2328;line-height:1.45}
a{color:#0b5cad}
nav.side{position:fixed;top:0;left:0;bottom:0;width:230px;overflow-y:auto;background:#f3f5f8;
 border-right:1px solid #d8dee4;padding:14px 14px 30px;font-size:14px}
nav.side h2{font-size:15px;margin:0 0 8px}nav.side h3{font-size:13px;margin:14px 0 4px;color:#57606a;
 text-transform:uppercase;letter-spacing:.04em}
nav.side ul{list-style:none;margin:0;padding:0}nav.side li{margin:2px 0}
nav.side a{text-decoration:none}nav.side a:hover{text-decoration:underline}
nav.side a.here{font-weight:600;color:#1f2328}
main{margin-left:230px;padding:18px 32px 40px;max-width:1150px}
h1{font-size:26px;margin:4px 0 6px}h2{font-size:20px;margin:26px 0 10px;border-bottom:1px solid #d8dee4}
.lead{color:#57606a;margin:0 0 10px}
.grid{display:grid;grid-template-columns:repeat(auto-fill,minmax(205px,1fr));gap:12px}
.card{display:block;border:1px solid #d8dee4;border-radius:8px;overflow:hidden;text-decoration:none;
 color:inherit;background:#fff}
.card:hover{border-color:#0b5cad;box-shadow:0 1px 6px rgba(0,0,0,.12)}
.card img{display:block;width:100%;height:118px;object-fit:contain;background:#fafbfc}
.card .none{height:118px;display:flex;align-items:center;justify-content:center;color:#a40e26;background:#fff5f5}
.card span{display:block;padding:6px 9px 8px;font-size:13.5px}
.card small{color:#57606a}
.figs{display:grid;grid-template-columns:repeat(auto-fill,minmax(440px,1fr));gap:18px 22px;margin:14px 0}
figure{margin:0}figure img{display:block;width:100%;border:1px solid #d8dee4;border-radius:4px;background:#fff}
figcaption{color:#424a53;font-size:14px;margin-top:4px}
table{border-collapse:collapse;margin:6px 0}td,th{border:1px solid #d8dee4;padding:3px 8px;font-size:14px;
 text-align:left}
pre{background:#f6f8fa;padding:8px 10px;overflow-x:auto;font-size:13px;border-radius:4px}
details{margin:14px 0}summary{cursor:pointer;font-weight:600}
.failed{color:#a40e26}.note{color:#57606a;font-size:14px;margin:4px 0}
.viewer{margin:12px 0}.view3d{position:relative;overflow:hidden;width:100%;max-width:900px;height:460px;
 border:1px solid #d8dee4;border-radius:4px}.view3d.chain{height:240px}
.controls{display:flex;gap:18px;align-items:center;margin:8px 0;font-size:14px}
ol.refs li{margin:6px 0}
"""


def page_name(name: str) -> str:
    """The file name of a scene's page: ``<name>.html`` for a valid scene name (`SAFE_NAME`), else the
    name with every other character made ``_`` (a failed scene's file stem may hold anything)."""
    if SAFE_NAME.match(name):
        return f"{name}.html"
    return "_" + re.sub(r"[^A-Za-z0-9_.-]", "_", name)[:60] + ".html"


def scene_href(name: str, *, root: str = ".") -> str:
    """The link to a scene's page from a page whose report folder is `root`."""
    return f"{root}/{SCENES}/{page_name(name)}" if root != "." else f"{SCENES}/{page_name(name)}"


def grouped(scenes: Sequence[SceneOutcome]) -> list[tuple[str, list[SceneOutcome]]]:
    """The scenes by kind, in the order of `GROUPS` (empty groups left out; unknown kinds last)."""
    known = {kind for kind, _ in GROUPS}
    groups = []
    for kind, heading in GROUPS:
        members = [o for o in scenes if (o.kind if o.kind in known else "") == kind]
        if members:
            groups.append((heading, members))
    return groups


def images(outcome: SceneOutcome) -> list[tuple[str, str]]:
    """(file, caption) of each image of a scene."""
    return [(f, c) for f, c in zip(outcome.outputs, outcome.captions) if f.lower().endswith(IMAGE_SUFFIXES)]


def short_caption(title: str, caption: str) -> str:
    """A caption as the page shows it: Unicode math, without a leading repeat of the scene title."""
    text = plain_math(caption).strip()
    for prefix in (plain_math(title), title):
        if prefix and text.startswith(prefix + ":"):
            text = text[len(prefix) + 1:].strip()
            break
    return text[:1].upper() + text[1:]


def _sidebar(scenes: Sequence[SceneOutcome], root: str, here: str) -> str:
    e = html.escape
    parts = ["<nav class='side'>", f"<h2><a href='{root}/index.html'>vibra report</a></h2>"]
    for heading, members in grouped(scenes):
        parts.append(f"<h3>{e(heading)}</h3><ul>")
        for o in members:
            mark = " class='here'" if o.name == here else ""
            flag = " <span class='failed'>(failed)</span>" if o.status == "failed" else ""
            parts.append(f"<li><a{mark} href='{e(scene_href(o.name, root=root), quote=True)}'>"
                         f"{e(plain_math(o.title))}</a>{flag}</li>")
        parts.append("</ul>")
    mark = " class='here'" if here == "references" else ""
    parts.append(f"<h3>About</h3><ul><li><a{mark} href='{root}/references.html'>References</a></li>"
                 f"<li><a href='{root}/summary.json'>summary.json</a></li></ul></nav>")
    return "".join(parts)


def page(title: str, body: str, scenes: Sequence[SceneOutcome], *, root: str = ".", here: str = "") -> str:
    """A whole page: head and style sheet, the contents sidebar, then `body` (HTML) as its main part.

    Parameters
    ----------
    title : str
        The page title (plain text).
    body : str
        The main part, HTML.
    scenes : sequence of SceneOutcome
        Every scene of the report (the sidebar).
    root : str
        The report folder, relative to this page.
    here : str
        The scene name (or ``"references"``) the sidebar marks as the current page.
    """
    return ("<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
            "<meta name='viewport' content='width=device-width, initial-scale=1'>"
            f"<title>{html.escape(plain_math(title))}</title><style>{_CSS}</style></head><body>\n"
            f"{_sidebar(scenes, root, here)}\n<main>\n{body}\n</main>\n</body></html>\n")
