"""All frequencies of a ring, values only, "high": ``accurate-ring`` against the paths it replaces.

    python benchmarks/bench_ring_values.py [--quick] [--lowest]

Issue 15, item 6: a ring over 6,000 sites took its band in "high" (absolute accuracy: the
lowest frequencies of a uniform 8,000-site ring off by 4.5e-9 relative, ~8,000 bounds over 1e-13
and over 1000 times their true error), and rings of 1,500 to 6,000 sites the dense checked
solve (O(n^3), 8 s at 1,600 sites with a spread of 1e12). ``accurate-ring`` (`ring.values`):
roots of the spring form's last pivot between the cut chain's eigenvalues, each certified by
two double-double Sturm counts; O(n^2).

Per ring, by the protocol of STYLE.md (one process, warm-up, interleaved rounds, BLAS threads 1;
numba's threads: the machine's cores, 2 here):

- time of `modes(vectors=False)` in "high" (``accurate-ring``), of the path it replaces (the
  same call with `common.RING_VALUES_FROM` out of reach: the band solver and the triplet
  step above 6,000 sites, the checked dense solve below), of "fast" (the band solver), and of
  the strongest peer for the eigenvalues of a banded symmetric matrix: scipy
  `eigvals_banded` (LAPACK sbevd) of the reordered K~ (half-width 2), formed outside the timing;
- the bounds: largest and median of omega_error / omega; the true error where a truth exists:
  the closed form 2 |sin(pi j / n)| (uniform rings, 30-digit mpmath), and for disordered rings
  40 + 2 spread digit mpmath Sturm counts (`tests/solvers/test_ring_bounds.ring_count`) on a sample of
  24 modes (the lowest, the loosest, random), which must hold each reported interval.

Writes results/ring_values.json.

``--lowest``: `modes(n_modes=10, vectors=False)` of long rings, where ``accurate-ring`` finds the cut chain's lowest eigenvalues by bisection (O(n k)) instead of
dqds of all, against the path it replaces (shift-invert Lanczos, scipy eigsh with the shift
chosen from ||K~||, then spring-space Rayleigh-Ritz), itself the strongest peer here (the
lowest eigenvalues of a sparse pencil). That path takes minutes on disordered rings: it is
timed once, before the rounds (not at all on disordered rings over 50,000 sites), and joins
the interleaved rounds only when that took under 30 s. Truth: the closed form (uniform),
64-digit mpmath counts on the modes (disordered, up to 50,000 sites; above, bounds only).
Writes results/ring_lowest.json.

``--small``: rings of 200 and 1,000 sites, which took the checked dense solve until
``accurate-ring`` started at 100 sites (`common.RING_VALUES_FROM`). Writes results/ring_small.json.

``--kernels``: the compiled loops themselves, `LANES` points at a time (SIMD lanes) against
one point at a time (`tests/scalar_kernels.py`, the previous kernels, bit-identical results),
at 20,000 sites: the ring's spring counts and pivot roots, a chain's path counts. Numba's
threads 2 for both. Writes results/ring_kernels.json.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from _common import ROUNDS, format_ratio, interleaved, ratio, write_json  # noqa: I001  (sets BLAS threads)

import mpmath
import numpy as np
import scipy.linalg as la

from vibra.chains import linear_chain
from vibra.solvers import common
from vibra.solvers.common import ring_ordering

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from solvers.test_ring_bounds import disordered_ring, ring_count, sampled  # noqa: E402  (the tests' oracles)

PEER = "scipy eigvals_banded (LAPACK sbevd, reordered K~)"


def previous(ring: object, n_modes: int | None = None) -> object:
    """The path this replaces: `common.RING_VALUES_FROM` out of reach for one call."""
    switch = common.RING_VALUES_FROM
    common.RING_VALUES_FROM = 10**12  # the ring's own path off
    try:
        return ring.modes(n_modes=n_modes, vectors=False, max_seconds=3600)  # type: ignore[attr-defined]
    finally:
        common.RING_VALUES_FROM = switch


def figures(modes: object, truth: np.ndarray | None, mass: np.ndarray, springs: np.ndarray, spread: float,
            digits: int | None = None) -> dict:
    omega, error = modes.omega, modes.omega_error  # type: ignore[attr-defined]
    relative = error[1:] / omega[1:]
    entry = {"solver": modes.solver, "bound_max": float(relative.max()),  # type: ignore[attr-defined]
             "bound_median": float(np.median(relative)), "over_1e-13": int(np.sum(relative > 1e-13))}
    if truth is not None:
        errors = np.abs(omega[1:] - truth[1:])
        entry.update(true_error_max=float(np.max(errors / truth[1:])),
                     covered=bool(np.all(errors <= error[1:] + 1e-16 * truth[1:])),
                     over_criterion=int(np.sum((error[1:] > 1000 * errors) & (relative > 1e-13))))
    else:
        digits = digits or 40 + int(2 * spread)
        checked = [j for j in sampled(omega.shape[0], np.r_[0.0, relative], np.random.default_rng(5)) if j > 0]
        held = 0
        for j in checked:
            with mpmath.workdps(digits):
                low = mpmath.mpf(omega[j]) - mpmath.mpf(error[j])
                high = (mpmath.mpf(omega[j]) + mpmath.mpf(error[j])) ** 2
            below = 0 if low <= 0 else ring_count(mass, springs, low**2, digits)
            held += below <= j < ring_count(mass, springs, high, digits)
        entry.update(sampled=len(checked), sampled_covered=held)
    return entry


def run(cases: list[tuple[int, float]], rounds: int) -> list[dict]:
    rows = []
    for n, spread in cases:
        if spread == 0.0:
            mass, springs = np.ones(n), np.ones(n)
        else:
            mass, springs = disordered_ring(n, spread, 7)
        ring = linear_chain(n, ends="periodic", mass=mass, stiffness=springs, units="dimensionless")
        K = ring.hessian()
        order, width = ring_ordering(K)
        band = _band(K, mass, order, width)
        methods = {
            PEER: lambda: la.eigvals_banded(band, lower=True, check_finite=False),
            "vibra fast": lambda: ring.modes(vectors=False, accuracy="fast"),
            "vibra high (previous path)": lambda: previous(ring),
            "vibra high": lambda: ring.modes(vectors=False),
        }
        print(f"ring of {n} sites, spread 10^{spread:g}", flush=True)
        timings = interleaved(methods, rounds)
        truth = None
        if spread == 0.0:
            with mpmath.workdps(30):
                truth = np.sort(np.array([float(2 * abs(mpmath.sin(mpmath.pi * j / n))) for j in range(n)]))
        row = {"n": n, "spread": spread, "times_s": {k: t.summary() for k, t in timings.items()},
               "high_vs_fast": ratio(timings["vibra high"], timings["vibra fast"]),
               "high_vs_peer": ratio(timings["vibra high"], timings[PEER]),
               "high_vs_previous": ratio(timings["vibra high"], timings["vibra high (previous path)"])}
        for key, label in (("now", "vibra high"), ("before", "vibra high (previous path)"), ("fast", "vibra fast")):
            row[key] = figures(timings[label].result, truth, mass, springs, spread)
            print(f"  {key}: {row[key]}", flush=True)
        print(f"  high/fast {format_ratio(row['high_vs_fast'])}, high/peer {format_ratio(row['high_vs_peer'])}, "
              f"high/previous {format_ratio(row['high_vs_previous'])}", flush=True)
        rows.append(row)
    return rows


def run_lowest(cases: list[tuple[int, float]], rounds: int, k: int = 10) -> list[dict]:
    import time

    rows = []
    for n, spread in cases:
        mass, springs = (np.ones(n), np.ones(n)) if spread == 0.0 else disordered_ring(n, spread, 7)
        ring = linear_chain(n, ends="periodic", mass=mass, stiffness=springs, units="dimensionless")
        print(f"ring of {n} sites, spread 10^{spread:g}, lowest {k}", flush=True)
        start = time.perf_counter()
        before: object = None
        once: object = "not run (disordered, over 50,000 sites: shift-invert took minutes at 50,000)"
        try:
            if n <= 50000 or spread == 0.0:
                before = previous(ring, n_modes=k)
                once = time.perf_counter() - start
        except Exception as exc:  # ARPACK's no-convergence, above all
            once = f"{type(exc).__name__} after {time.perf_counter() - start:.1f} s"
        print(f"  previous path, once: {once}", flush=True)
        methods = {"vibra high": lambda: ring.modes(n_modes=k, vectors=False, max_seconds=3600)}
        if isinstance(once, float) and once < 30.0:
            methods["vibra high (previous path)"] = lambda: previous(ring, n_modes=k)
        timings = interleaved(methods, rounds)
        truth = None
        if spread == 0.0:
            with mpmath.workdps(30):
                truth = np.sort(np.array([float(2 * mpmath.sin(mpmath.pi * min(j, n - j) / n))
                                          for j in range(k // 2 + 1)] * 2))[1: k + 1]
        row: dict = {"n": n, "spread": spread, "k": k, "times_s": {key: t.summary() for key, t in timings.items()},
                     "previous_once_s": once}
        for key, modes in (("now", timings["vibra high"].result), ("before", before)):
            if modes is None:
                continue
            if truth is not None or n <= 50000:
                row[key] = figures(modes, truth, mass, springs, spread, digits=64)
            else:
                relative = modes.omega_error[1:] / modes.omega[1:]  # type: ignore[attr-defined]
                row[key] = {"solver": modes.solver, "bound_max": float(relative.max())}  # type: ignore[attr-defined]
            row[key]["omega_0"] = float(modes.omega[0])  # type: ignore[attr-defined]
            print(f"  {key}: {row[key]}", flush=True)
        rows.append(row)
    return rows


def run_kernels(rounds: int, n: int = 20000, points: int = 512) -> list[dict]:
    import scalar_kernels

    from vibra._core.lapack import bidiagonal_singular_values
    from vibra.solvers.accurate import count_kernels as ring_kernel
    from vibra.solvers.accurate.ring import counts as ring_counts, values as ring_values
    from vibra.solvers.accurate.dd import UNIT, div, mul

    rows = []
    for spread in (0.0, 6.0):
        mass, springs = (np.ones(n), np.ones(n)) if spread == 0.0 else disordered_ring(n, spread, 7)
        ring = linear_chain(n, ends="periodic", mass=mass, stiffness=springs, units="dimensionless")
        m, w, c_in, c_out = ring_values.spring_arrays(ring_counts.ring_pencil(*ring.spring_factor(), mass))
        compliance = div(np.ones(n), np.zeros(n), w, np.zeros(n))
        off = np.empty(2 * n - 1)
        off[0::2], off[1::2] = c_in, c_out[: n - 1]
        squares = mul(off, np.zeros_like(off), off, np.zeros_like(off))
        d = np.r_[np.abs(np.sqrt(w[:-1]) * c_in[:-1] / np.sqrt(m[:-1])), 0.0]
        e = np.abs(np.sqrt(w[:-1]) * c_out[:-1] / np.sqrt(m[1:]))
        poles = np.sort(bidiagonal_singular_values(d, e)) ** 2
        x = poles[np.linspace(1, n - 1, points).astype(int)] * (1 + 1e-13)  # beside eigenvalues, as certified
        low, high = poles[1:points + 1], poles[2:points + 2]
        site = np.zeros(2 * n - 1, dtype=bool)
        site[0::2] = True
        nodes = np.zeros(2 * n - 1)
        nodes[0::2] = m
        stiff = np.ones(2 * n - 1)  # (site nodes: unused)
        stiff[1::2] = w[:-1]
        compliance_path = div(np.ones(2 * n - 1), np.zeros(2 * n - 1), stiff, np.zeros(2 * n - 1))
        counts = (m, compliance, off, squares, float(c_out[-1]), 4 * UNIT)
        roots = (low, high, low, high, m, compliance[0], off, float(c_out[-1]))
        path = (site, nodes, compliance_path, squares)
        for name, lanes, one in (
                ("spring counts", lambda: ring_kernel.spring_counts(x, *counts), lambda: scalar_kernels.spring_counts(x, *counts)),
                ("pivot roots", lambda: ring_kernel.pivot_roots(*roots), lambda: scalar_kernels.pivot_roots(*roots)),
                ("path counts", lambda: ring_kernel.chain_counts(x, *path), lambda: scalar_kernels.chain_counts(x, *path))):
            print(f"{name}, {n} sites, spread 10^{spread:g}", flush=True)
            timings = interleaved({"lanes": lanes, "one point at a time": one}, rounds)
            same = all(np.array_equal(a, b, equal_nan=True) for a, b in zip(timings["lanes"].result,
                                                                              timings["one point at a time"].result))
            if name == "path counts":  # (count below, certain) against (negative pivots, certain)
                a, b = timings["lanes"].result, timings["one point at a time"].result
                same = np.array_equal(a[0], n - b[0]) and np.array_equal(a[1], b[1])
            work = (2 * n) * (points if name != "pivot roots" else float(timings["lanes"].result[1].sum()))
            row = {"kernel": name, "n": n, "spread": spread, "same": bool(same),
                   "times_s": {k: t.summary() for k, t in timings.items()},
                   "ns_per_node_and_point": {k: t.min / work * 1e9 for k, t in timings.items()},
                   "speedup": ratio(timings["one point at a time"], timings["lanes"])}
            print(f"  bit-identical {same}, lanes {format_ratio(row['speedup'])} faster", flush=True)
            rows.append(row)
    return rows


def _band(K: object, mass: np.ndarray, order: np.ndarray, width: int) -> np.ndarray:
    """K~ reordered, in LAPACK's lower band storage (width + 1 rows)."""
    import scipy.sparse as sp

    scale = 1.0 / np.sqrt(mass)
    Kt = sp.csr_matrix(sp.diags(scale) @ K @ sp.diags(scale))[order][:, order].tocsr()
    n = Kt.shape[0]
    band = np.zeros((width + 1, n))
    for offset in range(width + 1):
        band[offset, : n - offset] = Kt.diagonal(-offset)
    return band


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one small ring, one round (smoke run)")
    parser.add_argument("--lowest", action="store_true", help="the lowest 10 modes of rings over 20,000 sites")
    parser.add_argument("--kernels", action="store_true", help="the compiled loops: SIMD lanes against one point")
    parser.add_argument("--small", action="store_true", help="rings of 200 and 1,000 sites (the ring path from 100)")
    args = parser.parse_args()
    rounds = 1 if args.quick else ROUNDS
    if args.small:
        rows = run([(200, 0.0), (200, 6.0), (1000, 0.0), (1000, 6.0)], rounds)
        path = write_json("ring_small", {"rows": rows, "peer": PEER}, rounds)
        print(f"wrote {path}")
        return
    if args.kernels:
        path = write_json("ring_kernels", {"rows": run_kernels(rounds), "peer": "the one-point kernels"}, rounds)
        print(f"wrote {path}")
        return
    if args.lowest:
        cases = [(30000, 0.0)] if args.quick else [(50000, 0.0), (50000, 6.0), (200000, 0.0), (200000, 12.0),
                                                   (1000000, 6.0), (1000000, 0.0)]
        path = write_json("ring_lowest", {"rows": run_lowest(cases, rounds), "peer": "the previous path"}, rounds)
        print(f"wrote {path}")
        return
    cases = [(2000, 0.0)] if args.quick else [(2000, 0.0), (2000, 12.0), (8000, 0.0), (8000, 6.0), (16000, 6.0)]
    rows = run(cases, rounds)
    path = write_json("ring_values", {"rows": rows, "peer": PEER}, rounds)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
