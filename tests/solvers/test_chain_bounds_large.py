"""Chain error bounds that guide at any size (issue 15, item 6): never below the true error, and
within 1000 times it (or within 1e-13 relative where the true error is smaller).

Truth: the closed forms of the uniform chain, omega_j = 2 sqrt(k/m) sin(j pi / 2n) (free ends) and
2 sqrt(k/m) sin(j pi / 2(n + 1)) (fixed ends), evaluated in 40-digit mpmath; for disordered
chains, Sturm counts of the mass-weighted tridiagonal in 40-digit mpmath built from the springs and
masses themselves: [lambda - b, lambda + b] must hold the j-th eigenvalue (b covers the true error)
and, where b / 1000 exceeds 1e-13 relative, [lambda - b / 1000, lambda + b / 1000] must not (b is
within 1000 times the true error). Nothing vibra computed enters the truth.
"""

from __future__ import annotations

from fractions import Fraction

import mpmath
import numpy as np
import pytest
from helpers.chains import (
    all_modes,
    assert_guides_by_counts,
    chain,
    disordered,
    mass_weighted,
    sturm_count,
    weighted_factor,
)
from hypothesis import given, settings
from hypothesis import strategies as st

from vibra.modes import normal_modes
from vibra.solvers.accurate.chain import bidiagonal
from vibra.solvers.accurate.chain.bidiagonal import (
    CERTIFY_ALL,
    segment_scalings,
)
from vibra.solvers.accurate.chain.lowest import (
    chain_segments,
    lowest_chain_modes,
    lowest_chain_path,
)
from vibra.solvers.accurate.rounding import (
    entry_deviation,
    scaling_logs,
    two_product,
    two_sum,
    walk_bound,
)
from vibra.solvers.common import omega_and_error

EPS = float(np.finfo(float).eps)


def lowest(mass, springs, walls, k, vectors):
    """The lowest k by the accurate-bisection path, the exact spring factor given."""
    B, w, K = chain(mass, springs, walls)
    return lowest_chain_modes(mass_weighted(K, mass), K, mass, (B, w), n_modes=k, vectors=vectors)


def closed_form(n: int, ends: str, count: int, kappa: float = 1.0, m: float = 1.0) -> list:
    """omega_j^2 of the uniform chain, 40 digits (j = 0.. for free ends, 1.. for fixed)."""
    with mpmath.workdps(40):
        scale = 4 * mpmath.mpf(kappa) / mpmath.mpf(m)
        if ends == "free":
            return [scale * mpmath.sin(mpmath.mpf(j) * mpmath.pi / (2 * n)) ** 2 for j in range(count)]
        return [scale * mpmath.sin(mpmath.mpf(j + 1) * mpmath.pi / (2 * (n + 1))) ** 2 for j in range(count)]


def assert_guides(eigenvalues: np.ndarray, error: np.ndarray, truth: list) -> None:
    """Both ways, in omega^2 and (through omega_and_error, what Modes reports) in omega."""
    omega, omega_error = omega_and_error(eigenvalues, error)
    with mpmath.workdps(40):
        for j, exact in enumerate(truth):
            true_error = abs(mpmath.mpf(float(eigenvalues[j])) - exact)
            assert true_error <= error[j], (j, float(true_error), error[j])
            if exact == 0:
                continue
            assert error[j] <= max(1000 * true_error, 1e-13 * exact), (j, float(true_error), error[j])
            root = mpmath.sqrt(exact)
            omega_true_error = abs(mpmath.mpf(float(omega[j])) - root)
            assert omega_true_error <= omega_error[j], j
            assert omega_error[j] <= max(1000 * omega_true_error, 1e-13 * root), (j, omega_error[j])


# ------------------------------------------------------------------------------ uniform chains
@pytest.mark.parametrize("n", [1_000, 10_000, 100_000])
@pytest.mark.parametrize("ends", ["free", "fixed"])
@pytest.mark.parametrize("vectors", [False, True])
def test_lowest_modes_of_uniform_chains_guide(n: int, ends: str, vectors: bool) -> None:
    """The lowest 10 (Golub-Kahan bisection, Kato-Temple certificates): bound / true error in [1, 1000]."""
    kappa, m = 3.0, 0.7  # entries sqrt(kappa / m), not exact: the forming error is real
    walls = (kappa, kappa) if ends == "fixed" else (0.0, 0.0)
    result = lowest(np.full(n, m), np.full(n - 1, kappa), walls, 10, vectors)
    assert result.solver == "accurate-bisection"
    assert_guides(result.eigenvalues, result.error, closed_form(n, ends, 10, kappa, m))


@pytest.mark.slow
@pytest.mark.parametrize("vectors", [False, True])
def test_lowest_twenty_of_the_million_site_chain_guide(vectors: bool) -> None:
    """The issue's 10^6-site chain (once 2.4e-9 reported for an error of 4e-15): the lowest 20."""
    n = 1_000_000
    result = lowest(np.ones(n), np.ones(n - 1), (0.0, 0.0), 20, vectors)
    assert_guides(result.eigenvalues, result.error, closed_form(n, "free", 20))


@pytest.mark.parametrize("n", [300, CERTIFY_ALL])
@pytest.mark.parametrize("vectors", [False, True])
def test_every_mode_of_a_uniform_chain_guides(n: int, vectors: bool) -> None:
    """All modes (dqds, certified by dbdsqr or inverse-iteration triplets), fixed ends, closed form."""
    kappa, m = 2.0, 5.0
    result = all_modes(np.full(n, m), np.full(n - 1, kappa), (kappa, kappa), vectors)
    assert result.solver == "accurate-bidiagonal"
    assert_guides(result.eigenvalues, result.error, closed_form(n, "fixed", n, kappa, m))


@pytest.mark.parametrize("ends", ["free", "fixed"])
def test_every_mode_of_a_long_uniform_chain_is_certified(ends: str) -> None:
    """10^4 sites, values only: every value certified by its compiled triplet (`triplets`), each
    bound covering the closed form and within 1000x its error or 1e-13 (once the size law,
    2.3e-11 relative for errors of ~1e-16)."""
    n = 10_000
    walls = (0.0, 0.0) if ends == "free" else (1.0, 1.0)
    result = all_modes(np.ones(n), np.ones(n - 1), walls, False)
    assert_guides(result.eigenvalues, result.error, closed_form(n, ends, n))


def test_on_the_numpy_route_long_chains_keep_the_size_law(monkeypatch: pytest.MonkeyPatch) -> None:
    """On the numpy route (`bidiagonal._compiled` None), values past CERTIFY_ALL keep the measured size law (the
    numpy certificates cost ~15x dqds): still never below the true error."""
    monkeypatch.setattr(bidiagonal, "_compiled", lambda: None)
    n = 4_000
    result = all_modes(np.ones(n), np.ones(n - 1), (0.0, 0.0), False)
    truth = closed_form(n, "free", n)
    with mpmath.workdps(40):
        errors = [abs(mpmath.mpf(float(v)) - t) for v, t in zip(result.eigenvalues, truth)]
    assert all(e <= b for e, b in zip(errors, result.error))
    assert result.error[-1] / result.eigenvalues[-1] > 1e-13  # the size law, not a certificate


# --------------------------------------------------------------------------- disordered chains
@pytest.mark.parametrize("spread", [1e6, 1e12])
@pytest.mark.parametrize("vectors", [False, True])
@pytest.mark.parametrize("walls", [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)])
def test_lowest_modes_of_disordered_chains_guide(spread: float, vectors: bool, walls) -> None:
    """2,000 sites, masses and springs log-uniform over `spread`: the lowest 6 against mpmath counts."""
    mass, springs = disordered(2000, spread, 11)
    walls = (walls[0] * springs[0], walls[1] * springs[-1])
    result = lowest(mass, springs, walls, 6, vectors)
    zero = 1 if walls == (0.0, 0.0) else 0
    assert_guides_by_counts(mass, springs, walls, result.eigenvalues, result.error, range(zero, 6))
    if zero:
        assert result.eigenvalues[0] == 0.0  # a free chain's translation, exactly


@pytest.mark.parametrize("vectors", [False, True])
def test_every_mode_of_a_disordered_chain_guides(vectors: bool) -> None:
    """600 sites spread over 1e9, all modes: a sample of modes against mpmath counts."""
    mass, springs = disordered(600, 1e9, 4)
    result = all_modes(mass, springs, (0.0, 0.0), vectors)
    assert_guides_by_counts(mass, springs, (0.0, 0.0), result.eigenvalues, result.error, [1, 2, 3, 150, 300, 599])


def test_public_all_mode_values_of_a_disordered_chain_are_certified() -> None:
    """normal_modes(K, M, spring_factor=(B, w), vectors=False), 1,500 sites spread over 1e10
    (inside CERTIFY_FROM..CERTIFY_ALL): the forming error from each entry's rounding and the
    solving error from each value's triplet, so every bound is tight; a sample against mpmath
    counts (covers, and within 1000x or 1e-13). Before the spring factor reached this path the
    bound was the worst case, 10 n eps = 3.3e-12 relative for every mode."""
    mass, springs = disordered(1500, 1e10, 21)
    B, w, K = chain(mass, springs, (0.0, 0.0))
    modes = normal_modes(K, mass, spring_factor=(B, w), vectors=False)
    assert modes.solver == "accurate-bidiagonal"
    relative = modes.omega_error[1:] / modes.omega[1:]
    assert float(relative.max()) < 1e-14
    for j in [1, 2, 3, 700, 1499]:
        omega, bound = mpmath.mpf(float(modes.omega[j])), mpmath.mpf(float(modes.omega_error[j]))
        with mpmath.workdps(40):
            assert sturm_count(mass, springs, (0.0, 0.0), (omega - bound) ** 2) <= j
            assert sturm_count(mass, springs, (0.0, 0.0), (omega + bound) ** 2) > j
            if bound / 1000 > 1e-13 * omega:
                inside = (sturm_count(mass, springs, (0.0, 0.0), (omega - bound / 1000) ** 2) <= j
                          < sturm_count(mass, springs, (0.0, 0.0), (omega + bound / 1000) ** 2))
                assert not inside


def test_public_partial_solve_of_a_disordered_chain_covers_and_guides() -> None:
    """normal_modes(K, M, n_modes=8): K's own anchor read back from its row sums; 3,000 sites.
    In omega, as Modes reports it: (omega +- omega_error)^2 brackets the j-th eigenvalue, and
    (omega +- omega_error / 1000)^2 does not where omega_error / 1000 exceeds 1e-13 omega."""
    mass, springs = disordered(3000, 1e10, 8)
    walls = (springs[0], 0.0)
    _, _, K = chain(mass, springs, walls)
    modes = normal_modes(K, mass, n_modes=8, vectors=False)
    assert modes.solver == "accurate-bisection"
    for j in range(8):
        omega, bound = mpmath.mpf(float(modes.omega[j])), mpmath.mpf(float(modes.omega_error[j]))
        with mpmath.workdps(40):
            assert sturm_count(mass, springs, walls, (omega - bound) ** 2) <= j
            assert sturm_count(mass, springs, walls, (omega + bound) ** 2) > j
            if bound / 1000 > 1e-13 * omega:
                inside = (sturm_count(mass, springs, walls, (omega - bound / 1000) ** 2) <= j
                          < sturm_count(mass, springs, walls, (omega + bound / 1000) ** 2))
                assert not inside


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10**6), n=st.integers(2, 40), spread_exponent=st.integers(0, 12),
       walls=st.sampled_from([(0, 0), (1, 0), (0, 1), (1, 1)]), vectors=st.booleans(), every=st.booleans())
def test_bounds_over_ratios_1e_12_to_1e12(seed, n, spread_exponent, walls, vectors, every) -> None:
    """Masses and springs log-uniform over 10^-6..10^6 times each other's spread (ratios up to 1e12):
    both paths, every mode, mpmath counts (never below; within 1000x or 1e-13)."""
    rng = np.random.default_rng(seed)
    half = spread_exponent / 2
    mass = 10.0 ** rng.uniform(-half, half, n)
    springs = 10.0 ** rng.uniform(-half, half, n - 1)
    wall = (walls[0] * float(10.0 ** rng.uniform(-half, half)), walls[1] * float(10.0 ** rng.uniform(-half, half)))
    result = all_modes(mass, springs, wall, vectors) if every else lowest(mass, springs, wall, n, vectors)
    zero = 1 if wall == (0.0, 0.0) else 0
    assert_guides_by_counts(mass, springs, wall, result.eigenvalues, result.error, range(zero, n))


# ---------------------------------------------------------------- the error-free transformations
@settings(max_examples=100, deadline=None)
@given(a=st.floats(-1e150, 1e150, allow_nan=False), b=st.floats(-1e150, 1e150, allow_nan=False))
def test_two_sum_and_two_product_are_exact(a: float, b: float) -> None:
    """Truth: exact rational arithmetic."""
    s, t = two_sum(np.array([a]), np.array([b]))
    assert Fraction(float(s[0])) + Fraction(float(t[0])) == Fraction(a) + Fraction(b)
    if 1e-140 < abs(a) and 1e-140 < abs(b):
        p, e = two_product(np.array([a]), np.array([b]))
        assert Fraction(float(p[0])) + Fraction(float(e[0])) == Fraction(a) * Fraction(b)


@settings(max_examples=100, deadline=None)
@given(w=st.floats(-200, 200), m=st.floats(-200, 200), sign=st.sampled_from([-1.0, 1.0]))
def test_entry_deviation_matches_mpmath(w: float, m: float, sign: float) -> None:
    """delta = x / (sqrt(w) c / sqrt(m)) - 1 of the float64 entry, against 50-digit mpmath, at any scale."""
    weight, mass = 10.0**w, 10.0**m
    x = sign * np.sqrt(weight) * (1.0 / np.sqrt(mass))
    delta, slack = entry_deviation(np.array([x]), np.array([weight]), np.array([sign]), np.array([mass]))
    with mpmath.workdps(50):
        exact = mpmath.mpf(x) / (sign * mpmath.sqrt(mpmath.mpf(weight)) / mpmath.sqrt(mpmath.mpf(mass))) - 1
        assert abs(exact - mpmath.mpf(float(delta[0]))) <= mpmath.mpf(float(slack[0]))
    assert slack[0] < 1e-29


def test_scalings_reproduce_the_stored_entries_and_a_uniform_chain_rounds_alike() -> None:
    """exp(a_i) d_i exp(b_i) = d_i (1 + dd_i) and exp(a_i) e_i exp(b_{i+1}) = e_i (1 + de_i); a common
    factor gives a bound of that factor alone (truth: the definition, and the closed form of a constant)."""
    rng = np.random.default_rng(3)
    dd, de = rng.uniform(-EPS, EPS, 50), rng.uniform(-EPS, EPS, 49)
    d = rng.uniform(1, 2, 50)
    a, b = scaling_logs(dd, de, d)
    np.testing.assert_allclose(np.expm1(a + b), dd, atol=1e-30, rtol=1e-12)
    np.testing.assert_allclose(np.expm1(a[:-1] + b[1:]), de, atol=1e-30, rtol=1e-12)
    a, b = scaling_logs(np.full(50, 3e-17), np.full(49, 3e-17), d)
    assert walk_bound(a, b, 0.0) == pytest.approx(3e-17, rel=1e-6)


def test_forming_of_a_disordered_chain_grows_like_a_walk() -> None:
    """10^5 sites spread over 1e6: the scalings' bound stays near sqrt(size) eps, far below the
    worst case 5 eps per entry (1e6 eps): the figure that lets the bound guide on long chains."""
    mass, springs = disordered(100_000, 1e6, 2)
    B, w, _ = chain(mass, springs)
    weighted = weighted_factor(B, w, mass)
    segments = chain_segments(weighted)
    bound = segment_scalings(weighted, segments, B, w, mass)[0].bound()
    assert bound <= 30 * np.sqrt(2 * 100_000) * EPS


def test_lowest_path_without_entry_figures_keeps_the_worst_case() -> None:
    """No spring factor known to the path: the worst-case forming figure, still covering (closed form)."""
    n = 2000
    B, w, K = chain(np.full(n, 0.7), np.full(n - 1, 3.0))
    weighted = weighted_factor(B, w, np.full(n, 0.7))
    result = lowest_chain_path(mass_weighted(K, np.full(n, 0.7)), chain_segments(weighted), 5, vectors=False)
    truth = closed_form(n, "free", 5, 3.0, 0.7)
    with mpmath.workdps(40):
        for j in range(1, 5):
            assert abs(mpmath.mpf(float(result.eigenvalues[j])) - truth[j]) <= result.error[j]
