"""FRF of a long damped chain: direct (banded) versus modal superposition, time and error.

A fixed-free chain of N unit masses and unit springs (N = 10^4 by default) with Rayleigh
damping (zeta = 1 % at omega_1 and omega_20) is driven at its free end at 1000 frequencies
from omega_1 / 2 to omega_20. Methods, timed in one process:

- ``LAPACK zgtsv loop (peer)``: scipy.linalg.lapack.zgtsv per frequency (tridiagonal LU with
  partial pivoting, the same work as vibra's direct path), diagonals assembled per frequency
  from prebuilt K, M, C diagonals, overwrite flags on: the strongest peer;
- ``banded LAPACK``: scipy.linalg.solve_banded per frequency on prebuilt storage (general
  banded ``zgbsv``; the old baseline, kept for comparison);
- ``vibra direct``: `vibra.response.frequency_response(method="direct")` (tridiagonal path);
- ``sparse LU (general)``: scipy.sparse.linalg.splu per frequency, timed on a subset of the
  frequencies and scaled to all of them (it is ~20x slower);
- ``vibra modal, all modes``: every normal mode, timed in its own warm-up + rounds (it is
  ~100x slower than the rest);
- ``vibra modal, 20 modes`` without and with the residual (static) correction.

The reference is the banded solution refined once with a residual computed in extended
precision (numpy longdouble), which removes the conditioning error of the plain solve. The
error of each method is the largest (and median) relative 2-norm error over frequencies; for
the modal method the reported `truncation_error` estimate is set beside the true error.

All timings follow the protocol of _common.py (warm-up, interleaved rounds, min/median/max).
Run:  python benchmarks/bench_frf.py [--quick]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import (ROUNDS, Timing, format_ratio, interleaved, plot_error_vs_time, ratio,  # noqa: E402,I001
                     write_json)  # (pins BLAS threads before numpy)

import numpy as np  # noqa: E402
import scipy.linalg as la  # noqa: E402
import scipy.sparse as sp  # noqa: E402
import scipy.sparse.linalg as spla  # noqa: E402
from scipy.linalg.lapack import zgtsv  # noqa: E402

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

    # Peers' storage is built outside the timing.
    k_low, k_main, k_up = (np.asarray(K.diagonal(o)) for o in (-1, 0, 1))
    c_low, c_main, c_up = (np.asarray(C.diagonal(o)) for o in (-1, 0, 1))
    rhs = force.astype(complex)[:, None]

    def zgtsv_loop() -> np.ndarray:
        out = np.empty((n_freq, n), dtype=complex)
        for i, w in enumerate(omegas):
            *_, x, info = zgtsv(k_low + 1j * w * c_low, k_main - w * w * M + 1j * w * c_main,
                                k_up + 1j * w * c_up, rhs, overwrite_dl=1, overwrite_d=1, overwrite_du=1)
            if info != 0:
                raise RuntimeError(f"zgtsv info={info} at omega={w}")
            out[i] = x[:, 0]
        return out

    ab_k = np.zeros((3, n)); ab_c = np.zeros((3, n))
    for A, ab in ((K, ab_k), (C, ab_c)):
        ab[0, 1:] = A.diagonal(1); ab[1] = A.diagonal(0); ab[2, :-1] = A.diagonal(-1)
    ab_m = np.zeros((3, n)); ab_m[1] = M

    def banded() -> np.ndarray:
        out = np.empty((n_freq, n), dtype=complex)
        for i, w in enumerate(omegas):
            out[i] = la.solve_banded((1, 1), ab_k - w * w * ab_m + 1j * w * ab_c, force, check_finite=False)
        return out

    subset = omegas[:: max(1, n_freq // 50)]
    K_c, M_c, C_c = K.tocsc(), sp.diags(M, format="csc"), C.tocsc()

    def sparse_lu() -> np.ndarray:
        return np.stack([spla.splu(sp.csc_matrix(K_c - w * w * M_c + 1j * w * C_c)).solve(force.astype(complex))
                         for w in subset])

    PEER, DIRECT = "LAPACK zgtsv loop (peer)", "vibra direct"
    methods = {
        PEER: zgtsv_loop,
        "banded LAPACK solve_banded loop": banded,
        DIRECT: lambda: frequency_response(K, M, C, omegas, force),
        "sparse LU (general)": sparse_lu,
        "vibra modal, 20 modes": lambda: frequency_response(
            K, M, C, omegas, force, method="modal", n_modes=20, residual_correction=False),
        "vibra modal, 20 modes + static correction": lambda: frequency_response(
            K, M, C, omegas, force, method="modal", n_modes=20, residual_correction=True),
        "normal_modes(n_modes=21) alone": lambda: normal_modes(K, M, n_modes=21),
    }
    print(f"FRF, n = {n}, {n_freq} frequencies", flush=True)
    timings = interleaved(methods)
    peer = timings[PEER]
    start = time.perf_counter()
    reference = refined_reference(K, M, C, omegas, force, peer.result)
    t_reference = time.perf_counter() - start
    rows: list[dict] = []
    series: dict[str, list] = {}

    def record(name: str, t: Timing, x: np.ndarray, estimate: np.ndarray | None = None, scale: float = 1.0,
               index: np.ndarray | None = None, note: str = "") -> None:
        e = errors(x, reference if index is None else reference[index])
        scaled = Timing(t.label, tuple(s * scale for s in t.seconds), None)
        r = ratio(scaled, peer)
        row = {"method": name, **scaled.summary(), "ratio_to_zgtsv": r,
               "ratio_to_banded_lapack": ratio(scaled, timings["banded LAPACK solve_banded loop"]),
               "max_rel_error": float(e.max()), "median_rel_error": float(np.median(e)), "note": note}
        if estimate is not None:
            row["max_estimated_error"] = float(estimate.max())
            row["median_estimated_error"] = float(np.median(estimate))
            with np.errstate(divide="ignore", invalid="ignore"):
                row["min_estimate_over_true"] = float(np.min(estimate / e))
        rows.append(row)
        series[name] = [(scaled, float(e.max()))]
        print(f"{name:42s} {scaled.min:8.3f} s  vs zgtsv {format_ratio(r)}  max err {e.max():.2e}  "
              f"median {np.median(e):.2e}" + (f"  est max {estimate.max():.2e}" if estimate is not None else ""),
              flush=True)

    record(PEER, peer, peer.result)
    record("banded LAPACK solve_banded loop", timings["banded LAPACK solve_banded loop"],
           timings["banded LAPACK solve_banded loop"].result)
    direct = timings[DIRECT]
    record(f"vibra direct ({direct.result.solver})", direct, direct.result.response)
    record("sparse LU (general)", timings["sparse LU (general)"], timings["sparse LU (general)"].result,
           scale=n_freq / subset.size, index=np.searchsorted(omegas, subset),
           note=f"timed on {subset.size} of {n_freq} frequencies, scaled")
    eig = timings["normal_modes(n_modes=21) alone"]
    for name in ("vibra modal, 20 modes", "vibra modal, 20 modes + static correction"):
        res = timings[name].result
        record(name, timings[name], res.response, res.truncation_error,
               note=f"includes normal_modes(n_modes=21): min {eig.min:.3f} s ({eig.result.solver})")

    def save() -> Path:
        payload = {
            "problem": {"n_dof": n, "n_freq": n_freq, "chain": "fixed-free, k = m = 1",
                        "damping": "Rayleigh, zeta = 1% at omega_1 and omega_20",
                        "omegas": [float(omegas[0]), float(omegas[-1])]},
            "peer": "scipy.linalg.lapack.zgtsv per frequency (overwrite_dl/d/du=1, one right-hand side)",
            "reference": f"zgtsv solve + one refinement step with longdouble residual ({t_reference:.2f} s)",
            "results": rows,
        }
        path = write_json("frf", payload, ROUNDS)
        plot_error_vs_time("frf", series, title=f"FRF of a {n}-dof damped chain at {n_freq} frequencies",
                           ylabel="largest relative error over frequencies")
        return path

    save()                      # the fast methods first: the all-modes rounds below take minutes
    print("modal, all modes (own rounds; warm-up on a 1000-dof chain at 100 frequencies)", flush=True)
    K_w, M_w, C_w, f_w, o_w = build(1000)
    w_w = np.linspace(0.5 * o_w[0], o_w[19], 100)
    frequency_response(K_w, M_w, C_w, w_w, f_w, method="modal", modes=normal_modes(K_w, M_w))
    all_modes = interleaved({"vibra modal, all modes": lambda: frequency_response(
        K, M, C, omegas, force, method="modal", modes=normal_modes(K, M))}, warmup=False)["vibra modal, all modes"]
    record("vibra modal, all modes", all_modes, all_modes.result.response,
           note="normal_modes (all) + superposition, timed in its own rounds after the others (warm-up on a "
                "1000-dof chain); its ratio's range is min/max of separate rounds")
    print(f"wrote {save()}")


if __name__ == "__main__":
    main()
