"""Benchmark of `vibra report` on the bundled scenes: seconds per scene and per image,
with ``--jobs 1`` and ``--jobs 2``, timed by the protocol of _common.py (one warm-up batch
each, then interleaved rounds jobs 1, jobs 2, jobs 1, ...; min/median/max of the batch wall
time). Per-scene figures come from each setting's fastest batch.

Writes ``benchmarks/results/report.json`` and ``benchmarks/results/report.png``.
Run with ``python benchmarks/bench_report.py`` (``--quick``: two small scenes at a small
window size, as a smoke test, into results/quick/).
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
from _common import ROUNDS, format_ratio, interleaved, new_figure, ratio, save_figure, write_json  # noqa: E402,I001  (pins BLAS threads before numpy)

ROOT = Path(__file__).resolve().parent.parent


def run_batch(paths: list[str], jobs: int, window: str | None) -> dict[str, object]:
    """Run the CLI once into a fresh folder; return wall time and the per-scene figures."""
    with tempfile.TemporaryDirectory() as folder:
        command = [sys.executable, "-m", "vibra", "report", *paths, "--out", folder, "--jobs", str(jobs),
                   "--force", "--quiet"]
        if window:
            command += ["--window-size", window]
        env = dict(os.environ)                 # the pinned BLAS thread settings of _common
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="two small scenes, small images")
    args = parser.parse_args()
    if args.quick:
        paths, window = ["chains/monatomic-free.toml", "molecules/co2-axial.toml"], "320x200"
    else:
        paths, window = ["chains", "molecules"], None
    batches: dict[int, list[dict[str, object]]] = {1: [], 2: []}

    def batch(jobs: int) -> dict[str, object]:
        out = run_batch(paths, jobs, window)
        batches[jobs].append(out)
        return out

    print("vibra report, --jobs 1 and --jobs 2", flush=True)
    timings = interleaved({"--jobs 1": lambda: batch(1), "--jobs 2": lambda: batch(2)})
    runs = [min(batches[jobs][1:] or batches[jobs], key=lambda b: b["wall_s"]) for jobs in (1, 2)]  # type: ignore[arg-type,return-value]
    print("vibra --help", flush=True)
    help_timing = interleaved({"vibra --help": lambda: subprocess.run(
        [sys.executable, "-m", "vibra", "--help"], cwd=ROOT, capture_output=True, check=True)}, max(ROUNDS, 5))
    speedup = ratio(timings["--jobs 1"], timings["--jobs 2"])
    payload = {
        "paths": paths, "window_size": window or "scene default (1024x640)",
        "help": help_timing["vibra --help"].summary(), "help_s": help_timing["vibra --help"].min,
        "batch_wall": {label: t.summary() for label, t in timings.items()},
        "runs": runs, "speedup_jobs2": speedup,
        "note": "runs: the fastest timed batch of each setting (per-scene and per-step seconds inside it)",
    }
    write_json("report", payload, ROUNDS)
    plot("report", runs, timings)
    for run in runs:
        print(f"jobs={run['jobs']}: best batch {run['wall_s']:.1f} s for {run['n_scenes']} scenes, "
              f"{run['n_images']} images: {run['s_per_scene']:.2f} s/scene, {run['s_per_image']:.2f} s/image")
    print(f"speed-up with 2 jobs: {format_ratio(speedup)}; vibra --help: {payload['help_s']:.2f} s")


def plot(name: str, runs: list[dict[str, object]], timings: dict) -> Path:  # type: ignore[type-arg]
    """Horizontal bars: seconds per scene with 1 and 2 jobs (each setting's fastest batch)."""
    import numpy as np

    scenes = sorted(runs[0]["scenes"])  # type: ignore[call-overload]
    fig, ax = new_figure(figsize=(8.0, 0.45 * len(scenes) + 1.8))
    y = np.arange(len(scenes))
    for offset, run in zip((-0.2, 0.2), runs):
        seconds = [run["scenes"][s]["seconds"] for s in scenes]  # type: ignore[index]
        t = timings[f"--jobs {run['jobs']}"]
        ax.barh(y + offset, seconds, height=0.4,
                label=f"--jobs {run['jobs']} (batch wall time {t.min:.1f} s best, {t.median:.1f} s median)")
    ax.set_yticks(y, scenes)
    ax.invert_yaxis()
    ax.set_xlabel("wall time per scene (s), inside the fastest batch")
    ax.set_title("vibra report on the bundled scenes")
    ax.legend(loc="lower right", fontsize=8)
    return save_figure(fig, name)


if __name__ == "__main__":
    main()
