"""`vibra report`: scene files -> PNG images, ``summary.json`` and ``index.html``, in batch.

- `vibra.pipeline.report.batch`: `report` (a locked, merged batch) and `run_scene` (one isolated scene).
- `vibra.pipeline.report.folder`: the output folder: checks, lock, stale-file cleanup, output
  verification, the code hash of the skip key.
- `vibra.pipeline.report.pages`: ``summary.json`` and the pages, merged with the folder's earlier scenes.
- `vibra.pipeline.report.site`: ``index.html`` (thumbnails by kind), ``references.html``, the scene pages.
- `vibra.pipeline.report.scenepage`: one scene's page (figures, 3-D view, frequencies, folded details).
- `vibra.pipeline.report.frame`: what every page shares (style sheet, contents sidebar, captions).
- `vibra.pipeline.report.viewer`: the interactive 3-D view (vendored 3Dmol.js in ``assets/``).
- `vibra.pipeline.report.outcome`: `SceneOutcome`, `BatchResult`, `ProgressBar`.
"""

from __future__ import annotations

from vibra._core.filesystem import atomic_write_text
from vibra.charts.modes import shapes_figure, spectrum_figure
from vibra.pipeline.report.batch import available_cores, missing_paths, report, run_scene
from vibra.pipeline.report.folder import FolderBusy, FolderLock, check_out_dir, clean_stale, code_hash, output_is_sound
from vibra.pipeline.report.outcome import BatchResult, ProgressBar, SceneOutcome
from vibra.pipeline.report.pages import merged_outcomes, write_index, write_summary

__all__ = [
    "SceneOutcome", "BatchResult", "run_scene", "report", "atomic_write_text",
    "write_summary", "write_index", "spectrum_figure", "shapes_figure", "ProgressBar",
    "FolderBusy", "FolderLock", "check_out_dir", "clean_stale", "code_hash", "output_is_sound",
    "merged_outcomes", "available_cores", "missing_paths",
]
