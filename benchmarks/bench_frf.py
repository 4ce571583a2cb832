"""FRF of a long damped chain: direct (banded) versus modal superposition, time and error.

A fixed-free chain of N unit masses and unit springs (N = 10^4 by default) with Rayleigh
damping (zeta = 1 % at omega_1 and omega_20) is driven at its free end at 1000 frequencies
from omega_1 / 2 to omega_20. Methods, timed in one process:

- ``banded LAPACK (baseline)``: scipy.linalg.solve_banded per frequency on prebuilt storage;
- ``vibra direct``: `vibra.response.frequency_response(method="direct")` (tridiagonal path);
- ``sparse LU (general)``: scipy.sparse.linalg.splu per frequency, timed on a subset of the
  frequencies and scaled to all of them (it is ~20x slower);
- ``vibra modal, all modes``: every normal mode (skipped with --quick above 2000 dofs);
- ``vibra modal, 20 modes`` without and with the residual (static) correction.

The reference is the banded solution refined once with a residual computed in extended
precision (numpy longdouble), which removes the conditioning error of the plain solve. The
error of each method is the largest (and median) relative 2-norm error over frequencies; for
the modal method the reported `truncation_error` estimate is set beside the true error.

Run with OPENBLAS_NUM_THREADS=1:  python benchmarks/bench_frf.py [--quick]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import scipy.linalg as la  # noqa: E402
import scipy.sparse as sp  # noqa: E402
import scipy.sparse.linalg as spla  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks._common import best_time, plot_error_vs_time, write_json  # noqa: E402
from vibra import normal_modes  # noqa: E402
from vibra.response import frequency_response, rayleigh_coefficients, rayleigh_damping  # noqa: E402


def build(n: int) -> tuple[sp.csr_matrix, np.ndarray, sp.csr_matrix, np.ndarray, np.ndarray]:
    main = 2.0 * np.ones(n)
    main[-1] = 1.0                                              # free end
    K = sp.diags([-np.ones(n - 1), main, -np.ones(n - 1)], [-1, 0, 1], format="csr")
    M = np.ones(n)
    k = np.arange(1, 21)
    omega_k = 2.0 * np.sin((2 * k - 1) * np.pi / (2 * (2 * n + 1)))   # closed form, fixed-free
    a, b = rayleigh_coefficients(omega_k[0], omega_k[19], 0.01, 0.01)
    C = rayleigh_damping(K, M, a, b)
    force = np.zeros(n)
    force[-1] = 1.0
    return K, M, C, force, omega_k


def refined_reference(K: sp.csr_matrix, M: np.ndarray, C: sp.csr_matrix, omegas: np.ndarray,
                      force: np.ndarray, x: np.ndarray) -> np.ndarray:
    """One step of iterative refinement with the residual in extended precision."""
    n = K.shape[0]
    lower, main, upper = (np.asarray(A.diagonal(o)) for A in (K,) for o in (-1, 0, 1))
    c_low, c_main, c_up = (np.asarray(C.diagonal(o)) for o in (-1, 0, 1))
    refined = np.empty_like(x)
    ld = np.longdouble
    for i, w in enumerate(omegas):
        W = ld(w)
        d = main.astype(ld) - W * W * M.astype(ld) + 1j * W * c_main.astype(ld)
        lo = lower.astype(ld) + 1j * W * c_low.astype(ld)
        up = upper.astype(ld) + 1j * W * c_up.astype(ld)
        xi = x[i].astype(np.clongdouble)
        Ax = d * xi
        Ax[1:] += lo * xi[:-1]
        Ax[:-1] += up * xi[1:]
        residual = (force.astype(np.clongdouble) - Ax).astype(complex)
        ab = np.zeros((3, n), dtype=complex)
        ab[0, 1:] = up.astype(complex)
        ab[1] = d.astype(complex)
        ab[2, :-1] = lo.astype(complex)
        refined[i] = x[i] + la.solve_banded((1, 1), ab, residual)
    return refined


def errors(x: np.ndarray, reference: np.ndarray) -> np.ndarray:
    return np.linalg.norm(x - reference, axis=1) / np.linalg.norm(reference, axis=1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small smoke run (N = 2000, 100 frequencies)")
    args = parser.parse_args()
    n, n_freq = (2000, 100) if args.quick else (10_000, 1000)
    K, M, C, force, omega_k = build(n)
    omegas = np.linspace(0.5 * omega_k[0], omega_k[19], n_freq)
    repeat = 1 if args.quick else 3
    rows: list[dict] = []
    series: dict[str, list[tuple[float, float]]] = {}

    # Baseline: bare LAPACK banded solve per frequency (storage built outside the timing).
    ab_k = np.zeros((3, n)); ab_c = np.zeros((3, n))
    for A, ab in ((K, ab_k), (C, ab_c)):
        ab[0, 1:] = A.diagonal(1); ab[1] = A.diagonal(0); ab[2, :-1] = A.diagonal(-1)
    ab_m = np.zeros((3, n)); ab_m[1] = M

    def baseline() -> np.ndarray:
        out = np.empty((n_freq, n), dtype=complex)
        for i, w in enumerate(omegas):
            out[i] = la.solve_banded((1, 1), ab_k - w * w * ab_m + 1j * w * ab_c, force,
                                     check_finite=False)
        return out

    t_base, x_base = best_time(baseline, repeat)
    start = time.perf_counter()
    reference = refined_reference(K, M, C, omegas, force, x_base)
    t_reference = time.perf_counter() - start

    def record(name: str, seconds: float, x: np.ndarray, estimate: np.ndarray | None = None,
               note: str = "") -> None:
        e = errors(x, reference)
        row = {"method": name, "time_s": seconds, "ratio_to_banded_lapack": seconds / t_base,
               "max_rel_error": float(e.max()), "median_rel_error": float(np.median(e)), "note": note}
        if estimate is not None:
            row["max_estimated_error"] = float(estimate.max())
            row["median_estimated_error"] = float(np.median(estimate))
            with np.errstate(divide="ignore", invalid="ignore"):
                row["min_estimate_over_true"] = float(np.min(estimate / e))
        rows.append(row)
        series[name] = [(seconds, float(e.max()))]
        print(f"{name:38s} {seconds:8.3f} s  x{seconds / t_base:6.2f}  max err {e.max():.2e}  "
              f"median {np.median(e):.2e}" + (f"  est max {estimate.max():.2e}" if estimate is not None else ""),
              flush=True)

    record("banded LAPACK (baseline)", t_base, x_base)

    t_direct, result = best_time(lambda: frequency_response(K, M, C, omegas, force), repeat)
    record(f"vibra direct ({result.solver})", t_direct, result.response)

    subset = omegas[:: max(1, n_freq // 50)]
    K_c, M_c, C_c = K.tocsc(), sp.diags(M, format="csc"), C.tocsc()

    def sparse_lu() -> np.ndarray:
        return np.stack([spla.splu(sp.csc_matrix(K_c - w * w * M_c + 1j * w * C_c)).solve(force.astype(complex))
                         for w in subset])

    t_sparse, x_sparse = best_time(sparse_lu, 1)
    index = np.searchsorted(omegas, subset)
    e_sparse = errors(x_sparse, reference[index])
    t_sparse_all = t_sparse * n_freq / subset.size
    rows.append({"method": "sparse LU (general)", "time_s": t_sparse_all,
                 "ratio_to_banded_lapack": t_sparse_all / t_base, "max_rel_error": float(e_sparse.max()),
                 "median_rel_error": float(np.median(e_sparse)),
                 "note": f"timed on {subset.size} of {n_freq} frequencies, scaled"})
    series["sparse LU (general)"] = [(t_sparse_all, float(e_sparse.max()))]
    print(f"{'sparse LU (general, scaled)':38s} {t_sparse_all:8.3f} s  x{t_sparse_all / t_base:6.2f}  "
          f"max err {e_sparse.max():.2e}", flush=True)

    t_eig20, modes20 = best_time(lambda: normal_modes(K, M, n_modes=21), repeat)
    for corrected in (False, True):
        name = "vibra modal, 20 modes" + (" + static correction" if corrected else "")
        seconds, res = best_time(lambda: frequency_response(
            K, M, C, omegas, force, method="modal", n_modes=20, residual_correction=corrected), repeat)
        record(name, seconds, res.response, res.truncation_error,
               note=f"includes normal_modes(n_modes=21): {t_eig20:.3f} s ({modes20.solver})")

    if not args.quick or n <= 2000:
        start = time.perf_counter()
        all_modes = normal_modes(K, M)
        t_eig_all = time.perf_counter() - start
        start = time.perf_counter()
        res = frequency_response(K, M, C, omegas, force, method="modal", modes=all_modes)
        t_sum = time.perf_counter() - start
        record("vibra modal, all modes", t_eig_all + t_sum, res.response,
               note=f"normal_modes (all, {all_modes.solver}) {t_eig_all:.2f} s + superposition {t_sum:.2f} s")

    payload = {
        "problem": {"n_dof": n, "n_freq": n_freq, "chain": "fixed-free, k = m = 1",
                    "damping": "Rayleigh, zeta = 1% at omega_1 and omega_20",
                    "omegas": [float(omegas[0]), float(omegas[-1])]},
        "reference": f"banded solve + one refinement step with longdouble residual ({t_reference:.2f} s)",
        "results": rows,
    }
    path = write_json("frf", payload)
    plot_error_vs_time("frf", series, title=f"FRF of a {n}-dof damped chain at {n_freq} frequencies",
                       ylabel="largest relative error over frequencies")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
