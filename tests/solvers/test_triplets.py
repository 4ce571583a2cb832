"""The compiled certificates of every chain frequency (`vibra.solvers.accurate.chain.triplets`, issue 15 item 6).

Truth from outside the code under test: 40-digit mpmath Sturm counts of the mass-weighted
tridiagonal built from the springs and masses themselves (`sturm_count` of
test_chain_bounds_large), and exact singular values where the bidiagonal is built to have them.
The compiled route must give bounds that cover the truth and lie within 1000 times it (or
1e-13 relative), like the numpy route it replaces, at any size.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from helpers.chains import all_modes, assert_guides_by_counts, disordered
from vibra.solvers.accurate.chain import bidiagonal
from vibra.solvers.accurate.rounding import Scalings

triplets = pytest.importorskip("vibra.solvers.accurate.chain.triplets")


@settings(max_examples=30, deadline=None)
@given(n=st.integers(2, 400), exponent=st.integers(0, 12), seed=st.integers(0, 10_000),
       walls=st.sampled_from([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)]))
def test_values_of_extreme_chains_are_covered(n: int, exponent: int, seed: int, walls) -> None:
    """Chains of 2..400 sites, masses and springs log-uniform over 1..1e12: each checked mode's
    bound covers the mpmath count and is within 1000x of the error (or 1e-13); all modes up to
    60 sites, 20 (the ends and a random sample) beyond. Certified wherever the a-priori bound
    exceeds 1e-13 (`bidiagonal.CERTIFY_ABOVE`: from ~40 sites here)."""
    mass, springs = disordered(n, 10.0**exponent, seed)
    walls = (walls[0] * (springs[0] if n > 1 else 1.0), walls[1] * (springs[-1] if n > 1 else 1.0))
    result = all_modes(mass, springs, walls, False)
    zero = 1 if walls == (0.0, 0.0) else 0
    modes = list(range(zero, n))
    if n > 60:
        picked = np.random.default_rng(seed).choice(modes[3:-3], 14, replace=False).tolist()
        modes = sorted(set(modes[:3] + modes[-3:] + picked))
    assert_guides_by_counts(mass, springs, walls, result.eigenvalues, result.error, modes)


@pytest.mark.parametrize("spread", [1.0, 1e4, 1e12])
def test_compiled_and_numpy_routes_both_cover(spread: float, monkeypatch: pytest.MonkeyPatch) -> None:
    """2,000 sites (every a-priori bound over 1e-13, so the compiled route certifies all): the
    compiled and the numpy certificates (the numpy route, inside CERTIFY_FROM..CERTIFY_ALL) both
    cover the truth on a sample, and the compiled bounds are within 100x of numpy's."""
    n = 2000
    mass, springs = (np.ones(n), np.ones(n - 1)) if spread == 1.0 else disordered(n, spread, 7)
    walls = (springs[0], 0.0)
    compiled = all_modes(mass, springs, walls, False)
    assert float(np.max(compiled.error / compiled.eigenvalues)) < 1e-13
    monkeypatch.setattr(bidiagonal, "_compiled", lambda: None)
    reference = all_modes(mass, springs, walls, False)
    sample = [0, 1, 2, 5, 100, 999, 1000, 1650, 1998, 1999]
    for result in (compiled, reference):
        assert_guides_by_counts(mass, springs, walls, result.eigenvalues, result.error, sample)
    assert np.all(compiled.error <= 100 * reference.error + 1e-13 * compiled.eigenvalues)


def test_a_cluster_keeps_the_a_priori_bound() -> None:
    """d = 1, e = 0: every singular value exactly 1, no gap; no certificate can be formed, each
    value keeps the a-priori bound (finite, covering the exact 1)."""
    size = 50
    d, e = np.ones(size), np.zeros(size - 1)
    sigma = np.ones(size)
    value, relative = bidiagonal.certified_values(d, e, sigma, Scalings.worst_case(size, 1e-15))
    assert np.all(np.isfinite(relative)) and np.all(np.abs(value - 1.0) <= relative * value)


def test_an_exact_zero_pivot_is_stepped_over() -> None:
    """sigma = d_0 exactly makes the first stationary-qd pivot zero; the value is still
    finite (the Golub-Kahan solve with a shift moved by 4 eps), and a true value beside it in
    the same block is refined to its SVD value (numpy's SVD of the 3 x 3 bidiagonal)."""
    d, e = np.ones(3), np.full(2, 0.5)
    exact = np.sort(np.linalg.svd(np.diag(d) + np.diag(e, 1), compute_uv=False))
    sigma = np.array([1.0, exact[2]])
    out = triplets.triplet_figures(d, e, sigma, np.random.default_rng(0).standard_normal(6),
                                   np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3), np.full(2, 0.1))
    assert np.all(np.isfinite(out))
    assert abs(out[1, 0] - exact[2]) < 1e-14


def test_non_contiguous_input_is_copied() -> None:
    """The kernel reads its arrays unchecked; the wrapper hands it contiguous float64 copies
    (a reversed view here), and the values come back refined to the SVD's."""
    d, e = np.ones(4)[::-1], np.full(3, 0.25)
    sigma = np.sort(np.linalg.svd(np.diag(d) + np.diag(e, 1), compute_uv=False))
    out = triplets.triplet_figures(d, e, sigma, np.ones(8), *(np.zeros(4),) * 4, np.full(4, 0.05))
    assert out.shape == (4, 6) and np.all(np.abs(out[:, 0] - sigma) <= 1e-14 * sigma)


def test_near_degenerate_localised_modes_are_tight() -> None:
    """A disordered chain's modes localise far apart with nearly equal frequencies; one
    inverse-iteration step mixes such a pair, and the Kato-Temple bound with that small gap
    stays loose (here 4e-13 on one mode, with one step). A second step from the first's vectors
    (`_enough` failing) keeps it tight: 10,000 sites spread over 1e12, the closest pairs and
    the largest bound against mpmath counts."""
    n = 10_000
    mass, springs = disordered(n, 1e12, 8)
    walls = (springs[0], springs[-1])
    result = all_modes(mass, springs, walls, False)
    omega = np.sqrt(result.eigenvalues)
    gaps = np.minimum(np.diff(omega, prepend=-np.inf), np.diff(omega, append=np.inf)) / omega
    relative = result.error / result.eigenvalues
    sample = sorted(set(np.argsort(gaps)[:4].tolist()) | {int(np.argmax(relative))})
    assert assert_guides_by_counts(mass, springs, walls, result.eigenvalues, result.error, sample) is None
    assert float(relative.max()) < 1e-14
