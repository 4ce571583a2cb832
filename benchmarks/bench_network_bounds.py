"""All frequencies of a 3-D spring network, values only: bounds that follow the true error, and their cost.

    python benchmarks/bench_network_bounds.py [--quick]

Issue 15, item 6: above 256 dofs the accurate path (`accurate-checked`) gave values only the
a-priori bound n eps ||K~|| (up to ~n times the true error, and above 1e-13 relative for every
mode once n passes ~900); it now computes every vector and bounds each mode from its own
residual, as with vectors. Measured per size, by the protocol of STYLE.md (one process,
warm-up, interleaved rounds, BLAS threads 1):

- time of `modes(vectors=False)` with `accuracy="high"`, of the same with vectors, of
  `accuracy="fast"` values only, and of the strongest peer for all values of a dense symmetric
  matrix, LAPACK via scipy `eigvalsh` (of the mass-weighted K~, formed outside the timing);
- the bounds: largest and median relative bound of omega, the largest true error, whether every
  bound covers its error and lies within 1000 times it (or 1e-13 relative).

Networks: periodic simple-cubic lattices (springs 1 to the nearest neighbours, 0.3 along the
face diagonals, masses 2), whose truth is closed form: Bloch waves with a 3 x 3 dynamical matrix
each, in 40-digit mpmath (`tests/solvers/test_accurate_bounds.py`, `lattice_omegas`; never vibra).

Ill-conditioned networks (random sites, 8 nearest neighbours, springs over 1e+-6, masses over
1e+-3; `tests/solvers/test_accurate_bounds.network`, seed 1), where one-sided Jacobi runs: the bounds
with and without the singular-triplet step (`golub_kahan.refine_triplets`; with:
``accuracy="certified"``; without: "high" with `accurate.springs.HIGH_WORK` = 0), their cost, and the truth (mpmath.eigsy of B~^T B~ at 34 digits from the
inputs) up to 300 dofs. Writes results/network_bounds.json.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from _common import ROUNDS, format_ratio, interleaved, ratio, write_json  # noqa: I001  (sets BLAS threads)

import mpmath
import numpy as np
import scipy.linalg as la
import scipy.sparse as sp

from vibra import normal_modes
from vibra.solvers.accurate import springs as accurate_springs

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from solvers.test_accurate_bounds import cubic_lattice, lattice_omegas, network, solve  # noqa: E402  (the tests' oracles)
from solvers.test_solvers import mp_spring_omegas  # noqa: E402

PEER = "scipy eigvalsh (LAPACK syevr, values)"


def run(sides: list[int], rounds: int) -> dict:
    rows = []
    for side in sides:
        B, springs, masses, bonds = cubic_lattice(side, 0.3)
        K = (B.T @ sp.diags(springs) @ B).toarray()
        Kt = K / np.sqrt(np.outer(masses, masses))
        factor = (B, springs)
        cases = {
            PEER: lambda: la.eigvalsh(Kt, check_finite=False),
            "vibra fast, values": lambda: normal_modes(K, masses, vectors=False),  # no spring factor: dense
            "vibra high, values": lambda: normal_modes(K, masses, spring_factor=factor, vectors=False),
            "vibra high, vectors": lambda: normal_modes(K, masses, spring_factor=factor, vectors=True),
        }
        print(f"cubic lattice, side {side} ({K.shape[0]} dofs)", flush=True)
        timings = interleaved(cases, rounds)
        high = timings["vibra high, values"].result
        exact = lattice_omegas(side, bonds)
        truth = np.array([float(value) for value in exact])[3:]  # three translations
        errors = np.array([float(abs(mpmath.mpf(float(w)) - value)) for w, value in zip(high.omega, exact)])[3:]
        bound = high.omega_error[3:]
        row = {"side": side, "n_dof": int(K.shape[0]), "n_springs": int(B.shape[0]), "solver": high.solver,
               "high_values_vs_fast": ratio(timings["vibra high, values"], timings["vibra fast, values"]),
               "high_values_vs_peer": ratio(timings["vibra high, values"], timings[PEER]),
               "high_vectors_vs_high_values": ratio(timings["vibra high, vectors"], timings["vibra high, values"]),
               "times_s": {k: t.summary() for k, t in timings.items()},
               "bound_max": float(np.max(bound / truth)), "bound_median": float(np.median(bound / truth)),
               "true_error_max": float(np.max(errors / truth)), "covered": bool(np.all(bound >= errors)),
               "within_1000x_or_1e-13": bool(np.all(bound <= np.maximum(1000 * errors, 1e-13 * truth))),
               "worst_bound_over_criterion": float(np.max(bound / np.maximum(1000 * errors, 1e-13 * truth)))}
        print(f"  high/fast {format_ratio(row['high_values_vs_fast'])}, high/eigvalsh "
              f"{format_ratio(row['high_values_vs_peer'])}, vectors/values "
              f"{format_ratio(row['high_vectors_vs_high_values'])}; bound max {row['bound_max']:.2e} "
              f"median {row['bound_median']:.2e}, true error max {row['true_error_max']:.2e}, covered "
              f"{row['covered']}, tight {row['within_1000x_or_1e-13']}", flush=True)
        rows.append(row)
    return {"rows": rows}


def ill_conditioned(sites: list[int], rounds: int, truth_up_to: int) -> list[dict]:
    rows = []
    for n_sites in sites:
        B, springs, masses = network(np.random.default_rng(1), n_sites, 6.0, 3.0)
        work = accurate_springs.HIGH_WORK

        def without() -> object:
            accurate_springs.HIGH_WORK = 0.0
            try:
                return solve(B, springs, masses, vectors=False)
            finally:
                accurate_springs.HIGH_WORK = work

        cases = {
            "vibra fast, values": lambda: normal_modes(B.T @ (springs[:, None] * B), masses, vectors=False),
            "vibra high, values, no triplets": without,
            "vibra high, values": lambda: solve(B, springs, masses, vectors=False, accuracy="certified"),
        }
        print(f"ill-conditioned network, {n_sites} sites ({3 * n_sites} dofs)", flush=True)
        timings = interleaved(cases, rounds)
        row: dict = {"n_sites": n_sites, "n_dof": 3 * n_sites, "n_springs": int(B.shape[0]),
                     "high_vs_fast": ratio(timings["vibra high, values"], timings["vibra fast, values"]),
                     "high_vs_no_triplets": ratio(timings["vibra high, values"], timings["vibra high, values, no triplets"]),
                     "times_s": {k: t.summary() for k, t in timings.items()}}
        truth = mp_spring_omegas(B, springs, masses, digits=34, exact=True) if 3 * n_sites <= truth_up_to else None
        for key, label in (("before", "vibra high, values, no triplets"), ("after", "vibra high, values")):
            modes = timings[label].result
            omega, bound = modes.omega[6:], modes.omega_error[6:]
            entry = {"solver": modes.solver, "refinement": modes.refinement,
                     "bound_max": float(np.max(bound / omega)), "bound_median": float(np.median(bound / omega)),
                     "over_1e-13": int(np.sum(bound > 1e-13 * omega))}
            if truth is not None:  # errors in mpmath (a float64 truth would round by ~1e-16 itself)
                exact = np.array([float(w) for w in truth[6:]])
                errors = np.array([float(abs(mpmath.mpf(float(w)) - value)) for w, value in zip(omega, truth[6:])])
                entry.update(true_error_max=float(np.max(errors / exact)), covered=bool(np.all(bound >= errors)),
                             within_1000x_or_1e_13=bool(np.all(bound <= np.maximum(1000 * errors, 1e-13 * exact))))
            row[key] = entry
            print(f"  {key}: bound max {entry['bound_max']:.2e}, over 1e-13: {entry['over_1e-13']}"
                  + (f", true error max {entry['true_error_max']:.2e}, covered {entry['covered']}, tight "
                     f"{entry['within_1000x_or_1e_13']}" if truth is not None else ""), flush=True)
        print(f"  high/fast {format_ratio(row['high_vs_fast'])}, with/without triplets "
              f"{format_ratio(row['high_vs_no_triplets'])}", flush=True)
        rows.append(row)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one small lattice, one round (smoke run)")
    args = parser.parse_args()
    rounds = 1 if args.quick else ROUNDS
    payload = run([6] if args.quick else [7, 8, 10, 12], rounds)
    payload["ill_conditioned"] = ill_conditioned([30] if args.quick else [60, 100, 300], rounds,
                                                 truth_up_to=90 if args.quick else 300)
    payload["peers"] = {PEER: "LAPACK values of the dense mass-weighted K~ via scipy (no vectors)"}
    write_json("network_bounds", payload, rounds)


if __name__ == "__main__":
    main()
