"""All frequencies of a chain, values only: certified bounds at every length, and what they cost.

    python benchmarks/bench_chain_bounds.py [--quick]

Issue 15, item 6: every bound of the accurate path (`accurate-bidiagonal`) is a certificate
(`vibra.solvers.accurate.chain.triplets`: a triplet per value, Kato-Temple), where before 3,000 sites it was
the a-priori size law, 10 n eps (2.3e-11 relative at 10^4 for errors of ~1e-16). Measured per
length, by the protocol of STYLE.md (one process, warm-up, interleaved rounds, BLAS threads 1):

- time of `modes(vectors=False)` (high), of `accuracy="fast"`, and of the strongest peer for all
  values of a symmetric tridiagonal, LAPACK dstemr (scipy `eigvalsh_tridiagonal`);
- the bounds: largest and median relative bound of omega; for the uniform chain the largest
  true error and the largest bound / error ratio, truth the closed form 2 sin(j pi / 2n) in
  30-digit mpmath (never vibra).

Chains: uniform free chains and disordered ones (masses and springs log-uniform over 1e6,
both ends fixed). Writes results/chain_bounds.json.
"""

from __future__ import annotations

import argparse

from _common import ROUNDS, format_ratio, interleaved, ratio, write_json  # noqa: I001  (sets BLAS threads)

import mpmath
import numpy as np
import scipy.linalg as la

import vibra
from vibra.chains import linear_chain

STEMR = "scipy eigvalsh_tridiagonal (stemr)"


def chain(n: int, disordered: bool) -> vibra.System:
    """A uniform free chain, or a fixed one with masses and springs log-uniform over 1e6."""
    if not disordered:
        return linear_chain(n, ends="free", units="dimensionless")
    rng = np.random.default_rng(5)
    return linear_chain(n, mass=10.0 ** rng.uniform(0, 6, n), stiffness=10.0 ** rng.uniform(0, 6, n + 1),
                        ends="fixed", units="dimensionless")


def run(sizes: list[int]) -> dict:
    rows = []
    for disordered in (False, True):
        for n in sizes:
            system = chain(n, disordered)
            K, M = system.hessian(), system.mass_matrix()
            scale = 1.0 / np.sqrt(M if np.ndim(M) == 1 else M.diagonal())
            Kt = (K.multiply(scale[:, None]).multiply(scale[None, :])).tocsr()
            d, e = Kt.diagonal(), Kt.diagonal(1)
            cases = {
                STEMR: lambda: la.eigvalsh_tridiagonal(d, e, check_finite=False),
                "vibra fast": lambda: system.modes(vectors=False, accuracy="fast"),
                "vibra high": lambda: system.modes(vectors=False),
            }
            label = f"{'disordered (1e6)' if disordered else 'uniform'}, n = {n}"
            print(label, flush=True)
            timings = interleaved(cases)
            high = timings["vibra high"].result
            nonzero = high.omega > 0
            relative = high.omega_error[nonzero] / high.omega[nonzero]
            row = {"chain": "disordered" if disordered else "uniform", "n": n, "solver": high.solver,
                   "high_vs_fast": ratio(timings["vibra high"], timings["vibra fast"]),
                   "high_vs_stemr": ratio(timings["vibra high"], timings[STEMR]),
                   "times_s": {k: t.summary() for k, t in timings.items()},
                   "bound_max": float(relative.max()), "bound_median": float(np.median(relative))}
            if not disordered:
                with mpmath.workdps(30):
                    errors = np.array([float(abs(mpmath.mpf(float(high.omega[j]))
                                                 - 2 * mpmath.sin(j * mpmath.pi / (2 * n)))) for j in range(1, n)])
                truth = 2 * np.sin(np.arange(1, n) * np.pi / (2 * n))
                row["true_error_max"] = float(np.max(errors / truth))
                row["covered"] = bool(np.all(errors <= high.omega_error[1:]))
                tight = np.maximum(1000 * errors, 1e-13 * truth)
                row["within_1000x_or_1e-13"] = bool(np.all(high.omega_error[1:] <= tight))
            print(f"  high/fast {format_ratio(row['high_vs_fast'])}, high/stemr {format_ratio(row['high_vs_stemr'])}, "
                  f"bound max {row['bound_max']:.2e} median {row['bound_median']:.2e}"
                  + (f", true error max {row['true_error_max']:.2e}, covered {row['covered']}, "
                     f"tight {row['within_1000x_or_1e-13']}" if not disordered else ""), flush=True)
            rows.append(row)
    return {"rows": rows}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes only (smoke run, results/quick/)")
    args = parser.parse_args()
    payload = run([1000, 3000] if args.quick else [1000, 3000, 10_000, 30_000])
    payload["peers"] = {STEMR: "LAPACK dstemr via scipy, values only, of the mass-weighted tridiagonal"}
    write_json("chain_bounds", payload, ROUNDS)


if __name__ == "__main__":
    main()
