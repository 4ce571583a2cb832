"""``summary.json`` and ``index.html`` of an output folder, merged with what the folder already shows.

A run renders some scenes; the folder may hold others from earlier runs. `merged_outcomes`
keeps those (when their outputs are still there and sound), replaces the scenes this run
re-ran, and appends new ones, so the index never loses images that are still in the folder.
"""

from __future__ import annotations

import html
import json
from pathlib import Path
from typing import Sequence

from vibra._io import atomic_write_text
from vibra.charts import plain_math
from vibra.pipeline.report.folder import output_is_sound
from vibra.pipeline.report.outcome import BatchResult, SceneOutcome

__all__ = ["previous_outcomes", "merged_outcomes", "write_summary", "write_index"]


def previous_outcomes(out_dir: Path) -> list[SceneOutcome]:
    """The scenes ``DIR/summary.json`` lists (none when it is missing or does not parse)."""
    try:
        data = json.loads((out_dir / "summary.json").read_text(encoding="utf-8"))
        return [SceneOutcome.from_json(entry) for entry in data["scenes"]]
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return []


def merged_outcomes(out_dir: Path, outcomes: Sequence[SceneOutcome]) -> list[SceneOutcome]:
    """This run's `outcomes` merged into the folder's earlier ones (by scene name).

    An earlier scene this run did not touch is kept when it failed (its error still applies)
    or when all its outputs are still in the folder and sound; a scene of this run replaces
    the earlier entry of the same name, in place; new scenes come last.
    """
    current = {o.name: o for o in outcomes}
    merged: list[SceneOutcome] = []
    seen = set()
    for old in previous_outcomes(out_dir):
        if old.name in seen:
            continue
        seen.add(old.name)
        if old.name in current:
            merged.append(current[old.name])
        elif old.status == "failed" or all(output_is_sound(out_dir / f) for f in old.outputs):
            merged.append(old)
    merged.extend(o for o in outcomes if o.name not in seen)
    return merged


def write_summary(result: BatchResult, outcomes: Sequence[SceneOutcome] | None = None) -> Path:
    """Write ``summary.json`` (every scene: status, outputs, steps, numbers, errors), atomically.

    Parameters
    ----------
    result : BatchResult
        This run.
    outcomes : sequence of SceneOutcome, optional
        The scenes to list (default: this run's; `report` passes `merged_outcomes`).
    """
    scenes = list(result.outcomes if outcomes is None else outcomes)
    payload = {
        "seconds": result.seconds, "jobs": result.jobs,
        "n_scenes": len(scenes), "n_failed": sum(1 for o in scenes if o.status == "failed"),
        "scenes": [o.as_json() for o in scenes],
    }
    return atomic_write_text(result.out_dir / "summary.json", json.dumps(payload, indent=1, allow_nan=False))


def write_index(result: BatchResult, outcomes: Sequence[SceneOutcome] | None = None) -> Path:
    """Write ``index.html``: every image with its caption, the step table and the errors."""
    scenes = list(result.outcomes if outcomes is None else outcomes)
    failed = sum(1 for o in scenes if o.status == "failed")
    e = html.escape
    parts = ["<!DOCTYPE html>", "<html lang='en'><head><meta charset='utf-8'>",
             "<title>vibra report</title><style>",
             "body{font-family:sans-serif;max-width:1100px;margin:auto;padding:1em}"
             "figure{margin:1em 0}img{max-width:100%;border:1px solid #ccc}"
             "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 6px;font-size:90%}"
             ".failed{color:#a00}pre{background:#f6f6f6;padding:.5em;overflow-x:auto}",
             "</style></head><body>", "<h1>vibra report</h1>",
             f"<p>{len(scenes)} scene(s), {failed} failed.</p>"]
    for o in scenes:
        parts.append(f"<section id='{e(o.name, quote=True)}'><h2>{e(o.title)}</h2>")
        parts.append(f"<p>Scene file <code>{e(o.source)}</code>: <b class='{e(o.status)}'>{e(o.status)}</b>"
                     f" in {o.seconds:.2f} s.</p>")
        if o.error:
            parts.append(f"<pre class='failed'>{e(o.error)}</pre>")
        if o.steps:
            parts.append("<table><tr><th>step</th><th>what</th><th>solver</th><th>accuracy</th>"
                         "<th>time (s)</th></tr>")
            for s in o.steps:
                parts.append(f"<tr><td>{e(s.name)}</td><td>{e(plain_math(s.what))}</td><td>{e(s.solver or '')}</td>"
                             f"<td>{e(plain_math(s.accuracy or ''))}</td><td>{s.seconds:.3f}</td></tr>")
            parts.append("</table>")
        for output, raw_caption in zip(o.outputs, o.captions):
            caption = plain_math(raw_caption)  # Unicode, never raw mathtext such as $\omega$
            link = e(output, quote=True)
            if output.endswith((".png", ".gif")):
                parts.append(f"<figure><img src='{link}' alt='{e(caption, quote=True)}'>"
                             f"<figcaption>{e(caption)}</figcaption></figure>")
            else:
                parts.append(f"<p><a href='{link}'>{e(output)}</a>: {e(caption)}</p>")
        if o.frequencies:
            parts.append("<details><summary>frequencies</summary><pre>"
                         + e(plain_math("\n".join(o.frequencies))) + "</pre></details>")
        parts.append("</section>")
    parts.append("</body></html>")
    return atomic_write_text(result.out_dir / "index.html", "\n".join(parts) + "\n")
