"""Dask: finite-difference Hessian with a slow calculator on 1, 2 and 4 workers; a 1,000-point sweep.

1. FD Hessian of a 30-atom molecule (a planar zig-zag carbon chain with vibra's valence force
   field) whose calculator sleeps 0.2 s per force call, a stand-in for an expensive one
   (DFT): 2-point stencil without the Richardson step, 1 + 6 x 30 = 181 calls. Each worker
   count has its own `LocalCluster` (separate processes, one thread each), started once; the
   methods run by the protocol of _common.py (a warm-up on a 3-atom molecule per cluster, then
   interleaved rounds 1, 2, 4, 1, 2, 4, ...). Reported: wall time against the ideal
   calls x 0.2 s / workers, and the overhead per task, (wall - ideal) x workers / calls:
   worker time lost per task to scheduling, pickling and the client's cache-free gathering.
   The Hessians of the three counts must be identical bit for bit (checked).
2. A 1,000-point sweep of the mass-defect chain (chains/mass-defect.toml, 41 sites, over
   system.defect_mass): points per second in this process (client=None) and on 2 and 4
   workers, one task per point (tasks per second) and 50 points per task, interleaved.
3. The cost of ``client="local"``: starting and closing a 2-worker LocalCluster.

The sleeping calculator needs no CPU, so the FD figures measure Dask's overhead, not the
machine's cores; the sweep's points are CPU-bound (about a millisecond each).

Usage: python benchmarks/bench_distributed.py [--quick]   (--quick: 6 atoms, 0.02 s per call)
Writes results/distributed.json and results/distributed.png.
"""

from __future__ import annotations

import logging
import sys
import time
from pathlib import Path

from _common import ROUNDS, interleaved, new_figure, save_figure, write_json  # noqa: E402,I001  (pins BLAS threads before numpy)

import numpy as np  # noqa: E402

QUICK = "--quick" in sys.argv
DELAY = 0.02 if QUICK else 0.2
N_ATOMS = 6 if QUICK else 30
WORKERS = (1, 2, 4)
SWEEP_POINTS = 100 if QUICK else 1000
CHUNK = 50
SCENE = Path(__file__).resolve().parent.parent / "chains" / "mass-defect.toml"


def zigzag(n: int):
    """A planar zig-zag chain of n carbons, C-C 1.54 Angstrom, C-C-C 112 degrees (its own equilibrium)."""
    from ase import Atoms

    half = np.radians(112.0) / 2.0
    dx, dy = 1.54 * np.sin(half), 1.54 * np.cos(half)
    positions = [(i * dx, (i % 2) * dy, 0.0) for i in range(n)]
    return Atoms(f"C{n}", positions=positions)


def sleepy_field(atoms, delay: float):
    from vibra.molecules import ValenceForceField, valence_model

    class SleepyField(ValenceForceField):  # defined here: shipped to the workers by value (cloudpickle)
        def calculate(self, atoms=None, properties=("energy",), system_changes=None):  # type: ignore[override]
            super().calculate(atoms, properties, system_changes or [])
            time.sleep(delay)

    return SleepyField(valence_model(atoms))


def main() -> None:
    from distributed import Client, LocalCluster

    logging.getLogger("distributed").setLevel(logging.ERROR)

    from vibra.molecules import finite_difference_hessian
    from vibra.pipeline.sweep import sweep, vary

    atoms = zigzag(N_ATOMS)
    calc = sleepy_field(atoms, DELAY)
    small = zigzag(3)
    small_calc = sleepy_field(small, 0.0)
    calls = 1 + 6 * N_ATOMS
    print(f"FD Hessian: {N_ATOMS} atoms, {calls} force calls of {DELAY} s", flush=True)

    start_close = []
    for _ in range(3):
        t0 = time.perf_counter()
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                          silence_logs=logging.ERROR) as cluster, Client(cluster):
            pass
        start_close.append(time.perf_counter() - t0)
    print(f"  LocalCluster(2 workers) start + close: min {min(start_close):.2f} s", flush=True)

    clusters = {w: LocalCluster(n_workers=w, threads_per_worker=1, processes=True, dashboard_address=":0",
                                silence_logs=logging.ERROR) for w in WORKERS}
    clients = {w: Client(c) for w, c in clusters.items()}
    try:
        for w in WORKERS:  # warm-up: imports and the first pickles on every worker
            finite_difference_hessian(small, small_calc, estimate_error=False, force_noise=None, client=clients[w])
        # force_noise=None: the fan-out alone (the default probes the calculator's noise first)
        methods = {f"{w} worker(s)": (lambda w=w: finite_difference_hessian(atoms, calc, estimate_error=False,
                                                                            force_noise=None, client=clients[w]))
                   for w in WORKERS}
        fd = interleaved(methods, warmup=False)
        hessians = [t.result.hessian for t in fd.values()]
        identical = all(np.array_equal(hessians[0], h) for h in hessians[1:])
        fd_rows = []
        for w, timing in zip(WORKERS, fd.values()):
            ideal = calls * DELAY / w
            overhead = (timing.min - ideal) * w / calls
            fd_rows.append({"workers": w, "ideal_s": ideal, **timing.summary(),
                            "efficiency": ideal / timing.min, "overhead_per_task_s": overhead})
            print(f"  {w} worker(s): best {timing.min:.2f} s, ideal {ideal:.2f} s, efficiency "
                  f"{ideal / timing.min:.3f}, overhead {overhead * 1e3:.1f} ms/task", flush=True)
        print(f"  Hessians identical bit for bit across worker counts: {identical}", flush=True)

        axis = vary("system.defect_mass", 0.2, 0.7, SWEEP_POINTS)
        print(f"Sweep: {SWEEP_POINTS} points of {SCENE.name}", flush=True)
        sweeps = {"this process": lambda: sweep(SCENE, axis)}
        for w in (2, 4):
            sweeps[f"{w} workers, 1 point/task"] = lambda w=w: sweep(SCENE, axis, client=clients[w])
            sweeps[f"{w} workers, {CHUNK} points/task"] = lambda w=w: sweep(SCENE, axis, client=clients[w],
                                                                           chunk_size=CHUNK)
        sw = interleaved(sweeps)
        tables = [t.result.json_text() for t in sw.values()]
        sweep_identical = all(t == tables[0] for t in tables[1:])
        sweep_rows = [{"where": label, **t.summary(), "points_per_s": SWEEP_POINTS / t.min,
                       "points_per_s_median": SWEEP_POINTS / t.median} for label, t in sw.items()]
        for row in sweep_rows:
            print(f"  {row['where']}: {row['points_per_s']:.0f} points/s (best), "
                  f"{row['points_per_s_median']:.0f} (median)", flush=True)
        print(f"  tables identical: {sweep_identical}", flush=True)
    finally:
        for w in WORKERS:
            clients[w].close()
            clusters[w].close()

    payload = {"fd": {"n_atoms": N_ATOMS, "calls": calls, "delay_s": DELAY, "rows": fd_rows,
                      "identical": identical},
               "sweep": {"points": SWEEP_POINTS, "scene": SCENE.name, "rows": sweep_rows,
                         "identical": sweep_identical},
               "local_cluster_start_close_s": {"min": min(start_close), "all": start_close}}
    write_json("distributed", payload, ROUNDS)

    figure, (left, right) = new_figure(1, 2, figsize=(11.0, 4.5))
    w = np.array(WORKERS)
    left.plot(w, [r["min_s"] for r in fd_rows], "o-", label="measured (best)")
    left.plot(w, [r["ideal_s"] for r in fd_rows], "k--", label=f"ideal: {calls} x {DELAY} s / workers")
    left.set_xlabel("workers")
    left.set_ylabel("wall time (s)")
    left.set_xticks(list(WORKERS))
    left.set_title(f"FD Hessian, {N_ATOMS} atoms, {DELAY} s per call")
    left.legend()
    right.barh([r["where"] for r in sweep_rows], [r["points_per_s"] for r in sweep_rows])
    right.set_xlabel("points per second (best)")
    right.set_title(f"{SWEEP_POINTS}-point sweep, mass-defect chain")
    save_figure(figure, "distributed")


if __name__ == "__main__":
    main()
