"""Solver paths on the free chain: time and largest relative frequency error, side by side.

Truth: the closed form omega_j = 2 sqrt(kappa/m) sin(j pi / 2N) (seed 003 section 5.3).
Every path runs in the same process on the same matrices; scipy's own calls are the
references for the ratios the foundation issue sets:

- lowest 20 modes of a 10^6-site chain: vibra's sparse path and accurate path against a
  well-shifted scipy ``eigsh`` shift-invert call (sigma = -1e-10 ||K||);
- all frequencies of a 10^4-site chain: the accurate path against
  ``scipy.linalg.eigvalsh_tridiagonal``.

Writes results/solvers.json and results/solvers.png. Run:
    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_solvers.py [--quick]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import scipy.linalg as la
import scipy.sparse.linalg as sla

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import best_time, plot_error_vs_time, write_json  # noqa: E402

import vibra  # noqa: E402

K_LOWEST = 20


def free_chain(n: int) -> vibra.System:
    return vibra.System.from_springs(np.arange(n, dtype=float), 1.0, np.c_[np.arange(n - 1), np.arange(1, n)], 1.0)


def exact(n: int) -> np.ndarray:
    return 2.0 * np.sin(np.arange(n) * np.pi / (2 * n))


def relative_error(omega: np.ndarray, n: int) -> float:
    """Largest relative error over the computed nonzero frequencies (the zero mode skipped)."""
    reference = exact(n)[: omega.shape[0]]
    return float(np.max(np.abs(np.abs(omega[1:]) - reference[1:]) / reference[1:]))


def run(sizes_full: list[int], sizes_lowest: list[int], repeat: int) -> dict:
    rows = []
    for n in sizes_full:
        system = free_chain(n)
        K, M = system.hessian(), system.mass_matrix()
        d, e = K.diagonal(), K.diagonal(1)
        cases = {
            "scipy eigvalsh_tridiagonal (all)": lambda: np.sqrt(np.abs(la.eigvalsh_tridiagonal(d, e))),
            "vibra tridiagonal (all)": lambda: vibra.normal_modes(K, M, vectors=False, solver="tridiagonal").omega,
            "vibra accurate (all)": lambda: system.modes(vectors=False).omega,
        }
        if n <= 3000:
            cases["vibra dense (all)"] = lambda: vibra.normal_modes(K, M, vectors=False, solver="dense").omega
        for label, call in cases.items():
            seconds, omega = best_time(call, repeat=repeat)
            rows.append({"path": label, "n": n, "seconds": seconds, "error": relative_error(np.sort(omega), n)})
            print(f"{label:40s} n={n:>8d}  {seconds:9.4f} s  error {rows[-1]['error']:.2e}", flush=True)
    for n in sizes_lowest:
        system = free_chain(n)
        K, M = system.hessian(), system.mass_matrix()
        norm = 4.0
        cases = {
            "scipy eigsh sigma=-1e-10||K|| (lowest 20)": lambda: np.sqrt(np.abs(np.sort(
                sla.eigsh(K, k=K_LOWEST, sigma=-1e-10 * norm, which="LM")[0]))),
            "vibra sparse (lowest 20)": lambda: vibra.normal_modes(K, M, n_modes=K_LOWEST).omega,
            "vibra accurate (lowest 20)": lambda: system.modes(n_modes=K_LOWEST).omega,
        }
        for label, call in cases.items():
            seconds, omega = best_time(call, repeat=repeat if n < 10**6 else 1)
            rows.append({"path": label, "n": n, "seconds": seconds, "error": relative_error(np.sort(omega), n)})
            print(f"{label:40s} n={n:>8d}  {seconds:9.4f} s  error {rows[-1]['error']:.2e}", flush=True)
    return {"rows": rows}


def headline(rows: list[dict]) -> dict:
    def find(path: str, n: int) -> dict | None:
        return next((r for r in rows if r["path"] == path and r["n"] == n), None)

    figures = {}
    n_low = max((r["n"] for r in rows if "lowest" in r["path"]), default=None)
    if n_low:
        scipy_row = find("scipy eigsh sigma=-1e-10||K|| (lowest 20)", n_low)
        for path in ("vibra sparse (lowest 20)", "vibra accurate (lowest 20)"):
            row = find(path, n_low)
            if scipy_row and row:
                figures[f"{path} at n={n_low}"] = {
                    "time_ratio_vs_scipy_eigsh": row["seconds"] / scipy_row["seconds"],
                    "error": row["error"], "scipy_error": scipy_row["error"],
                }
    n_full = 10_000 if find("vibra accurate (all)", 10_000) else max((r["n"] for r in rows if "(all)" in r["path"]), default=None)
    if n_full:
        accurate = find("vibra accurate (all)", n_full)
        reference = find("scipy eigvalsh_tridiagonal (all)", n_full)
        if accurate and reference:
            figures[f"vibra accurate (all) at n={n_full}"] = {
                "time_ratio_vs_eigvalsh_tridiagonal": accurate["seconds"] / reference["seconds"],
                "error": accurate["error"], "scipy_error": reference["error"],
                "error_improvement": reference["error"] / max(accurate["error"], 1e-300),
            }
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes only (smoke run)")
    args = parser.parse_args()
    if args.quick:
        payload = run([100, 1000], [10_000], repeat=1)
    else:
        payload = run([100, 1000, 3000, 10_000, 30_000], [10_000, 100_000, 1_000_000], repeat=3)
    payload["headline"] = headline(payload["rows"])
    for key, value in payload["headline"].items():
        print(key, value)
    name = "solvers"  # a --quick run writes to results/quick/ (see _common.RESULTS)
    write_json(name, payload)
    series: dict[str, list[tuple[float, float]]] = {}
    for row in payload["rows"]:
        series.setdefault(row["path"], []).append((row["seconds"], row["error"]))
    plot_error_vs_time(name, series, title="Free chain: largest relative frequency error vs time (points: N)")


if __name__ == "__main__":
    main()
