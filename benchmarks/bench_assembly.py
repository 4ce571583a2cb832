"""The lowest 20 modes of large protein assemblies: the iterative path against the factorisation (issue 47).

The network: ANM (cutoff 15 Å, ProDy's default, gamma 1) of a synthetic assembly of copies of
ubiquitin packed face to face (`assembly_builder.synthetic_assembly`): n_sites = dofs / 3.
Methods, each in its own subprocess (so that its peak resident memory, ru_maxrss, is its own),
on the same K~ (masses 1):

- ``iterative``: `vibra.solvers.standard.iterative.lowest_modes` ("fast": residuals <= 1e-8 ||K~||)
  with the sites' coordinates, as `System.modes` passes them (the rigid-block multigrid, the six
  rigid-body modes projected out);
- ``iterative-translations``: the same on K~ alone (the translations deflated, translations as the
  multigrid's near-null space: what `normal_modes(K, M)` without `positions` runs);
- ``iterative-high``: `System.modes(20, accuracy="high")` on the accurate-iterative path forced by
  the registry's rule (the factorisation's rate raised; relative bounds from spring-space Ritz: the
  row records the largest relative bound on omega^2 of a moving mode and how many exceed 1e-10);
- ``iterative-fast`` (not in the default methods): ``iterative-high``'s call at ``accuracy="fast"``, the plan, K~
  and the checks included, as a user's `System.modes(20, accuracy="fast")` runs it: the like-for-like row for
  "high"'s time over "fast"'s (issue 47: at most 1.5);
- ``iterative-gpu`` (only where CuPy sees a GPU; not in the default methods): ``iterative`` with LOBPCG and
  the multigrid cycle on the GPU (`lowest_modes(..., device="gpu")`, the registry's `iterative-gpu`); the
  row adds the GPU's peak memory (its free memory sampled every 20 ms) and the device's name;
- ``factorisation``: vibra's sparse path (`sparse_path`: CHOLMOD / PARDISO shift-invert, the path
  the plan picks at these sizes today);
- ``eigsh``: the strongest peer named, scipy's ``eigsh(K~, k, sigma=-1e-4 ||K~||, which="LM")``
  (shift-invert with SuperLU), tol 0 (machine precision).

Each row records time (one run: the 10^5 rows take minutes, so N = 1, with the load average
beside it), peak memory, the cost model's estimate, the largest residual ||K~ v - lambda v|| /
||K~||_inf, and the lowest values; eigsh is skipped over `EIGSH_MOST` dofs (the row says why), and a
failed run's row gives its exit status. Results: results/assembly.json.

Usage: ``python benchmarks/bench_assembly.py [--sizes 10000,100000] [--methods ...] [--budget 900]``
(3·10^5 and 10^6 dofs: ``--sizes 300000,1000000 --methods iterative``, hours on 2 cores; not run).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from typing import Any
from pathlib import Path

from _common import RESULTS, write_json  # noqa: E402  (pins BLAS threads before numpy)

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
MODES = 20
CUTOFF = 15.0
#: eigsh (SuperLU, minimum-degree order) above this many dofs: skipped (its fill grows past the machine).
EIGSH_MOST = 30_000
METHODS = ("iterative", "iterative-translations", "iterative-high", "factorisation", "eigsh")


def _system(dofs: int):  # type: ignore[no-untyped-def]
    from assembly_builder import synthetic_assembly
    from vibra import networks

    return networks.anm(synthetic_assembly(dofs // 3), cutoff=CUTOFF)


def _estimate(method: str, K: Any, n_terms: int) -> float | None:
    from vibra.solvers.registry import estimate
    from vibra.solvers.topology import separator_width

    name = {"iterative": "iterative", "iterative-translations": "iterative", "iterative-high": "accurate-iterative",
            "iterative-fast": "iterative",
            "factorisation": "sparse", "iterative-gpu": "iterative-gpu"}.get(method)
    if name is None:
        return None
    accuracy = "high" if method == "iterative-high" else "fast"
    n = K.shape[0]
    return estimate(name, n, k=MODES, vectors=True, nnz=int(K.nnz), width=n - 1, accuracy=accuracy,
                    n_terms=n_terms if accuracy == "high" else 0, separator=separator_width(K.tocsr()),
                    coordinates=method != "iterative-translations").seconds


def _product_threads() -> int:
    """Threads the iterative path's products ran on (`vibra.solvers.standard.rows`; BLAS stays pinned)."""
    from vibra.solvers.standard.rows import product_threads

    return product_threads()


def run_one(method: str, dofs: int) -> dict:
    """One method on one size, in this process: its figures."""
    from vibra.solvers import registry
    from vibra.solvers.standard.iterative import lowest_modes
    from vibra.solvers.standard.sparse import sparse_path
    import scipy.sparse.linalg as sla

    import pyamg  # noqa: F401  (imported before the clock: the path imports it on first use)

    built = time.perf_counter()
    system = _system(dofs)
    # the system's own K (read-only; no path writes it), which `System.modes` solves: `system.hessian()` returns a
    # copy, and holding it beside the system's counted a second K in every row's peak from 3cd1754 on (2.1 GB at 10^6)
    K = system._hessian
    build_s = time.perf_counter() - built
    n = K.shape[0]
    norm = float(abs(K).sum(axis=1).max())
    stages: list[str] = []  # (the path's progress messages: LOBPCG's iteration count)
    bounds: dict = {}  # ("high": the largest relative bound on omega^2 of a moving mode, the count over 1e-10)
    start = time.perf_counter()
    if method in ("iterative", "iterative-translations"):
        result = lowest_modes(K, MODES, positions=system.positions if method == "iterative" else None,
                              on_stage=lambda fraction, message: stages.append(message))
        values, vectors = result.eigenvalues, result.vectors
    elif method == "iterative-gpu":
        with _gpu_peak() as device:
            began = time.perf_counter()
            result = lowest_modes(K, MODES, positions=system.positions, device="gpu",
                                  on_stage=lambda fraction, message: stages.append(f"{message} @{time.perf_counter() - began:.2f}"))
        values, vectors, bounds = result.eigenvalues, result.vectors, device
    elif method in ("iterative-high", "iterative-fast"):
        registry.SPARSE_FACTOR_S = 1.0  # (the plan weighs the two: the factorisation's estimate made the larger)
        accuracy = "high" if method == "iterative-high" else "fast"
        # as a user calls it: `System.modes` forms the spring factor for "high" only
        modes = system.modes(MODES, accuracy=accuracy, max_seconds=float("inf"), max_memory=float("inf"),
                             progress=lambda fraction, message: stages.append(message))
        assert modes.path == ("accurate-iterative" if accuracy == "high" else "iterative"), modes.path
        values, vectors = modes.omega ** 2 * np.sign(modes.omega), modes.vectors
        moving = modes.omega ** 2 > 1e-6 * norm  # (the six rigid-body modes: zero, within absolute bounds)
        relative = (2 * np.abs(modes.omega) * modes.omega_error + modes.omega_error ** 2)[moving] / values[moving]
        bounds = {"max_relative_bound": float(relative.max()), "moving_modes": int(moving.sum()),
                  "bounds_over_target": int(np.count_nonzero(relative > 1e-10))}
    elif method == "factorisation":
        result = sparse_path(K, n_modes=MODES, vectors=True, band=None)
        values, vectors = result.eigenvalues, result.vectors
    else:
        values, vectors = sla.eigsh(K.tocsc(), k=MODES, sigma=-1e-4 * norm, which="LM", tol=0.0)
    seconds = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024.0  # (the solve's, before the checks below)
    residual = np.linalg.norm(K @ vectors - vectors * values, axis=0) / norm
    iterations = [int(m.split()[1]) for m in stages if m.startswith("LOBPCG:")]
    if method == "iterative-gpu":  # (the path's own stages, with their times: the setup on the host, LOBPCG on the GPU)
        bounds["stages"] = stages
    return {"method": method, "dofs": n, "nnz": int(K.nnz), "seconds": seconds, "build_seconds": build_s,
            "peak_bytes": peak,
            "estimate_seconds": _estimate(method, K, int(system.spring_factor()[0].shape[0])),
            "max_relative_residual": float(residual.max()), "product_threads": _product_threads(),
            "iterations": iterations[0] if iterations else None,
            "values": [float(v) for v in np.sort(values)], "load_average": os.getloadavg()[0], **bounds}


class _gpu_peak:
    """The GPU's peak memory in use over a block (its free memory sampled every 20 ms by a thread), in a dict
    filled on exit: gpu_peak_bytes (above the use at entry) and the device's name."""

    def __enter__(self) -> dict:
        import threading

        import cupy

        self.cupy, self.figures, self.done = cupy, {}, threading.Event()
        free, total = cupy.cuda.runtime.memGetInfo()
        self.lowest, self.entry = free, free
        name = cupy.cuda.runtime.getDeviceProperties(0)["name"]
        self.figures["gpu"] = name.decode() if isinstance(name, bytes) else str(name)
        self.figures["gpu_total_bytes"] = int(total)
        self.thread = threading.Thread(target=self._watch, daemon=True)
        self.thread.start()
        return self.figures

    def _watch(self) -> None:
        while not self.done.wait(0.02):
            self.lowest = min(self.lowest, self.cupy.cuda.runtime.memGetInfo()[0])

    def __exit__(self, *exc: object) -> None:
        self.done.set()
        self.thread.join()
        self.figures["gpu_peak_bytes"] = int(self.entry - self.lowest)


def _measured(method: str, dofs: int, budget: float) -> dict:
    """One method on one size in its own process (its peak memory its own); a failure's exit status
    and last line of stderr."""
    done = subprocess.run([sys.executable, __file__, "--one", method, str(dofs)], capture_output=True,
                          text=True, timeout=4 * budget)
    if done.returncode:
        return {"method": method, "dofs": dofs, "failed": f"exit status {done.returncode}",
                "stderr": done.stderr.strip().splitlines()[-1:]}
    return dict(json.loads(done.stdout.strip().splitlines()[-1]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="10000,100000")
    parser.add_argument("--methods", default=",".join(METHODS))
    parser.add_argument("--budget", type=float, default=900.0, help="a method is stopped after 4 times this (s)")
    parser.add_argument("--one", nargs=2, metavar=("METHOD", "DOFS"), help=argparse.SUPPRESS)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--merge", action="store_true",
                        help="keep the stored rows of other (method, size) pairs; replace the ones measured now")
    args = parser.parse_args()
    if args.one:
        print(json.dumps(run_one(args.one[0], int(args.one[1]))))
        return
    rows = []
    path = RESULTS / "assembly.json"
    sizes = [int(x) for x in args.sizes.split(",")]
    methods = args.methods.split(",")
    if args.merge and path.exists():
        rows = [row for row in json.loads(path.read_text())["rows"]
                if not (row["method"] in methods and any(abs(row["dofs"] - size) <= 3 for size in sizes))]
    for dofs in sizes:
        for method in methods:
            print(f"{dofs} dofs, {method} ...", flush=True)
            if method == "eigsh" and dofs > EIGSH_MOST:
                rows.append({"method": method, "dofs": dofs, "skipped": f"over {EIGSH_MOST} dofs: SuperLU's "
                             "minimum-degree factor of a 3-D network (the peer's own ordering) does not fit the time"})
            else:
                rows.append(_measured(method, dofs, args.budget))
            print(rows[-1] if "failed" in rows[-1] else {k: v for k, v in rows[-1].items() if k != "values"},
                  flush=True)
            write_json("assembly", {"modes": MODES, "cutoff_angstrom": CUTOFF, "rows": rows,
                                    "note": "one run per row (N = 1), each method in its own process; "
                                            "load_average: the 1-minute load when it finished"}, rounds=1)
    print(path)


if __name__ == "__main__":
    main()
