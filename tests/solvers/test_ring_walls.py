"""``accurate-ring`` for rings with springs to a wall (a ring of pendulums, a Klein-Gordon lattice).

Before, a ring with any spring to a wall left the ring path above 6,000 sites for the band
solver (absolute accuracy: its lowest modes off relatively by ||K~|| eps / omega^2) and its
lowest modes for shift-invert. Now its cut chain (walls kept) has a relatively accurate
bidiagonal Cholesky factor (`counting.cut_chain`), and the spring form's counts and pivots
carry each site's wall (`count_kernels`), so every frequency is certified as a free ring's is.

Truth from outside the code under test: the closed form of the uniform ring on a wall,
omega_j^2 = (g + 4 k sin^2(pi j / n)) / m in 30-digit mpmath; eigenvalues of K~ in
80-digit mpmath (`mpmath.eigsy`, K~ formed in mpmath from the inputs); Sylvester inertia
counts of K - x M in mpmath (`tests/solvers/test_ring_bounds.ring_count` with the walls, checked against a
dense solve here) for long rings.
"""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pytest
import scipy.linalg as la
import scipy.sparse as sp
from helpers.rings import certified_by_eigsy, ring_count, walled_ring
from helpers.rings import kernel_arrays as _kernel_arrays
from helpers.rings import walled_covered as covered

from vibra import normal_modes
from vibra._core.lapack import bidiagonal_singular_values
from vibra.solvers.accurate.dd import UNIT
from vibra.solvers.accurate.ring import counts as ring_counts
from vibra.solvers.accurate import count_kernels, counting
from vibra.solvers.accurate.ring import values as ring_values

EPS = float(np.finfo(float).eps)


@pytest.mark.parametrize("n", [3, 4, 7, 12])
def test_the_walled_count_matches_a_dense_solve(n: int) -> None:
    B, w, mass, springs, ground = walled_ring(n, 1.0, n, walls=max(1, n // 3))
    values = la.eigh((B.T @ sp.diags(w) @ B).toarray(), np.diag(mass), eigvals_only=True)
    middles = np.r_[0.5 * values[0], 0.5 * (values[1:] + values[:-1]), 2 * values[-1]]
    assert [ring_count(mass, springs, mp.mpf(float(x)), 40, ground) for x in middles] == list(range(n + 1))


def test_the_cut_chains_factor_is_relatively_accurate() -> None:
    """`counting.cut_chain` with walls: the squared singular values of its bidiagonal factor
    against 80-digit eigenvalues of the cut chain's K~ (30 chains of 2-59 sites, masses,
    springs and walls over up to 1e12, B's entries not +-1, walls at some sites). Bound:
    8 n eps relatively, from dqds's own few ulps per entry and the recurrence's rounding
    (each step a sum, product or quotient of nonnegative numbers: a few ulps, accumulating at
    most linearly along the chain); observed up to 0.8 n eps. Forming K~ and factoring it
    would lose the lowest eigenvalues to ||K~|| eps (here up to 1e12 times them)."""
    rng = np.random.default_rng(0)
    for _ in range(30):
        n, spread = int(rng.integers(2, 60)), float(rng.choice([0.0, 6.0, 12.0]))
        m, w = 10.0 ** rng.uniform(-spread / 2, spread / 2, n), 10.0 ** rng.uniform(-spread / 2, spread / 2, n)
        c_in, c_out = -rng.uniform(0.2, 1, n), rng.uniform(0.2, 1, n)
        wall = np.zeros(n)
        k = int(rng.integers(1, n + 1))
        wall[rng.choice(n, k, replace=False)] = 10.0 ** rng.uniform(-spread / 2, spread / 2, k)
        d, e = counting.cut_chain(m, w, c_in, c_out, wall)
        got = np.sort(bidiagonal_singular_values(d, e) ** 2)
        with mp.workdps(80):
            K = mp.matrix(n, n)
            for i in range(n):
                K[i, i] += mp.mpf(wall[i])
            for i in range(n - 1):
                ci, co, wi = mp.mpf(c_in[i]), mp.mpf(c_out[i]), mp.mpf(w[i])
                K[i, i] += wi * ci * ci
                K[i + 1, i + 1] += wi * co * co
                K[i, i + 1] += wi * ci * co
                K[i + 1, i] += wi * ci * co
            for i in range(n):
                for j in range(n):
                    K[i, j] /= mp.sqrt(mp.mpf(m[i]) * mp.mpf(m[j]))
            exact = sorted(mp.eigsy(K, eigvals_only=True))
            worst = max(float(abs(mp.mpf(g) - x) / x) for g, x in zip(got, exact))
        assert worst <= 8 * n * EPS, (n, spread, worst)


@pytest.mark.parametrize("n", [3, 5, 40, 300])
def test_compiled_counts_with_walls_agree_with_the_numpy_spring_form_and_a_dense_solve(n: int) -> None:
    """`count_kernels.spring_counts` with walls against `ring_counts.count_below_springs` (numpy, walls
    eliminated into each site's diagonal the same way) and a dense eigh: at points across
    1e-20..1e20 and beside every eigenvalue the counts agree wherever both are certain, and
    match the dense solve where it resolves the point."""
    rng = np.random.default_rng(n)
    for spread, walls in ((0.0, None), (3.0, 1), (12.0, max(1, n // 4))):
        B, w, mass, _, _ = walled_ring(n, spread, n + int(spread), walls)
        pencil = ring_counts.ring_pencil(B, w, mass)
        assert pencil is not None and pencil.walls
        m, compliance, off, squares, closing = _kernel_arrays(pencil)
        wall = ring_values.spring_walls(pencil)
        values = la.eigh((B.T @ sp.diags(w) @ B).toarray(), np.diag(mass), eigvals_only=True)
        beside = np.abs(values) * (1 + np.array([[-1e-6], [1e-6]]))
        x = np.r_[10.0 ** rng.uniform(-20, 20, 200), beside.ravel()]
        compiled, sure, _ = count_kernels.spring_counts(x, m, compliance, off, squares, closing, 4 * UNIT, wall)
        reference, reference_sure, _ = ring_counts.count_below_springs(pencil, x)
        both = sure & reference_sure
        assert np.array_equal(compiled[both], reference[both])
        assert sure.mean() >= reference_sure.mean() - 0.02
        if n <= 40 and spread == 0.0:
            dense = np.searchsorted(values, x)
            assert np.array_equal(compiled[sure], dense[sure])


def test_zero_walls_change_no_bit_of_a_free_rings_kernels() -> None:
    """Walls of zero given explicitly (the walled loops) give a free ring's counts, last pivots
    and roots bit for bit (subtracting a zero changes no double-double, nor x m in float64)."""
    rng = np.random.default_rng(4)
    B, w, mass, _, _ = walled_ring(501, 6.0, 3, walls=1)
    free = ring_counts.ring_pencil(B[:501], w[:501], mass)
    m, compliance, off, squares, closing = _kernel_arrays(free)
    x = np.r_[10.0 ** rng.uniform(-12, 6, 61), 0.0, -1.0, np.inf, np.nan]
    zero = (np.zeros(501), np.zeros(501))
    for a, b in zip(count_kernels.spring_counts(x, m, compliance, off, squares, closing, 4 * UNIT),
                    count_kernels.spring_counts(x, m, compliance, off, squares, closing, 4 * UNIT, zero)):
        assert np.array_equal(a, b, equal_nan=True)
    _, w_path, c_in, c_out = ring_values.spring_arrays(free)
    d, e = counting.cut_chain(m, w_path, c_in, c_out, None)
    poles = np.sort(bidiagonal_singular_values(d, e)) ** 2
    low, high = poles[1:-1], poles[2:]
    for a, b in zip(count_kernels.pivot_roots(low, high, low, high, m, compliance[0], off, closing),
                    count_kernels.pivot_roots(low, high, low, high, m, compliance[0], off, closing, zero[0])):
        assert np.array_equal(a, b)


def test_small_walled_rings_are_certified_against_80_digit_eigenvalues() -> None:
    """60 small rings (3-13 sites; masses, springs and walls over up to 1e12; B's entries not
    always +-1; 1..n walls, sometimes two at one site), all values and the lowest 1 and 2 by
    `ring_values.ring_values`: every value certified, covered by its bound against mpmath.eigsy
    of K~ at 80 digits, and the bound within 1e-13 relative in omega (2e-13 in omega^2)."""
    rng = np.random.default_rng(5)
    for _ in range(60):
        n, spread = int(rng.integers(3, 14)), float(rng.choice([0.3, 6.0, 12.0]))
        springs, mass = 10.0 ** rng.uniform(-spread / 2, spread / 2, n), 10.0 ** rng.uniform(-spread / 2, spread / 2, n)
        B = np.zeros((n, n))
        B[np.arange(n), np.arange(n)] = -rng.uniform(0.2, 1.0, n) if rng.random() < 0.5 else -1.0
        B[np.arange(n), (np.arange(n) + 1) % n] = rng.uniform(0.2, 1.0, n) if rng.random() < 0.5 else 1.0
        k = int(rng.integers(1, n + 1))
        W = np.zeros((k, n))
        W[np.arange(k), rng.choice(n, k, replace=rng.random() < 0.3)] = rng.uniform(0.2, 1.0, k)
        B, springs = np.vstack([B, W]), np.r_[springs, 10.0 ** rng.uniform(-spread / 2, spread / 2, k)]
        pencil = ring_counts.ring_pencil(sp.csr_matrix(B), springs, mass)
        assert pencil is not None and pencil.walls
        certified_by_eigsy(B, springs, mass, lambda count: ring_values.ring_values(pencil, count))


@pytest.mark.slow
def test_a_uniform_ring_of_pendulums_of_8000_sites_meets_the_criterion() -> None:
    """8,000 sites, each on a wall spring g = 0.01 (the Klein-Gordon lattice): omega_j^2 =
    g + 4 sin^2(pi j / n), in exactly degenerate pairs. All values, and the lowest 10 with
    vectors, through `normal_modes`: solver accurate-ring (before: the band solver, absolute
    accuracy), every bound covering the closed form, within 1e-13 relative at accuracy="certified"
    (the ring's own values path) and within 1e-10 at "high" (the band solver's values bracketed
    by counts); the vectors' residuals ||K v - omega^2 M v|| / omega^2 below 1e-10."""
    n = 8000
    B, w, mass, _, _ = walled_ring(n, 0.0, 1)
    w[n:] = 0.01
    K = (B.T @ sp.diags(w) @ B).tocsr()
    with mp.workdps(30):
        truth = np.sort(np.array([float(mp.sqrt(mp.mpf("0.01") + 4 * mp.sin(mp.pi * j / n) ** 2)) for j in range(n)]))
    modes = normal_modes(K, mass, spring_factor=(B, w), vectors=False, accuracy="certified")
    assert modes.solver == "accurate-ring"
    assert f"{n} of {n} bounds certified" in modes.refinement
    true_error = np.maximum(np.abs(modes.omega - truth) - 1e-16 * truth, 0.0)  # (truth to 1 ulp)
    assert np.all(true_error <= modes.omega_error)
    assert np.all(modes.omega_error <= 1e-13 * modes.omega)
    high = normal_modes(K, mass, spring_factor=(B, w), vectors=False)
    assert high.solver == "accurate-ring" and "from the band solver" in high.refinement
    assert np.all(np.maximum(np.abs(high.omega - truth) - 1e-16 * truth, 0.0) <= high.omega_error)
    assert np.all(high.omega_error <= 0.5e-10 * high.omega)  # (omega^2 within 1e-10)
    lowest = normal_modes(K, mass, spring_factor=(B, w), n_modes=10)
    assert lowest.solver == "accurate-ring"
    assert np.all(np.abs(lowest.omega - truth[:10]) <= lowest.omega_error)
    assert np.all(lowest.omega_error <= 1e-13 * lowest.omega)
    V = lowest.vectors
    residual = np.linalg.norm(K @ V - (V * mass[:, None]) * lowest.omega**2, axis=0)
    assert np.all(residual <= 1e-10 * lowest.omega**2 * np.linalg.norm(V * mass[:, None], axis=0))


@pytest.mark.parametrize(("spread", "walls", "seed"), [(3.0, None, 1), (6.0, 5, 2), (12.0, 1, 3), (12.0, None, 4),
                                                     (24.0, 3, 5)])
def test_disordered_walled_rings_are_certified_against_mpmath_counts(spread: float, walls: int | None,
                                                                     seed: int) -> None:
    """2,000 sites, masses, springs and walls log-uniform over 10^spread (up to 1e-12..1e12:
    ||K~|| / omega_1^2 beyond 1e48), walls at every site, at 5, 3 or 1: every bound within 1e-13 relative; the
    lowest 3, the loosest 3 and 4 random modes covered by mpmath counts (40 + 2 spread
    digits), and within 1e-13 of the truth by the same counts. The lowest 5 alone agree."""
    n = 2000
    B, w, mass, springs, ground = walled_ring(n, spread, seed, walls)
    K = (B.T @ sp.diags(w) @ B).tocsr()
    modes = normal_modes(K, mass, spring_factor=(B, w), vectors=False)
    assert modes.solver == "accurate-ring"
    relative = modes.omega_error / modes.omega
    assert np.all(relative <= 1e-13)
    rng = np.random.default_rng(seed)
    picked = np.unique(np.r_[0, 1, 2, np.argsort(-relative)[:3], rng.choice(n, 4, replace=False)])
    digits = 40 + int(2 * spread)
    for j in picked.tolist():
        omega, error = float(modes.omega[j]), float(modes.omega_error[j])
        assert covered(mass, springs, ground, omega, error, j, digits), j
        assert covered(mass, springs, ground, omega, 1e-13 * omega, j, digits), j
    lowest = normal_modes(K, mass, spring_factor=(B, w), n_modes=5, vectors=False)
    assert lowest.solver == "accurate-ring"
    assert np.all(np.abs(lowest.omega - modes.omega[:5]) <= lowest.omega_error + modes.omega_error[:5])


@pytest.mark.slow
def test_the_lowest_modes_of_a_long_ring_on_few_walls_spread_over_1e12() -> None:
    """20,000 sites, masses and springs over 1e12, walls at 3 sites (||K~|| / omega_1^2 ~ 1e25):
    the lowest 10 by bisection on the cut chain's factor and the ring's counts (O(n k)),
    each covered by 64-digit mpmath counts for the lowest 3 and within 1e-13 relative."""
    n = 20000
    B, w, mass, springs, ground = walled_ring(n, 12.0, 6, walls=3)
    K = (B.T @ sp.diags(w) @ B).tocsr()
    lowest = normal_modes(K, mass, spring_factor=(B, w), n_modes=10, vectors=False)
    assert lowest.solver == "accurate-ring"
    assert np.all(lowest.omega_error <= 1e-13 * lowest.omega)
    for j in range(3):
        assert covered(mass, springs, ground, float(lowest.omega[j]), float(lowest.omega_error[j]), j, 64), j


def test_a_ring_of_pendulums_built_from_springs_takes_the_ring_path() -> None:
    """What a user writes: `System.from_springs` with the ring's bonds and every site anchored
    (300 sites, k = 1, g = 0.04, m = 2): all frequencies and the lowest 6 by ``accurate-ring``
    (the lowest 6 with vectors: the checked dense solve, under DENSE_LIMIT), against the closed
    form omega_j^2 = (g + 4 k sin^2(pi j / n)) / m,
    every bound covering it and within 1e-13 relative."""
    from vibra import System

    n = 300
    bonds = np.c_[np.arange(n), (np.arange(n) + 1) % n]
    ring = System.from_springs(np.arange(n) * 1.0, np.full(n, 2.0), bonds, np.ones(n), anchors=np.arange(n),
                               anchor_stiffness=np.full(n, 0.04), units="dimensionless")
    with mp.workdps(30):
        truth = np.sort(np.array([float(mp.sqrt((mp.mpf("0.04") + 4 * mp.sin(mp.pi * j / n) ** 2) / 2))
                                  for j in range(n)]))
    for modes, path in ((ring.modes(vectors=False), "accurate-ring"), (ring.modes(n_modes=6, vectors=False), "accurate-ring"),
                        (ring.modes(n_modes=6), "accurate-checked")):  # (with vectors under 1,500 sites: dense)
        k = modes.n_modes
        assert modes.solver == path
        assert np.all(np.maximum(np.abs(modes.omega - truth[:k]) - 1e-16 * truth[:k], 0.0) <= modes.omega_error)
        assert np.all(modes.omega_error <= 1e-13 * modes.omega)
