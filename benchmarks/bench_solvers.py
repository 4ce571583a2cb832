"""Solver paths on the free chain: time and largest relative frequency error, side by side.

Truth: the closed form omega_j = 2 sqrt(kappa/m) sin(j pi / 2N) (seed 003 section 5.3).
Every path runs in the same process on the same matrices, timed by the protocol of
_common.py (warm-up, then interleaved rounds; min/median/max). The peers, each doing the
same work as the vibra path it is set beside:

- lowest 20 modes: scipy ``eigvalsh_tridiagonal(d, e, select="i", select_range=(0, 19),
  lapack_driver="stebz")`` (LAPACK bisection, tol=0: |error| <= ~eps ||K||), the strongest
  peer for a chain; and scipy ``eigsh(K, k=20, sigma=-1e-10 ||K||, which="LM")`` (ARPACK
  shift-invert with SuperLU), the general sparse peer;
- all frequencies: scipy ``eigvalsh_tridiagonal(d, e)`` (LAPACK ``stemr``, values only).

Writes results/solvers.json and results/solvers.png. Run:
    python benchmarks/bench_solvers.py [--quick]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import ROUNDS, format_ratio, interleaved, plot_error_vs_time, ratio, write_json  # noqa: E402,I001  (pins BLAS threads before numpy)

import numpy as np  # noqa: E402
import scipy.linalg as la  # noqa: E402
import scipy.sparse.linalg as sla  # noqa: E402

import vibra  # noqa: E402

K_LOWEST = 20
EIGSH = "scipy eigsh sigma=-1e-10||K|| (lowest 20)"
STEBZ = "scipy eigvalsh_tridiagonal stebz select=i (lowest 20)"
STEMR = "scipy eigvalsh_tridiagonal stemr (all)"


def free_chain(n: int) -> vibra.System:
    return vibra.System.from_springs(np.arange(n, dtype=float), 1.0, np.c_[np.arange(n - 1), np.arange(1, n)], 1.0)


def exact(n: int) -> np.ndarray:
    return 2.0 * np.sin(np.arange(n) * np.pi / (2 * n))


def relative_error(omega: np.ndarray, n: int) -> float:
    """Largest relative error over the computed nonzero frequencies (the zero mode skipped)."""
    reference = exact(n)[: omega.shape[0]]
    return float(np.max(np.abs(np.abs(omega[1:]) - reference[1:]) / reference[1:]))


def run(sizes_full: list[int], sizes_lowest: list[int]) -> dict:
    rows = []
    for n in sizes_full:
        system = free_chain(n)
        K, M = system.hessian(), system.mass_matrix()
        d, e = K.diagonal(), K.diagonal(1)
        cases = {
            STEMR: lambda: np.sqrt(np.abs(la.eigvalsh_tridiagonal(d, e, check_finite=False))),
            "vibra tridiagonal (all)": lambda: vibra.normal_modes(K, M, vectors=False, solver="tridiagonal").omega,
            "vibra accurate (all)": lambda: system.modes(vectors=False).omega,
        }
        if n <= 3000:
            cases["vibra dense (all)"] = lambda: vibra.normal_modes(K, M, vectors=False, solver="dense").omega
        print(f"all frequencies, n = {n}", flush=True)
        for label, t in interleaved(cases).items():
            rows.append({"path": label, "n": n, **t.summary(), "error": relative_error(np.sort(t.result), n),
                         "_timing": t})
    for n in sizes_lowest:
        system = free_chain(n)
        K, M = system.hessian(), system.mass_matrix()
        d, e = K.diagonal(), K.diagonal(1)
        norm = 4.0
        cases = {
            STEBZ: lambda: np.sqrt(np.abs(la.eigvalsh_tridiagonal(
                d, e, select="i", select_range=(0, K_LOWEST - 1), lapack_driver="stebz", check_finite=False))),
            EIGSH: lambda: np.sqrt(np.abs(np.sort(sla.eigsh(K, k=K_LOWEST, sigma=-1e-10 * norm, which="LM")[0]))),
            "vibra sparse (lowest 20)": lambda: vibra.normal_modes(K, M, n_modes=K_LOWEST).omega,
            "vibra accurate (lowest 20)": lambda: system.modes(n_modes=K_LOWEST).omega,
        }
        print(f"lowest {K_LOWEST} modes, n = {n}", flush=True)
        for label, t in interleaved(cases).items():
            rows.append({"path": label, "n": n, **t.summary(), "error": relative_error(np.sort(t.result), n),
                         "_timing": t})
    return {"rows": rows}


def headline(rows: list[dict]) -> dict:
    def find(path: str, n: int) -> dict | None:
        return next((r for r in rows if r["path"] == path and r["n"] == n), None)

    figures: dict = {}
    for n in sorted({r["n"] for r in rows if "lowest" in r["path"]}):
        for path in ("vibra sparse (lowest 20)", "vibra accurate (lowest 20)"):
            row = find(path, n)
            entry: dict = {"error": row["error"]} if row else {}
            for peer in (STEBZ, EIGSH):
                peer_row = find(peer, n)
                if row and peer_row:
                    entry[f"time_ratio_vs {peer}"] = ratio(row["_timing"], peer_row["_timing"])
                    entry[f"error of {peer}"] = peer_row["error"]
            figures[f"{path} at n={n}"] = entry
    for n in sorted({r["n"] for r in rows if "(all)" in r["path"]}):
        reference = find(STEMR, n)
        for path in ("vibra accurate (all)", "vibra tridiagonal (all)"):
            row = find(path, n)
            if row and reference:
                figures[f"{path} at n={n}"] = {
                    "time_ratio_vs " + STEMR: ratio(row["_timing"], reference["_timing"]),
                    "error": row["error"], "scipy_error": reference["error"],
                    "error_improvement": reference["error"] / max(row["error"], 1e-300),
                }
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes only (smoke run, results/quick/)")
    args = parser.parse_args()
    if args.quick:
        payload = run([100, 1000], [10_000])
    else:
        payload = run([100, 1000, 3000, 10_000, 30_000], [10_000, 100_000, 1_000_000])
    series: dict[str, list] = {}
    for row in payload["rows"]:
        series.setdefault(row["path"], []).append((row["_timing"], row["error"]))
    payload["headline"] = headline(payload["rows"])
    for key, value in payload["headline"].items():
        print(key, {k: (format_ratio(v) if isinstance(v, dict) else f"{v:.2e}") for k, v in value.items()})
    for row in payload["rows"]:
        del row["_timing"]
    payload["peers"] = {STEBZ: "LAPACK dstebz bisection via scipy, tol=0 (default), values only",
                        EIGSH: "ARPACK shift-invert, SuperLU factor of K - sigma I, sigma = -1e-10 * 4",
                        STEMR: "LAPACK dstemr via scipy, values only"}
    write_json("solvers", payload, ROUNDS)
    plot_error_vs_time("solvers", series, title="Free chain: largest relative frequency error vs time (points: N)")


if __name__ == "__main__":
    main()
