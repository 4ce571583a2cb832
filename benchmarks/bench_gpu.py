"""GPU versus CPU: all modes of a dense 3-D spring network (issue 14's optional GPU path).

Methods, interleaved per size in one process, best of 3 after a warm-up solve:

- ``cpu_scipy_evd``: scipy.linalg.eigh(K~, driver="evd"), LAPACK dsyevd (divide and conquer),
  all vectors, on every core the BLAS was given (the threads are recorded): the peer;
- ``gpu_vibra``: `vibra.solvers.standard.gpu.dense_eigh_gpu`, cuSOLVER Xsyevd in place, including the upload
  of K~, the residual / orthogonality figures and the download of the vectors;
- ``gpu_vibra_values``: the same, frequencies only;
- ``gpu_cupy_eigh``: cupy.linalg.eigh on a K~ already on the GPU (no transfers, no figures):
  the set-up of issue 14's anchor (30,000 dofs, 21.5 s on an H100).

Agreement: max |lambda_gpu - lambda_cpu| against the reported error (n eps ||K~|| or the
residual); where the CPU column is skipped, the trace of K~ and the six rigid-body modes.
Memory: `vibra.solvers.standard.gpu.estimate_gpu_memory` beside the measured peak (CuPy's pool in use, and
the drop of the device's free memory sampled every millisecond). The 50,000-dof case of the
issue is checked by estimate only (is it refused, and with which figures).

Run:  python benchmarks/bench_gpu.py [--sizes 3000 9000 30000] [--cpu-max 9000] [--quick]
On a machine without CuPy or a GPU the GPU columns are skipped, and the JSON says why.
Writes benchmarks/results/gpu.json.
"""

from __future__ import annotations

import argparse
import os
import sys
import threading
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from _common import best_time, write_json  # noqa: E402

from vibra.solvers.standard import gpu  # noqa: E402

EPS = float(np.finfo(float).eps)


def lattice_network(n_dof: int, seed: int = 11) -> tuple[np.ndarray, np.ndarray]:
    """(K~ dense, masses) of a free 3-D network: a jittered cubic lattice of n_dof / 3 sites,
    each joined to every site within 1.75 spacings (about 18 springs), random stiffness and mass.

    Assembled with scipy.sparse (K = sum k e e^T blocks), then made dense and mass-weighted.
    """
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(seed)
    n_sites = n_dof // 3
    side = int(np.ceil(n_sites ** (1 / 3)))
    grid = np.stack(np.meshgrid(*(np.arange(side),) * 3, indexing="ij"), axis=-1).reshape(-1, 3)[:n_sites]
    positions = grid + rng.uniform(-0.2, 0.2, (n_sites, 3))
    pairs = np.array(sorted(cKDTree(positions).query_pairs(1.75)))
    stiffness = rng.uniform(0.5, 2.0, len(pairs))
    bond = positions[pairs[:, 1]] - positions[pairs[:, 0]]
    unit = bond / np.linalg.norm(bond, axis=1)[:, None]
    block = stiffness[:, None, None] * unit[:, :, None] * unit[:, None, :]  # (n_springs, 3, 3)
    i, j = pairs[:, 0], pairs[:, 1]
    rows, cols, data = [], [], []
    for a, b, sign in ((i, i, 1.0), (j, j, 1.0), (i, j, -1.0), (j, i, -1.0)):
        r = (3 * a[:, None, None] + np.arange(3)[None, :, None]).repeat(3, axis=2)
        c = (3 * b[:, None, None] + np.arange(3)[None, None, :]).repeat(3, axis=1)
        rows.append(r.ravel())
        cols.append(c.ravel())
        data.append(sign * block.ravel())
    K = sp.coo_matrix((np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(3 * n_sites, 3 * n_sites)).toarray()
    masses = np.repeat(rng.uniform(1.0, 3.0, n_sites), 3)
    scale = 1.0 / np.sqrt(masses)
    K *= scale[:, None]
    K *= scale[None, :]
    return K, masses


def blas_threads() -> dict[str, Any]:
    """The BLAS libraries and their thread counts (threadpoolctl when installed)."""
    info: dict[str, Any] = {"cpu_count": os.cpu_count(),
                            "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS"),
                            "OMP_NUM_THREADS": os.environ.get("OMP_NUM_THREADS")}
    try:
        from threadpoolctl import threadpool_info

        info["blas"] = [{"library": p.get("internal_api"), "threads": p.get("num_threads"),
                         "version": p.get("version")} for p in threadpool_info()]
    except ImportError:
        info["blas"] = "threadpoolctl not installed"
    return info


class PeakMemory:
    """Peak GPU memory of a call: CuPy's pool in use, and the drop of the device's free memory."""

    def __init__(self, cupy: Any) -> None:
        self.cupy = cupy
        self.pool = cupy.get_default_memory_pool()
        self.pool_peak = 0
        cupy.cuda.set_allocator(self._malloc)

    def _malloc(self, size: int) -> Any:
        memory = self.pool.malloc(size)
        self.pool_peak = max(self.pool_peak, int(self.pool.used_bytes()))
        return memory

    def measure(self, function: Callable[[], Any]) -> tuple[Any, dict[str, int]]:
        self.pool.free_all_blocks()
        self.pool_peak = 0
        free_before = int(self.cupy.cuda.runtime.memGetInfo()[0])
        lowest = [free_before]
        done = threading.Event()

        def sample() -> None:
            while not done.is_set():
                lowest[0] = min(lowest[0], int(self.cupy.cuda.runtime.memGetInfo()[0]))
                time.sleep(0.001)

        sampler = threading.Thread(target=sample, daemon=True)
        sampler.start()
        try:
            result = function()
            self.cupy.cuda.Device().synchronize()
        finally:
            done.set()
            sampler.join()
        return result, {"pool_peak_bytes": self.pool_peak, "device_drop_bytes": free_before - lowest[0]}


def run(sizes: list[int], cpu_max: int, repeat: int, budget_s: float) -> dict[str, Any]:
    available, reason = gpu.gpu_available()
    payload: dict[str, Any] = {
        "benchmark": "all modes of a dense 3-D spring network, CPU LAPACK dsyevd vs GPU cuSOLVER syevd",
        "gpu": reason if available else None,
        "gpu_skipped": None if available else reason,
        "threads": blas_threads(),
        "repeat": repeat,
        "rows": [],
    }
    cupy = gpu.require_gpu() if available else None
    if cupy is not None:
        payload["cupy"] = cupy.__version__
        payload["cuda_runtime"] = int(cupy.cuda.runtime.runtimeGetVersion())
        peak = PeakMemory(cupy)
        warm, _ = lattice_network(600)
        gpu.dense_eigh_gpu(warm, vectors=True)  # warm-up: handles, kernels, pool
        gpu.dense_eigh_gpu(warm, vectors=False)
        cupy.linalg.eigh(cupy.asarray(warm))
    la.eigh(lattice_network(600)[0], driver="evd")
    print(f"GPU: {payload['gpu'] or 'skipped: ' + reason}", flush=True)
    payload["n50000"] = estimate_50000(cupy)  # first, on a clean device
    print(payload["n50000"], flush=True)
    for n in sizes:
        Kt, _ = lattice_network(n)
        n = Kt.shape[0]
        norm = float(np.abs(np.diagonal(Kt)).max())
        row: dict[str, Any] = {"n_dof": n}
        reference = None
        if n <= cpu_max:
            row["cpu_scipy_evd_s"], (reference, _) = best_time(lambda: la.eigh(Kt, driver="evd"), repeat, budget_s)
        else:
            row["cpu_scipy_evd_s"] = None
            row["cpu_skipped"] = f"n > --cpu-max {cpu_max}"
        if cupy is not None:
            for vectors, key in ((True, "gpu_vibra"), (False, "gpu_vibra_values")):
                row[f"{key}_estimate_bytes"] = gpu.estimate_gpu_memory(n, vectors=vectors)
                row[f"{key}_s"], result, row[f"{key}_peak"], row[f"{key}_runs"] = best_with_peak(
                    peak, lambda: gpu.dense_eigh_gpu(Kt, vectors=vectors), repeat, budget_s)
                bound = result.error + n * EPS * max(norm, float(np.abs(result.eigenvalues).max()))
                if reference is not None:
                    gap = np.abs(result.eigenvalues - reference)
                    row[f"{key}_max_diff_over_n_eps_norm"] = float(gap.max() / (n * EPS * norm))
                    row[f"{key}_within_bounds"] = bool((gap <= bound).all())
                row[f"{key}_trace_gap_over_error_sum"] = float(
                    abs(result.eigenvalues.sum() - np.trace(Kt)) / result.error.sum())
                row[f"{key}_rigid_modes"] = int((np.abs(result.eigenvalues) <= result.error).sum())
                row[f"{key}_residual"] = result.residual
                row[f"{key}_orthogonality"] = result.orthogonality
                del result
            device_Kt = cupy.asarray(Kt)

            def raw() -> Any:
                values, basis = cupy.linalg.eigh(device_Kt)
                cupy.cuda.Device().synchronize()
                return values

            row["gpu_cupy_eigh_s"], _, row["gpu_cupy_eigh_peak"], row["gpu_cupy_eigh_runs"] = best_with_peak(
                peak, raw, repeat, budget_s)
            del device_Kt
            cupy.get_default_memory_pool().free_all_blocks()
        print(row, flush=True)
        payload["rows"].append(row)
        del Kt
    return payload


def best_with_peak(peak: PeakMemory, function: Callable[[], Any], repeat: int, budget_s: float
                   ) -> tuple[float, Any, dict[str, int], int]:
    """Best wall time of up to `repeat` calls (fewer past `budget_s`), the last result, the
    memory peaks of the first call, and the number of calls made."""
    start = time.perf_counter()
    result, memory = peak.measure(function)
    first = time.perf_counter() - start
    if repeat < 2 or first * 2 > budget_s:
        return first, result, memory, 1
    del result
    rest, result = best_time(function, repeat - 1, budget_s - first)
    return min(first, rest), result, memory, repeat


def estimate_50000(cupy: Any) -> dict[str, Any]:
    """Issue 14's 16,716-residue complex (50,000 dofs): would all its modes fit? (estimate only)"""
    n = 50_000
    out: dict[str, Any] = {"n_dof": n}
    free = int(cupy.cuda.Device().mem_info[0]) if cupy is not None else None
    for vectors in (True, False):
        key = "vectors" if vectors else "values"
        out[f"{key}_estimate_bytes"] = gpu.estimate_gpu_memory(n, vectors=vectors)
        if free is not None:
            try:
                gpu.check_gpu_memory(n, vectors=vectors, free=free)
                out[f"{key}_verdict"] = "fits"
            except ValueError as error:
                out[f"{key}_verdict"] = str(error)
    out["free_bytes"] = free
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[3000, 9000, 30000])
    parser.add_argument("--cpu-max", type=int, default=9000, help="largest n for the CPU column")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--budget", type=float, default=60.0, help="seconds per method and size")
    parser.add_argument("--quick", action="store_true", help="small sizes, results/quick/")
    args = parser.parse_args()
    sizes = [300, 900] if args.quick else args.sizes
    payload = run(sizes, args.cpu_max, args.repeat, args.budget)
    print(write_json("gpu", payload))


if __name__ == "__main__":
    main()
