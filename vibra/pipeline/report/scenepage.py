"""One scene's page, ``DIR/scenes/<scene>.html``: its figures with short captions, the interactive
3-D view of its modes, the frequency table, and how it was computed folded away."""

from __future__ import annotations

import html
from pathlib import Path
from typing import Sequence

from vibra.charts import plain_math
from vibra.pipeline.report.frame import IMAGE_SUFFIXES, page, short_caption
from vibra.pipeline.report.outcome import SceneOutcome
from vibra.pipeline.report.viewer import VIEW_SUFFIX, read_view, view_heading, view_html
from vibra.pipeline.scene.kinds import SCENE_KINDS

__all__ = ["scene_page", "KIND_WORDS"]

#: Scene kind -> what the page says the scene is (`SceneKind.phrase`).
KIND_WORDS = {name: kind.phrase for name, kind in SCENE_KINDS.items()}


def _steps_table(outcome: SceneOutcome) -> str:
    e = html.escape
    rows = ["<table><tr><th>step</th><th>what</th><th>solver</th><th>accuracy</th><th>time (s)</th></tr>"]
    for s in outcome.steps:
        rows.append(f"<tr><td>{e(s.name)}</td><td>{e(plain_math(s.what))}</td><td>{e(s.solver or '')}</td>"
                    f"<td>{e(plain_math(s.accuracy or ''))}</td><td>{s.seconds:.3f}</td></tr>")
    rows.append("</table>")
    return "".join(rows)


def _dynamics_parts(outcome: SceneOutcome) -> list[str]:
    """A dynamics scene's normal modes (the lowest, those of the harmonic part the run starts from) and what
    the run conserved: the ``dynamics-run`` step's `Trajectory.conserved_drift` of each run."""
    e = html.escape
    parts = []
    if outcome.frequencies:
        parts.append("<h2>Normal modes the run starts from</h2><p class='note'>The lowest normal modes of the "
                     "system's harmonic part (rigid modes apart).</p>"
                     "<pre>" + e(plain_math("\n".join(outcome.frequencies))) + "</pre>")
    drift = next((s.accuracy for s in outcome.steps if s.name == "dynamics-run" and s.accuracy), None)
    if drift:
        parts.append("<h2>What the run conserved</h2><p>" + e(drift[:1].upper() + drift[1:]) + ".</p>"
                     "<p class='note'>The largest change |C(t) - C(0)| over the recorded states, relative to "
                     "the energy (Trajectory.conserved_drift), of what the run conserves: C is the energy "
                     "without a thermostat, the extended energy of a Nosé-Hoover thermostat (its conserved "
                     "quantity), or the kinetic energy that Gauss's isokinetic constraint holds.</p>")
    return parts


def scene_page(outcome: SceneOutcome, scenes: Sequence[SceneOutcome], out_dir: Path) -> str:
    """The HTML of `outcome`'s page (in ``DIR/scenes/``, so files of the folder are ``../<file>``).

    Parameters
    ----------
    outcome : SceneOutcome
        The scene.
    scenes : sequence of SceneOutcome
        Every scene of the report (the sidebar).
    out_dir : Path
        The report folder (the scene's view data is read from there).
    """
    e = html.escape
    o = outcome
    what = KIND_WORDS.get(o.kind, "a scene")
    status = {"ok": "computed", "skipped": "unchanged since the last run", "failed": "failed"}.get(o.status, o.status)
    parts = [f"<p class='lead'><a href='../index.html'>All scenes</a> &rsaquo; {e(what)}</p>",
             f"<h1>{e(plain_math(o.title))}</h1>",
             f"<p class='lead'>Scene file <code>{e(Path(o.source).name)}</code>, "
             f"<span class='{e(o.status)}'>{e(status)}</span> in {o.seconds:.2f} s.</p>"]
    if o.error:
        parts.append(f"<pre class='failed'>{e(o.error)}</pre>")
    view = None
    figures, others = [], []
    for output, caption in zip(o.outputs, o.captions):
        link = e(f"../{output}", quote=True)
        text = short_caption(o.title, caption)
        if output.lower().endswith(IMAGE_SUFFIXES):
            figures.append(f"<figure><a href='{link}'><img src='{link}' alt='{e(text, quote=True)}' "
                           f"loading='lazy'></a><figcaption>{e(text)}</figcaption></figure>")
        elif output.endswith(VIEW_SUFFIX):
            view = read_view(out_dir / output)
            others.append(f"<li><a href='{link}'>{e(output)}</a>: the data of the 3-D view below</li>")
        else:
            others.append(f"<li><a href='{link}'>{e(output)}</a>: {e(text)}</li>")
    if figures:
        parts.append("<div class='figs'>" + "".join(figures) + "</div>")
    if view is not None:
        parts.append(f"<h2>{view_heading(view)}</h2>" + view_html(view))
    if o.kind == "dynamics":
        parts.extend(_dynamics_parts(o))
    elif o.frequencies:
        parts.append("<h2>Frequencies</h2><pre>" + e(plain_math("\n".join(o.frequencies))) + "</pre>")
    details = []
    if o.steps:
        details.append("<p class='note'>Each step of the computation: what it computed, the solver that "
                       "served it, its accuracy figure and its time.</p>" + _steps_table(o))
    if others:
        details.append("<p>Other files:</p><ul>" + "".join(others) + "</ul>")
    details.append(f"<p class='note'>Scene file: <code>{e(o.source)}</code></p>")
    parts.append("<details><summary>How it was computed (solvers, accuracy, files)</summary>"
                 + "".join(details) + "</details>")
    return page(o.title, "\n".join(parts), scenes, root="..", here=o.name)
