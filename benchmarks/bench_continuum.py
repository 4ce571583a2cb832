"""Continuum limit of the free chain, and the cost of the lowest modes of long chains.

Part 1 (convergence): a free chain of N unit masses on a rod of length L = 1 with c = 1
(dx = 1 / N, Omega = N). The relative error of modes k = 1..4 against the rod
omega_k = k pi c / L is measured for N = 16 .. 2^17 with the accurate solver path
(``accuracy="high"``) and the fast one, the order and coefficient are fitted (expected
2 and (k pi)^2 / 24), and the N needed for 1e-6 relative is read off the fit and checked,
with the time to solve that chain.

Part 2 (long chains): the 5 lowest modes of a uniform chain, N = 10^3 .. 10^6:
``vibra.chains.periodic_modes`` (Fourier, periodic ring), ``System.modes(n_modes=5,
accuracy="high")`` and ``accuracy="fast"`` (free chain); time and the relative error of
the lowest non-zero mode against the closed form. Build time is excluded and reported.

Timings follow the protocol of _common.py (warm-up, interleaved rounds, min/median/max).
Run:  python benchmarks/bench_continuum.py [--quick]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import ROUNDS, interleaved, new_figure, plot_error_vs_time, save_figure, write_json  # noqa: E402,I001  (pins BLAS threads before numpy)

import numpy as np  # noqa: E402

from vibra import chains, continuum  # noqa: E402

NAME = "continuum"


def plot_convergence(study, title: str):  # noqa: ANN001,ANN201  (a continuum.convergence_study result)
    """Log-log |relative error| of each mode against N: measured points, fitted power law (solid)
    and the prediction (k pi)^2 / (24 N^2) (dashed)."""
    fig, ax = new_figure()
    sizes = np.asarray(study.n_sites, dtype=float)
    expected = study.expected_coefficient()
    for i, k in enumerate(study.modes):
        line, = ax.loglog(sizes, np.abs(study.errors[:, i]), "o", ms=5,
                          label=f"mode k={k}: fitted order {study.order[i]:.3f}")
        ax.loglog(sizes, study.coefficient[i] * sizes ** -study.order[i], "-", color=line.get_color(), lw=1.0)
        ax.loglog(sizes, expected[i] / sizes**2, "--", color=line.get_color(), lw=1.0, alpha=0.7)
    ax.plot([], [], "k--", lw=1.0, label="prediction (kπ)²/(24 N²)")
    ax.set_xlabel("number of masses N (L fixed)")
    ax.set_ylabel("|ω_chain / ω_continuum − 1| (relative)")
    ax.set_title(title)
    ax.legend(fontsize=9)
    return fig


def convergence(sizes: list[int]) -> dict:
    ks = [1, 2, 3, 4]
    out: dict = {"modes": ks, "n_sites": sizes}
    studies = {}
    for accuracy in ("high", "fast"):
        study = continuum.convergence_study(ks, sizes, ends="free", accuracy=accuracy)
        studies[accuracy] = study
        out[accuracy] = {
            "solver": study.solver,
            "errors": study.errors.tolist(),
            "order": study.order.tolist(),
            "coefficient": study.coefficient.tolist(),
        }
    high = studies["high"]
    out["expected_coefficient"] = high.expected_coefficient().tolist()
    # Fit on the range where the accurate errors are far above rounding (|err| > 1e-11).
    needed = high.n_for_error(1e-6)
    cases = {}
    for k, n in zip(ks, needed):
        system = chains.linear_chain(int(n), mass=1.0, stiffness=float(n) ** 2, spacing=1.0 / int(n),
                                     units="dimensionless")
        cases[k] = (int(n), lambda system=system, k=k: system.modes(n_modes=k + 1, vectors=False))
    print("cost to 1e-6 (accurate path)", flush=True)
    timings = interleaved({f"k={k}, N={n}": call for k, (n, call) in cases.items()})
    cost = []
    for k, t in zip(cases, timings.values()):
        error = t.result.omega[k] / (k * np.pi) - 1.0
        cost.append({"k": k, "n_needed": cases[k][0], "error_at_n": float(error), **t.summary()})
    out["cost_to_1e-6"] = cost
    fig = plot_convergence(high, title="Free chain to the rod: |relative error| of mode k (accurate path)")
    save_figure(fig, f"{NAME}_convergence")
    fig, ax = new_figure()
    for i, k in enumerate(ks):
        line, = ax.loglog(sizes, np.abs(high.errors[:, i]), "o-", ms=4, label=f"k={k}, accurate path")
        ax.loglog(sizes, np.maximum(np.abs(studies["fast"].errors[:, i]), 1e-17), "x--", color=line.get_color(),
                  ms=5, label=f"k={k}, fast path")
    ax.set_xlabel("number of masses N (L fixed)")
    ax.set_ylabel("|ω_chain / ω_rod − 1| (relative)")
    ax.set_title("Continuum error seen through each solver path")
    ax.legend(fontsize=8, ncol=2)
    save_figure(fig, f"{NAME}_paths")
    return out


def long_chains(sizes: list[int]) -> dict:
    rows = []
    series: dict[str, list] = {"Fourier (periodic ring)": [], "accurate path (free chain)": [],
                                                   "fast path (free chain)": []}
    for n in sizes:
        start = time.perf_counter()
        ring = chains.linear_chain(n, ends="periodic", units="dimensionless")
        free = chains.linear_chain(n, ends="free", units="dimensionless")
        build = (time.perf_counter() - start) / 2
        exact_ring = chains.monatomic_frequencies(n, ends="periodic")[1]
        exact_free = chains.monatomic_frequencies(n, ends="free")[1]
        row = {"n": n, "build_seconds": build}
        exact = {"Fourier (periodic ring)": exact_ring, "accurate path (free chain)": exact_free,
                 "fast path (free chain)": exact_free}
        print(f"lowest 5 modes, N = {n}", flush=True)
        timings = interleaved({
            "Fourier (periodic ring)": lambda: chains.periodic_modes(ring, n_modes=5),
            "accurate path (free chain)": lambda: free.modes(n_modes=5, accuracy="high"),
            "fast path (free chain)": lambda: free.modes(n_modes=5, accuracy="fast"),
        })
        for label, t in timings.items():
            error = abs(t.result.omega[1] / exact[label] - 1.0)
            row[label] = {**t.summary(), "relative_error": float(error), "solver": t.result.solver}
            series[label].append((t, max(error, 1e-17)))
        rows.append(row)
    plot_error_vs_time(NAME, series, title="5 lowest modes of a uniform chain, N = "
                       f"{sizes[0]:.0e} to {sizes[-1]:.0e}",
                       ylabel="relative error of the lowest non-zero mode")
    return {"rows": rows}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small smoke run (N up to 10^4)")
    args = parser.parse_args()
    conv_sizes = [8, 16, 32, 64, 128, 256, 512, 1024] if args.quick else [2**p for p in range(4, 18)]
    long_sizes = [1000, 10_000] if args.quick else [1000, 10_000, 100_000, 1_000_000]
    payload = {"convergence": convergence(conv_sizes), "long_chains": long_chains(long_sizes)}
    path = write_json(NAME, payload, ROUNDS)
    conv = payload["convergence"]
    print("fitted order (accurate):", np.round(conv["high"]["order"], 4))
    print("fitted coefficient:", np.round(conv["high"]["coefficient"], 4), "expected",
          np.round(conv["expected_coefficient"], 4))
    print("fitted order (fast):", np.round(conv["fast"]["order"], 4))
    for row in conv["cost_to_1e-6"]:
        print(f"k={row['k']}: N={row['n_needed']} gives {row['error_at_n']:.3e} in {row['min_s']:.3g} s (best)")
    print("wrote", path)


if __name__ == "__main__":
    main()
