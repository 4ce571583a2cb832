"""Benchmark of `vibra report` on the bundled scenes: seconds per scene and per image,
with ``--jobs 1`` and ``--jobs 2``, in one run (ratios, not absolute seconds).

Writes ``benchmarks/results/report.json`` and ``benchmarks/results/report.png``.
Run with ``OPENBLAS_NUM_THREADS=1 python benchmarks/bench_report.py`` (``--quick``: two
small scenes at a small window size, as a smoke test).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _common import RESULTS, write_json  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def run_batch(paths: list[str], jobs: int, window: str | None) -> dict[str, object]:
    """Run the CLI once into a fresh folder; return wall time and the per-scene figures."""
    with tempfile.TemporaryDirectory() as folder:
        command = [sys.executable, "-m", "vibra", "report", *paths, "--out", folder, "--jobs", str(jobs),
                   "--force", "--quiet"]
        if window:
            command += ["--window-size", window]
        env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
        start = time.perf_counter()
        run = subprocess.run(command, cwd=ROOT, env=env, capture_output=True, text=True)
        wall = time.perf_counter() - start
        if run.returncode != 0:
            raise SystemExit(f"vibra report failed:\n{run.stdout}\n{run.stderr}")
        summary = json.loads((Path(folder) / "summary.json").read_text())
    scenes = {}
    n_images = 0
    for entry in summary["scenes"]:
        images = [o for o in entry["outputs"] if o.endswith((".png", ".gif"))]
        n_images += len(images)
        scenes[entry["name"]] = {
            "seconds": entry["seconds"], "images": len(images),
            "steps": {s["name"]: s["seconds"] for s in entry["steps"]},
        }
    return {"jobs": jobs, "wall_s": wall, "n_scenes": len(scenes), "n_images": n_images,
            "s_per_scene": wall / len(scenes), "s_per_image": wall / max(n_images, 1), "scenes": scenes}


def help_time() -> float:
    """Best of 5 wall times of ``python -m vibra --help`` (start-up cost)."""
    best = float("inf")
    for _ in range(5):
        start = time.perf_counter()
        subprocess.run([sys.executable, "-m", "vibra", "--help"], cwd=ROOT, capture_output=True, check=True)
        best = min(best, time.perf_counter() - start)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="two small scenes, small images")
    args = parser.parse_args()
    if args.quick:
        paths, window = ["chains/monatomic-free.toml", "molecules/co2-axial.toml"], "320x200"
    else:
        paths, window = ["chains", "molecules"], None
    runs = [run_batch(paths, jobs, window) for jobs in (1, 2)]
    payload = {
        "paths": paths, "window_size": window or "scene default (1024x640)",
        "help_s": help_time(), "runs": runs,
        "speedup_jobs2": runs[0]["wall_s"] / runs[1]["wall_s"],
    }
    name = "report_quick" if args.quick else "report"
    write_json(name, payload)
    plot(name, runs)
    for run in runs:
        print(f"jobs={run['jobs']}: {run['wall_s']:.1f} s for {run['n_scenes']} scenes, {run['n_images']} images: "
              f"{run['s_per_scene']:.2f} s/scene, {run['s_per_image']:.2f} s/image")
    print(f"speed-up with 2 jobs: {payload['speedup_jobs2']:.2f}x; vibra --help: {payload['help_s']:.2f} s")


def plot(name: str, runs: list[dict[str, object]]) -> Path:
    """Horizontal bars: seconds per scene with 1 and 2 jobs."""
    import numpy as np

    from vibra.charts._style import new_figure, save_figure

    scenes = sorted(runs[0]["scenes"])  # type: ignore[arg-type]
    fig, ax = new_figure(figsize=(8.0, 0.45 * len(scenes) + 1.8))
    y = np.arange(len(scenes))
    for offset, run in zip((-0.2, 0.2), runs):
        seconds = [run["scenes"][s]["seconds"] for s in scenes]  # type: ignore[index]
        ax.barh(y + offset, seconds, height=0.4,
                label=f"--jobs {run['jobs']} (batch wall time {run['wall_s']:.1f} s)")
    ax.set_yticks(y, scenes)
    ax.invert_yaxis()
    ax.set_xlabel("wall time per scene (s), inside the batch")
    ax.set_title("vibra report on the bundled scenes")
    ax.legend(loc="lower right")
    return save_figure(fig, RESULTS / f"{name}.png")


if __name__ == "__main__":
    main()
