"""The lowest modes of chains whose masses and springs spread over up to 1e12 (issue 15, item 0).

Truth: Sturm-count bisection of the mass-weighted tridiagonal in 60-digit mpmath, built from
the springs and masses themselves (not from anything vibra computed).
"""

from __future__ import annotations

import mpmath
import numpy as np
import pytest
import scipy.sparse as sp
from helpers.springs import partial_truth as _truth
from hypothesis import given, settings
from hypothesis import strategies as st

from vibra.modes import normal_modes
from vibra.solvers.accurate import gk_bisection
from vibra.solvers.accurate.chain.lowest import (
    chain_segments,
    lowest_chain_path,
    spring_factor_of_chain,
)


def _chain(n: int, spread: float, seed: int, anchored: bool = False):
    """Masses and springs log-uniform over `spread`; (B~, K, masses, springs, anchor)."""
    rng = np.random.default_rng(seed)
    mass = 10.0 ** rng.uniform(0, np.log10(spread), n)
    springs = 10.0 ** rng.uniform(0, np.log10(spread), n - 1)
    anchor = float(10.0 ** rng.uniform(0, np.log10(spread))) if anchored else 0.0
    rows = np.repeat(np.arange(n - 1), 2)
    cols = np.ravel(np.c_[np.arange(n - 1), np.arange(1, n)])
    vals = np.tile([-1.0, 1.0], n - 1)
    weights = springs
    if anchored:
        rows, cols, vals = np.r_[rows, n - 1], np.r_[cols, 0], np.r_[vals, 1.0]
        weights = np.r_[springs, anchor]
    B = sp.csr_matrix((vals, (rows, cols)), shape=(weights.shape[0], n))
    weighted = sp.csr_matrix(sp.diags(np.sqrt(weights)) @ B @ sp.diags(1.0 / np.sqrt(mass)))
    K = sp.csr_matrix(B.T @ sp.diags(weights) @ B)
    return weighted, K, mass, springs, anchor


def _check(result, truth, relative: float = 1e-10) -> None:
    omega = np.sqrt(result.eigenvalues)
    for j, value in enumerate(truth):
        true = float(mpmath.sqrt(value))
        if true == 0.0:
            assert omega[j] <= np.sqrt(result.error[j]) + 1e-300
            continue
        error = abs(omega[j] - true) / true
        assert error <= relative, (j, omega[j], true)
        # the reported bound covers the true error (in omega^2)
        assert abs(result.eigenvalues[j] - true**2) <= result.error[j]


@pytest.mark.parametrize("anchored", [False, True])
@pytest.mark.parametrize("vectors", [False, True])
def test_lowest_ten_of_a_disordered_chain_spread_1e12(anchored: bool, vectors: bool) -> None:
    weighted, K, mass, springs, anchor = _chain(300, 1e12, 7, anchored)
    Kt = sp.csr_matrix(sp.diags(mass**-0.5) @ K @ sp.diags(mass**-0.5))
    result = lowest_chain_path(Kt, chain_segments(weighted), 10, vectors=vectors)
    assert result.solver == "accurate-bisection"
    _check(result, _truth(mass, springs, anchor, 10))
    if vectors:
        assert result.orthogonality < 1e-10
        assert result.residual < 1e-12


def test_bisection_branch_is_taken_for_values_when_dqds_would_cost_more(monkeypatch) -> None:
    weighted, K, mass, springs, anchor = _chain(200, 1e12, 3)
    monkeypatch.setattr(gk_bisection, "DQDS_FACTOR", 0)  # force bisection
    Kt = sp.csr_matrix(sp.diags(mass**-0.5) @ K @ sp.diags(mass**-0.5))
    _check(lowest_chain_path(Kt, chain_segments(weighted), 10, vectors=False), _truth(mass, springs, anchor, 10))


@settings(max_examples=12, deadline=None)
@given(spread_exponent=st.integers(0, 12), seed=st.integers(0, 10**6), n=st.integers(2, 60),
       k=st.integers(1, 8), anchored=st.booleans(), force_bisection=st.booleans())
def test_lowest_modes_match_mpmath_over_spreads(spread_exponent, seed, n, k, anchored, force_bisection) -> None:
    weighted, K, mass, springs, anchor = _chain(n, 10.0**spread_exponent, seed, anchored)
    Kt = sp.csr_matrix(sp.diags(mass**-0.5) @ K @ sp.diags(mass**-0.5))
    k = min(k, n)
    saved = gk_bisection.DQDS_FACTOR
    gk_bisection.DQDS_FACTOR = 0 if force_bisection else saved
    try:
        result = lowest_chain_path(Kt, chain_segments(weighted), k, vectors=force_bisection)
    finally:
        gk_bisection.DQDS_FACTOR = saved
    _check(result, _truth(mass, springs, anchor, k))


@pytest.mark.parametrize("anchored", [False, True])
def test_spring_factor_of_a_tridiagonal_stiffness(anchored: bool) -> None:
    """K alone (no factor given): springs from its off-diagonals, anchors from its row sums."""
    _, K, mass, springs, anchor = _chain(250, 1e12, 11, anchored)
    factor = spring_factor_of_chain(K)
    assert factor is not None
    B, w = factor
    weighted = sp.csr_matrix(sp.diags(np.sqrt(w)) @ B @ sp.diags(1.0 / np.sqrt(mass)))
    Kt = sp.csr_matrix(sp.diags(mass**-0.5) @ K @ sp.diags(mass**-0.5))
    _check(lowest_chain_path(Kt, chain_segments(weighted), 10, vectors=False), _truth(mass, springs, anchor, 10))


def test_spring_factor_of_chain_refuses_what_is_not_a_chain() -> None:
    assert spring_factor_of_chain(sp.csr_matrix(np.array([[1.0, 0.5], [0.5, 1.0]]))) is None  # negative spring
    assert spring_factor_of_chain(sp.csr_matrix(np.array([[1.0, -2.0], [-2.0, 1.0]]))) is None  # negative anchor
    ring = sp.csr_matrix(np.array([[2.0, -1, -1], [-1, 2, -1], [-1, -1, 2]]))
    assert spring_factor_of_chain(ring) is None


def test_normal_modes_partial_solve_of_a_disordered_chain() -> None:
    """normal_modes(K, M, n_modes=10) on 2,000 sites spread over 1e12 (ARPACK fails without the route)."""
    _, K, mass, springs, anchor = _chain(2000, 1e12, 5)
    modes = normal_modes(K, mass, n_modes=10, vectors=False)
    truth = np.array([float(mpmath.sqrt(v)) for v in _truth(mass, springs, anchor, 4)])
    assert modes.omega.shape == (10,)
    assert abs(modes.omega[0]) <= modes.omega_error[0]
    assert np.all(np.abs(modes.omega[1:4] - truth[1:]) <= 1e-10 * truth[1:])


@pytest.mark.parametrize("accuracy", ["high", "fast"])
def test_system_modes_partial_solve_of_a_disordered_chain_routes_to_bisection(accuracy: str) -> None:
    """System.modes(n_modes=10), either accuracy, with vectors, on 2,000 sites spread over 1e12
    (ArpackNoConvergence before): frequencies against 60-digit mpmath, vectors by residual."""
    from vibra.chains import linear_chain

    _, K, mass, springs, anchor = _chain(2000, 1e12, 5)
    chain = linear_chain(2000, mass=mass, stiffness=springs, ends="free", units="dimensionless")
    modes = chain.modes(n_modes=10, accuracy=accuracy)
    assert modes.solver == "accurate-bisection"
    truth = np.array([float(mpmath.sqrt(v)) for v in _truth(mass, springs, anchor, 4)])
    assert np.all(np.abs(modes.omega[1:4] - truth[1:]) <= 1e-10 * truth[1:])
    Kt = chain.hessian().toarray() / np.sqrt(np.outer(mass, mass))
    residual = Kt @ modes.vectors - modes.vectors * modes.omega_squared
    assert np.abs(residual).max() <= 1e-12 * np.abs(Kt).max()


def test_shift_invert_keeps_converged_pairs_and_redoes_those_a_zero_mode_held() -> None:
    """A free 2-D triangular mesh (3 zero modes far below the rest: they dominate the shifted
    inverse) and a free chain of 200,000 sites (its lowest values within a few |sigma|): both
    come out with residuals within 1e-14 ||K~|| (a zero mode left beside the others holds them
    at ~1e-11), values equal to the dense solve's / the closed form."""
    import scipy.linalg as la

    from vibra import System
    from vibra.solvers.standard import sparse

    rng = np.random.default_rng(1)
    m = 40
    xy = np.array([(i + 0.5 * (j % 2), j * np.sqrt(3) / 2) for j in range(m) for i in range(m)])
    xy += 0.05 * rng.standard_normal(xy.shape)
    pairs = np.array([(a, b) for a in range(len(xy)) for b in range(a + 1, min(a + m + 2, len(xy)))
                      if np.linalg.norm(xy[a] - xy[b]) < 1.3])
    mesh = System.from_springs(xy, 1.0, pairs, 1.0)
    n = 200_000
    chain = System.from_springs(np.arange(n, dtype=float), 1.0, np.c_[np.arange(n - 1), np.arange(1, n)], 1.0)
    for system, k in ((mesh, 12), (chain, 8)):
        Kt = sp.csr_matrix(system.hessian())
        sigma, factor = sparse.lowest_shift(Kt)
        values, basis = sparse.shift_invert(Kt, k, sigma, factor)
        scale = float(abs(Kt).sum(axis=1).max())
        residual = np.linalg.norm(Kt @ basis - basis * values, axis=0) / scale
        assert residual.max() <= 1e-14
        if system is mesh:
            dense = la.eigh(Kt.toarray(), eigvals_only=True, subset_by_index=[0, k - 1])
            np.testing.assert_allclose(values[3:], dense[3:], rtol=1e-11)
        else:
            exact = 4 * np.sin(np.arange(k) * np.pi / (2 * n)) ** 2
            np.testing.assert_allclose(values[1:], exact[1:], rtol=1e-6)
