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

Run with OPENBLAS_NUM_THREADS=1:  python benchmarks/bench_continuum.py [--quick]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks._common import RESULTS, best_time, plot_error_vs_time, write_json  # noqa: E402
from vibra import chains, continuum  # noqa: E402
from vibra.charts._style import new_figure, save_figure  # noqa: E402
from vibra.charts.chains import plot_convergence  # noqa: E402

NAME = "continuum"


def convergence(sizes: list[int], repeat: int) -> dict:
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
    cost = []
    for k, n in zip(ks, needed):
        system = chains.linear_chain(int(n), mass=1.0, stiffness=float(n) ** 2, spacing=1.0 / int(n),
                                     units="dimensionless")
        seconds, modes = best_time(lambda: system.modes(n_modes=k + 1, vectors=False), repeat=repeat)
        error = modes.omega[k] / (k * np.pi) - 1.0
        cost.append({"k": k, "n_needed": int(n), "error_at_n": float(error), "seconds": seconds})
    out["cost_to_1e-6"] = cost
    fig = plot_convergence(high, title="Free chain to the rod: |relative error| of mode k (accurate path)")
    save_figure(fig, RESULTS / f"{NAME}_convergence.png")
    fig, ax = new_figure()
    for i, k in enumerate(ks):
        line, = ax.loglog(sizes, np.abs(high.errors[:, i]), "o-", ms=4, label=f"k={k}, accurate path")
        ax.loglog(sizes, np.maximum(np.abs(studies["fast"].errors[:, i]), 1e-17), "x--", color=line.get_color(),
                  ms=5, label=f"k={k}, fast path")
    ax.set_xlabel("number of masses N (L fixed)")
    ax.set_ylabel("|ω_chain / ω_rod − 1| (relative)")
    ax.set_title("Continuum error seen through each solver path")
    ax.legend(fontsize=8, ncol=2)
    save_figure(fig, RESULTS / f"{NAME}_paths.png")
    return out


def long_chains(sizes: list[int], repeat: int) -> dict:
    rows = []
    series: dict[str, list[tuple[float, float]]] = {"Fourier (periodic ring)": [], "accurate path (free chain)": [],
                                                   "fast path (free chain)": []}
    for n in sizes:
        start = time.perf_counter()
        ring = chains.linear_chain(n, ends="periodic", units="dimensionless")
        free = chains.linear_chain(n, ends="free", units="dimensionless")
        build = (time.perf_counter() - start) / 2
        exact_ring = chains.monatomic_frequencies(n, ends="periodic")[1]
        exact_free = chains.monatomic_frequencies(n, ends="free")[1]
        row = {"n": n, "build_seconds": build}
        for label, run, exact in (
            ("Fourier (periodic ring)", lambda: chains.periodic_modes(ring, n_modes=5), exact_ring),
            ("accurate path (free chain)", lambda: free.modes(n_modes=5, accuracy="high"), exact_free),
            ("fast path (free chain)", lambda: free.modes(n_modes=5, accuracy="fast"), exact_free),
        ):
            seconds, modes = best_time(run, repeat=repeat)
            error = abs(modes.omega[1] / exact - 1.0)
            row[label] = {"seconds": seconds, "relative_error": float(error), "solver": modes.solver}
            series[label].append((seconds, max(error, 1e-17)))
        rows.append(row)
        print(f"N={n:>8}: " + ", ".join(f"{k.split(' (')[0]} {v['seconds']:.3g}s err {v['relative_error']:.1e}"
                                        for k, v in row.items() if isinstance(v, dict)), flush=True)
    plot_error_vs_time(NAME, series, title="5 lowest modes of a uniform chain, N = "
                       f"{sizes[0]:.0e} to {sizes[-1]:.0e}",
                       ylabel="relative error of the lowest non-zero mode")
    return {"rows": rows}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small smoke run (N up to 10^4)")
    args = parser.parse_args()
    repeat = 1 if args.quick else 3
    conv_sizes = [8, 16, 32, 64, 128, 256, 512, 1024] if args.quick else [2**p for p in range(4, 18)]
    long_sizes = [1000, 10_000] if args.quick else [1000, 10_000, 100_000, 1_000_000]
    payload = {"convergence": convergence(conv_sizes, repeat), "long_chains": long_chains(long_sizes, repeat)}
    path = write_json(NAME, payload)
    conv = payload["convergence"]
    print("fitted order (accurate):", np.round(conv["high"]["order"], 4))
    print("fitted coefficient:", np.round(conv["high"]["coefficient"], 4), "expected",
          np.round(conv["expected_coefficient"], 4))
    print("fitted order (fast):", np.round(conv["fast"]["order"], 4))
    for row in conv["cost_to_1e-6"]:
        print(f"k={row['k']}: N={row['n_needed']} gives {row['error_at_n']:.3e} in {row['seconds']:.3g}s")
    print("wrote", path)


if __name__ == "__main__":
    main()
