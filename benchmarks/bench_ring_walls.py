"""Rings with springs to a wall, "high": ``accurate-ring`` against the paths it replaces.

    python benchmarks/bench_ring_walls.py [--quick] [--chains]

Issue 15, item 6: a ring with any spring to a wall (a ring of pendulums, a Klein-Gordon
lattice) left the ring path: over 6,000 sites "high" took its band (absolute accuracy: bounds
up to 10% relative on the lowest modes with a spread of 1e6, negative frequencies with one of
1e12), and its lowest modes shift-invert Lanczos (minutes, or no convergence, on a wide
spread). Now the cut chain keeps its walls in a relatively accurate bidiagonal Cholesky factor
(`counting.cut_chain`) and the spring form's counts carry them (`count_kernels`).

Per ring, by the protocol of STYLE.md (one process, warm-up, interleaved rounds, BLAS threads 1;
numba's threads: the machine's cores, 2 here):

- all frequencies, values only: `normal_modes(..., vectors=False)` in "high" (``accurate-ring``),
  the path it replaces (`common.RING_VALUES_FROM` out of reach: the band solver, and the triplet
  step), and "fast" (the band solver, itself scipy's banded eigensolver: the strongest peer);
- the lowest 10, values only: "high" against the path it replaces (shift-invert Lanczos, then
  spring-space Rayleigh-Ritz), run once in a subprocess with a time limit (`LIMIT_S`);
- bounds: largest and median omega_error / omega; the truth: the closed form
  omega_j^2 = g + 4 sin^2(pi j / n) for the uniform ring on walls g (30-digit mpmath), and
  mpmath Sturm counts (`tests/solvers/test_ring_walls.covered`, 40 + 2 spread digits) on 10 sampled
  modes (the lowest 3, the loosest 3, 4 random) for disordered rings up to 32,000 sites.

Writes results/ring_walls.json.

``--chains``: chains of pendulums (a spring to a wall at every site, free ends; uniform with
g = 0.01, truth the closed form omega_j^2 = g + 4 sin^2(pi j / 2n), or disordered), values
only: ``accurate-walled`` against the path it replaces and "fast". Writes results/chain_walls.json.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

from _common import ROUNDS, format_ratio, interleaved, ratio, write_json  # noqa: I001  (sets BLAS threads)

import mpmath
import numpy as np
import scipy.sparse as sp

from vibra import normal_modes
from vibra.solvers import common

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from solvers.test_ring_walls import covered, walled_ring  # noqa: E402  (the tests' oracles)

#: The previous path of a lowest-modes request runs once, in a subprocess stopped after this.
LIMIT_S = 200


def ring(n: int, spread: float, walls: int | None) -> tuple:
    """(K, B, w, mass, springs, ground): the uniform ring on walls of 0.01 (spread 0) or a
    disordered one (seed 7)."""
    B, w, mass, springs, ground = walled_ring(n, spread, 7, walls)
    if spread == 0.0:
        w[n:], ground[:] = 0.01, 0.01
    return (B.T @ sp.diags(w) @ B).tocsr(), B, w, mass, springs, ground


def previous(K: object, mass: np.ndarray, B: object, w: np.ndarray, **request: object) -> object:
    """The path this replaces: `common.RING_VALUES_FROM` out of reach for one call."""
    switch = common.RING_VALUES_FROM
    common.RING_VALUES_FROM = 10**12  # the ring's own path off
    try:
        return normal_modes(K, mass, spring_factor=(B, w), max_seconds=3600, **request)
    finally:
        common.RING_VALUES_FROM = switch


def figures(modes: object, n: int, spread: float, system: tuple, sample: bool) -> dict:
    omega, error = modes.omega, modes.omega_error  # type: ignore[attr-defined]
    relative = np.abs(error / omega)
    entry = {"solver": modes.solver, "omega_0": float(omega[0]), "bound_max": float(relative.max()),  # type: ignore[attr-defined]
             "bound_median": float(np.median(relative)), "over_1e-13": int(np.sum(relative > 1e-13))}
    if spread == 0.0:
        with mpmath.workdps(30):
            truth = np.sort(np.array([float(mpmath.sqrt(mpmath.mpf("0.01") + 4 * mpmath.sin(mpmath.pi * j / n) ** 2))
                                      for j in range(n)]))[: omega.shape[0]]
        true_error = np.abs(omega - truth)
        entry.update(true_error_max=float(np.max(true_error / truth)),
                     covered=bool(np.all(np.maximum(true_error - 1e-16 * truth, 0.0) <= error)))
    elif sample:
        _, _, _, mass, springs, ground = system
        k = omega.shape[0]
        picked = np.unique(np.r_[np.arange(min(3, k)), np.argsort(-relative)[:3],
                                 np.random.default_rng(1).choice(k, min(4, k), replace=False)])
        digits = 40 + int(2 * spread)
        held = sum(covered(mass, springs, ground, float(omega[j]), float(error[j]), j, digits) for j in picked)
        entry["sampled_covered"] = f"{held} of {picked.shape[0]}"
    return entry


def run(cases: list[tuple[int, float, int | None]], rounds: int) -> list[dict]:
    rows = []
    for n, spread, walls in cases:
        system = ring(n, spread, walls)
        K, B, w, mass = system[:4]
        methods = {
            "vibra fast": lambda: normal_modes(K, mass, vectors=False),  # no spring factor: the band solver
            "vibra high (previous path)": lambda: previous(K, mass, B, w, vectors=False),
            "vibra high": lambda: normal_modes(K, mass, spring_factor=(B, w), vectors=False, max_seconds=3600),
        }
        print(f"ring of {n} sites, spread 10^{spread:g}, walls {'every site' if walls is None else walls}", flush=True)
        timings = interleaved(methods, rounds)
        row = {"n": n, "spread": spread, "walls": "all" if walls is None else walls,
               "times_s": {k: t.summary() for k, t in timings.items()},
               "high_vs_fast": ratio(timings["vibra high"], timings["vibra fast"]),
               "high_vs_previous": ratio(timings["vibra high"], timings["vibra high (previous path)"])}
        for key, label in (("now", "vibra high"), ("before", "vibra high (previous path)"), ("fast", "vibra fast")):
            row[key] = figures(timings[label].result, n, spread, system, sample=key == "now" and n <= 32000)
            print(f"  {key}: {row[key]}", flush=True)
        print(f"  high/fast {format_ratio(row['high_vs_fast'])}, high/previous {format_ratio(row['high_vs_previous'])}",
              flush=True)
        rows.append(row)
    return rows


def run_lowest(cases: list[tuple[int, float, int | None]], rounds: int, k: int = 10) -> list[dict]:
    rows = []
    for n, spread, walls in cases:
        system = ring(n, spread, walls)
        K, B, w, mass = system[:4]
        print(f"ring of {n} sites, spread 10^{spread:g}, walls {'every site' if walls is None else walls}, lowest {k}",
              flush=True)
        start = time.perf_counter()
        try:
            done = subprocess.run([sys.executable, __file__, "--previous-once", str(n), str(spread), str(walls), str(k)],
                                  capture_output=True, text=True, timeout=LIMIT_S)
            once: object = done.stdout.strip().splitlines()[-1] if done.returncode == 0 else done.stderr[-300:]
        except subprocess.TimeoutExpired:
            once = f"not finished after {LIMIT_S} s"
        print(f"  previous path, once: {once} ({time.perf_counter() - start:.1f} s with the subprocess' start)", flush=True)
        timings = interleaved({"vibra high": lambda: normal_modes(K, mass, spring_factor=(B, w), n_modes=k,
                                                                   vectors=False, max_seconds=3600)}, rounds)
        row = {"n": n, "spread": spread, "walls": "all" if walls is None else walls, "k": k,
               "times_s": {key: t.summary() for key, t in timings.items()}, "previous_once": once,
               "now": figures(timings["vibra high"].result, n, spread, system, sample=n <= 32000)}
        print(f"  now: {row['now']}", flush=True)
        rows.append(row)
    return rows


def previous_once(n: int, spread: float, walls: int | None, k: int) -> None:
    K, B, w, mass = ring(n, spread, walls)[:4]
    start = time.perf_counter()
    try:
        modes = previous(K, mass, B, w, n_modes=k, vectors=False)
        relative = modes.omega_error / np.abs(modes.omega)  # type: ignore[attr-defined]
        print(f"{modes.solver}, {time.perf_counter() - start:.1f} s, bound/omega up to {relative.max():.2g}")  # type: ignore[attr-defined]
    except Exception as exc:  # ARPACK's no-convergence, above all
        print(f"{type(exc).__name__} after {time.perf_counter() - start:.1f} s")


def run_chains(cases: list[tuple[int, float]], rounds: int) -> list[dict]:
    """Chains of pendulums (a wall spring at every site, free ends): ``accurate-walled`` against
    the path it replaces (`common.RING_VALUES_FROM` out of reach: the checked dense solve, or the Rayleigh
    path over 1,500 sites) and "fast" (the tridiagonal solver, LAPACK stemr: the strongest peer)."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from solvers.test_walled_chain import chain_on_walls

    rows = []
    for n, spread in cases:
        B, w, mass, _, _ = chain_on_walls(n, spread, 7)
        if spread == 0.0:
            w[n - 1:] = 0.01
        K = (B.T @ sp.diags(w) @ B).tocsr()

        def before() -> object:
            switch = common.RING_VALUES_FROM
            common.RING_VALUES_FROM = 10**12  # the walled chain's own path off
            try:
                return normal_modes(K, mass, spring_factor=(B, w), vectors=False, max_seconds=3600)
            finally:
                common.RING_VALUES_FROM = switch

        methods = {"vibra fast": lambda: normal_modes(K, mass, vectors=False),
                   "vibra high": lambda: normal_modes(K, mass, spring_factor=(B, w), vectors=False, max_seconds=3600)}
        if n <= 5000:
            methods["vibra high (previous path)"] = before
        print(f"chain of {n} pendulums, spread 10^{spread:g}", flush=True)
        timings = interleaved(methods, rounds)
        row: dict = {"n": n, "spread": spread, "times_s": {k: t.summary() for k, t in timings.items()},
                     "high_vs_fast": ratio(timings["vibra high"], timings["vibra fast"])}
        for key, label in (("now", "vibra high"), ("before", "vibra high (previous path)"), ("fast", "vibra fast")):
            if label in timings:
                modes = timings[label].result
                relative = np.abs(modes.omega_error / modes.omega)  # type: ignore[attr-defined]
                row[key] = {"solver": modes.solver, "bound_max": float(relative.max()),  # type: ignore[attr-defined]
                            "over_1e-13": int(np.sum(relative > 1e-13))}
                if spread == 0.0:
                    with mpmath.workdps(30):
                        truth = np.array([float(mpmath.sqrt(mpmath.mpf("0.01") + 4 * mpmath.sin(mpmath.pi * j / (2 * n)) ** 2))
                                          for j in range(n)])
                    row[key]["true_error_max"] = float(np.max(np.abs(modes.omega - truth) / truth))  # type: ignore[attr-defined]
                print(f"  {key}: {row[key]}", flush=True)
        rows.append(row)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one small ring, one round (smoke run)")
    parser.add_argument("--previous-once", nargs=4, help=argparse.SUPPRESS)
    parser.add_argument("--chains", action="store_true", help="chains of pendulums (accurate-walled)")
    args = parser.parse_args()
    if args.chains:
        rounds = 1 if args.quick else ROUNDS
        cases = [(2000, 6.0)] if args.quick else [(2000, 0.0), (5000, 0.0), (5000, 6.0), (50000, 24.0)]
        path = write_json("chain_walls", {"rows": run_chains(cases, rounds), "peer": "vibra fast (LAPACK stemr)"}, rounds)
        print(f"wrote {path}")
        return
    if args.previous_once:
        n, spread, walls, k = args.previous_once
        previous_once(int(n), float(spread), None if walls == "None" else int(walls), int(k))
        return
    rounds = 1 if args.quick else ROUNDS
    cases = [(2000, 6.0, None)] if args.quick else [(8000, 0.0, None), (8000, 6.0, None), (8000, 12.0, 3),
                                                   (32000, 6.0, None)]
    lowest = [(20000, 12.0, 3)] if args.quick else [(20000, 12.0, 3), (200000, 12.0, 3), (1000000, 6.0, None)]
    path = write_json("ring_walls", {"rows": run(cases, rounds), "lowest": run_lowest(lowest, rounds),
                                     "peer": "vibra fast (the band solver, scipy eigvals_banded)"}, rounds)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
