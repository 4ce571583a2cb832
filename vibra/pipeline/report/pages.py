"""``summary.json`` and the pages (``index.html`` ...) of an output folder, merged with what the folder already shows.

A run renders some scenes; the folder may hold others from earlier runs. `merged_outcomes`
keeps those (when their outputs are still there and sound), replaces the scenes this run
re-ran, and appends new ones, so the index never loses images that are still in the folder.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Sequence

from vibra._core.filesystem import atomic_write_text
from vibra.pipeline.report.folder import output_is_sound
from vibra.pipeline.report.outcome import BatchResult, SceneOutcome
from vibra.pipeline.report.site import write_site

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
    """Write the report's pages (`vibra.pipeline.report.site.write_site`); return ``index.html``.

    ``index.html`` groups the scenes by kind in a thumbnail grid; each scene has its page in
    ``scenes/`` (figures, 3-D view, frequencies, how it was computed); ``references.html``
    names the sources; ``assets/`` holds the vendored 3Dmol.js.
    """
    return write_site(result.out_dir, list(result.outcomes if outcomes is None else outcomes))
