"""Shared helpers of the benchmark scripts: timing, JSON output, error-versus-time figure.

Every benchmark compares methods side by side in one process (ratios, not absolute
seconds: machines are shared and noisy) and writes ``benchmarks/results/<name>.json`` and
``benchmarks/results/<name>.png``. Run them with OPENBLAS_NUM_THREADS=1.
"""

from __future__ import annotations

import json
import os
import platform
import tempfile
import time
from pathlib import Path
from typing import Any, Callable

import sys

#: Where results go. A ``--quick`` smoke run writes to results/quick/ (git-ignored) so that it
#: never overwrites the committed full-size figures.
RESULTS = Path(__file__).resolve().parent / "results" / ("quick" if "--quick" in sys.argv else "")


def best_time(function: Callable[[], Any], repeat: int = 3, budget_s: float = 60.0) -> tuple[float, Any]:
    """Smallest wall time of `repeat` calls (fewer if over `budget_s`), and the last result."""
    best = float("inf")
    result = None
    spent = 0.0
    for _ in range(repeat):
        start = time.perf_counter()
        result = function()
        elapsed = time.perf_counter() - start
        best = min(best, elapsed)
        spent += elapsed
        if spent > budget_s:
            break
    return best, result


def write_json(name: str, payload: dict[str, Any]) -> Path:
    """Write ``results/<name>.json`` atomically, with machine details added."""
    RESULTS.mkdir(parents=True, exist_ok=True)
    payload = dict(payload)
    payload.setdefault("machine", {
        "python": platform.python_version(), "processor": platform.processor() or platform.machine(),
        "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS"),
    })
    target = RESULTS / f"{name}.json"
    handle, temporary = tempfile.mkstemp(dir=RESULTS, suffix=".tmp")
    with os.fdopen(handle, "w") as stream:
        json.dump(payload, stream, indent=2, default=float)
    os.replace(temporary, target)
    return target


def plot_error_vs_time(name: str, series: dict[str, list[tuple[float, float]]], *, title: str,
                       xlabel: str = "wall time (s)", ylabel: str = "largest relative error") -> Path:
    """Log-log PNG ``results/<name>.png`` of (time, error) points, one line per method."""
    from vibra.charts._style import new_figure, save_figure

    fig, ax = new_figure()
    for label, points in series.items():
        if not points:
            continue
        xs, ys = zip(*points)
        ax.loglog(xs, [max(y, 1e-17) for y in ys], "o-", label=label)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend()
    return save_figure(fig, RESULTS / f"{name}.png")
