"""Shared helpers of the benchmark scripts: the timing protocol, JSON output, figures.

The protocol (house rule, STYLE.md): every method of a comparison runs in one process, first
once as a warm-up (imports, caches, page faults), then in N >= 3 interleaved rounds
(A, B, C, A, B, C, ...), so that a slow spell of a shared machine hits every method alike.
A figure is the best (min) time of each method, reported with its median and max and with the
range of the per-round ratio; a ratio inside the run-to-run spread is reported as a tie.

BLAS threads are pinned to one per process: importing this module (which every script does
before numpy) sets OPENBLAS_NUM_THREADS, OMP_NUM_THREADS and MKL_NUM_THREADS, and
``threadpoolctl`` (when installed) limits the pools of an already-loaded BLAS too. Each JSON
records the machine, its core count, the thread settings and N.

Every script writes ``results/<name>.json`` and ``.png`` (``--quick``: ``results/quick/``,
git-ignored). ``VIBRA_BENCH_RESULTS`` names another folder (used for runs on another machine),
``VIBRA_BENCH_MACHINE`` a label for the machine in the JSON.
"""

from __future__ import annotations

import os

THREADS = os.environ.get("VIBRA_BENCH_THREADS", "1")
for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = THREADS           # before numpy is imported anywhere

import gc  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any, Callable  # noqa: E402

import numpy as np  # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

try:                                          # limits a BLAS that was loaded before the env was set
    from threadpoolctl import threadpool_info, threadpool_limits
    threadpool_limits(int(THREADS))
except ImportError:                           # pragma: no cover - optional
    threadpool_info = None

_QUICK = "--quick" in sys.argv
_BASE = Path(os.environ["VIBRA_BENCH_RESULTS"]) if os.environ.get("VIBRA_BENCH_RESULTS") else \
    Path(__file__).resolve().parent / "results"
#: Where results go. A ``--quick`` smoke run writes to results/quick/ (git-ignored) so that it
#: never overwrites the committed full-size figures.
RESULTS = _BASE / "quick" if _QUICK else _BASE
#: Default number of timed rounds (after one warm-up round).
ROUNDS = 1 if _QUICK else 3


@dataclass(frozen=True)
class Timing:
    """Wall times of one method over the timed rounds (seconds), and its last result."""

    label: str
    seconds: tuple[float, ...]
    result: Any

    @property
    def min(self) -> float:
        return min(self.seconds)

    @property
    def median(self) -> float:
        return float(statistics.median(self.seconds))

    @property
    def max(self) -> float:
        return max(self.seconds)

    def summary(self) -> dict[str, Any]:
        """JSON-ready min / median / max and every round."""
        return {"min_s": self.min, "median_s": self.median, "max_s": self.max, "rounds_s": list(self.seconds)}


def interleaved(methods: dict[str, Callable[[], Any]], rounds: int | None = None, *,
                warmup: bool = True, verbose: bool = True) -> dict[str, Timing]:
    """Time named callables by the protocol: one warm-up round, then `rounds` interleaved rounds.

    Round r calls every method once, in the given order (A, B, C, A, B, C, ...). Returns a
    Timing per method (min, median, max over the timed rounds; the result of its last call).
    """
    rounds = ROUNDS if rounds is None else rounds
    if warmup:
        for function in methods.values():
            function()
    seconds: dict[str, list[float]] = {label: [] for label in methods}
    results: dict[str, Any] = {}
    for _ in range(rounds):
        for label, function in methods.items():
            gc.collect()
            start = time.perf_counter()
            results[label] = function()
            seconds[label].append(time.perf_counter() - start)
    timings = {label: Timing(label, tuple(seconds[label]), results[label]) for label in methods}
    if verbose:
        for t in timings.values():
            print(f"  {t.label:52s} min {t.min:9.4f} s  median {t.median:9.4f} s  max {t.max:9.4f} s", flush=True)
    return timings


def ratio(numerator: Timing, denominator: Timing) -> dict[str, Any]:
    """numerator / denominator: the ratio of the best times, the range of the per-round ratios
    (round r of one method over round r of the other: they ran side by side), and whether it is
    a tie (1 inside that range: the run-to-run spread covers "equal")."""
    per_round = [a / b for a, b in zip(numerator.seconds, denominator.seconds)]
    best = numerator.min / denominator.min
    tie = min(per_round) <= 1.0 <= max(per_round)
    return {"of_min": best, "of_median": numerator.median / denominator.median,
            "round_min": min(per_round), "round_max": max(per_round), "tie": bool(tie)}


def format_ratio(r: dict[str, Any], digits: int = 2) -> str:
    """'0.68x (0.65-0.71)' or 'tie: 1.02x (0.97-1.06)'."""
    text = f"{r['of_min']:.{digits}f}x ({r['round_min']:.{digits}f}-{r['round_max']:.{digits}f})"
    return ("tie: " + text) if r["tie"] else text


def machine(rounds: int) -> dict[str, Any]:
    """Machine, cores, BLAS thread settings and the protocol, for every JSON."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    info: dict[str, Any] = {
        "label": os.environ.get("VIBRA_BENCH_MACHINE", platform.node()),
        "cpu": cpu, "cores": os.cpu_count(),
        "cores_usable": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None,
        "load_average_1min": os.getloadavg()[0] if hasattr(os, "getloadavg") else None,
        "python": platform.python_version(), "numpy": np.__version__,
        "threads": {v: os.environ.get(v) for v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")},
        "protocol": f"one warm-up round, then {rounds} interleaved round(s); min/median/max per method",
        "rounds": rounds,
    }
    try:
        import scipy
        info["scipy"] = scipy.__version__
    except ImportError:                       # pragma: no cover
        pass
    if threadpool_info is not None:
        info["threadpools"] = [{k: p.get(k) for k in ("internal_api", "num_threads", "version")}
                               for p in threadpool_info()]
    return info


def write_json(name: str, payload: dict[str, Any], rounds: int | None = None) -> Path:
    """Write ``results/<name>.json`` atomically, with the machine and protocol added."""
    RESULTS.mkdir(parents=True, exist_ok=True)
    payload = {"machine": machine(ROUNDS if rounds is None else rounds), **payload}
    target = RESULTS / f"{name}.json"
    handle, temporary = tempfile.mkstemp(dir=RESULTS, suffix=".tmp")
    with os.fdopen(handle, "w") as stream:
        json.dump(payload, stream, indent=2, default=float)
    os.replace(temporary, target)
    return target



def write_markdown(name: str, header: list[str], rows: list[list[str]], *, align: str = "---") -> Path:
    """Write ``results/<name>.md``: a Markdown table of `header` and `rows` (cells already
    formatted), and print it; `align` is every column's separator cell ("---:" right-aligns)."""
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join(f" {align} " for _ in header) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    RESULTS.mkdir(parents=True, exist_ok=True)
    target = RESULTS / f"{name}.md"
    target.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return target

def new_figure(nrows: int = 1, ncols: int = 1, figsize: tuple[float, float] = (8.0, 5.0)) -> tuple[Figure, Any]:
    """A matplotlib Figure (no pyplot, no global state) and its axes."""
    fig = Figure(figsize=figsize, dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, ncols)
    if isinstance(axes, np.ndarray):
        for ax in axes.flat:
            ax.grid(True, which="both", alpha=0.3)
    else:
        axes.grid(True, which="both", alpha=0.3)
    return fig, axes


def save_figure(fig: Figure, name: str) -> Path:
    """Write `fig` to ``results/<name>.png`` atomically."""
    RESULTS.mkdir(parents=True, exist_ok=True)
    target = RESULTS / f"{name}.png"
    handle, temporary = tempfile.mkstemp(dir=RESULTS, suffix=".tmp")
    os.close(handle)
    try:
        fig.savefig(temporary, format="png")
        os.replace(temporary, target)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise
    return target


def plot_error_vs_time(name: str, series: dict[str, list[tuple[Timing, float]]], *, title: str,
                       xlabel: str = "wall time (s): best of the rounds, bar to the slowest",
                       ylabel: str = "largest relative error") -> Path:
    """Log-log PNG ``results/<name>.png``: error against best time, one line per method, with
    a horizontal bar from each method's best to its slowest round."""
    fig, ax = new_figure()
    for label, points in series.items():
        if not points:
            continue
        xs = np.array([t.min for t, _ in points])
        spread = np.array([t.max - t.min for t, _ in points])
        ys = np.array([max(y, 1e-17) for _, y in points])
        line, = ax.loglog(xs, ys, "o-", label=label)
        ax.errorbar(xs, ys, xerr=[np.zeros_like(spread), spread], fmt="none", ecolor=line.get_color(),
                    capsize=3)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(fontsize=8)
    return save_figure(fig, name)
