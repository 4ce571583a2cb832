"""A value repeated inside one connected part more often than a Krylov iteration sees: the Sylvester count.

A star of M identical arms (ARM sites each, springs 1 + 0.3 s along the arm, 1 to the hub; unit masses)
is one connected part whose arm modes are (M - 1)-fold. Before the count the sparse path returned the
lowest 250 values of a 200-arm star (0 to 0.41) off by up to 0.38, every pair's residual small.

Truth from outside the solver: the star's symmetry splits it into small chains (not the star's own
matrix). A mode in which the hub stays still moves each arm as a chain walled at the hub (the ARM x ARM
matrix T below), M - 1 independent ways (amplitudes summing to zero); a mode in which every arm moves
alike is a chain of the hub and one arm whose masses and springs are M times heavier (ARM + 1 dofs).
Their values, with those multiplicities, are the star's whole spectrum.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as sla
from hypothesis import given, settings
from hypothesis import strategies as st

import vibra.solvers.standard.sparse as sparse
from vibra.modes import normal_modes
from tests.helpers.stars import star, star_spectrum
from vibra.solvers.standard.inertia import below, missed


def test_the_truth_is_the_stars_spectrum() -> None:
    """The split into chains agrees with the star's whole matrix (small enough for eigvalsh)."""
    assert np.allclose(star_spectrum(7, 4), la.eigvalsh(star(7, 4).toarray()), rtol=0, atol=1e-13)


@pytest.mark.parametrize(("arms", "arm", "k"), [(200, 10, 250), (300, 10, 50), (60, 30, 40)])
@pytest.mark.parametrize("accuracy", ["fast", "high"])
def test_lowest_values_of_a_star_hold_every_copy(arms: int, arm: int, k: int, accuracy: str) -> None:
    """Every copy of a (M - 1)-fold value among the k lowest: to 1e-12 ||K|| (the path's own absolute
    accuracy, ~eps ||K~|| times the rounding of the Ritz step on k vectors), and within the reported
    bounds (their floor, 4 eps ||K~||)."""
    K = star(arms, arm)
    truth = star_spectrum(arms, arm)[:k]
    modes = normal_modes(K, np.ones(K.shape[0]), n_modes=k, solver="sparse", accuracy=accuracy)
    scale = float(abs(K).sum(axis=1).max())
    assert np.max(np.abs(modes.omega ** 2 * np.sign(modes.omega) - truth)) <= 1e-12 * scale
    moving = truth > 1e-6
    assert np.all(np.abs(modes.omega[moving] - np.sqrt(truth[moving])) <= modes.omega_error[moving] + 1e-15)


@pytest.mark.parametrize(("arms", "arm", "k"), [(60, 30, 40), (300, 10, 50), (30, 40, 100)])
def test_block_iteration_on_a_star(monkeypatch, arms: int, arm: int, k: int) -> None:
    """The block iteration (3-D networks' route, forced here on the star) with a value far more multiple
    than its block: widened, or handed to ARPACK, and counted either way."""
    monkeypatch.setattr(sparse, "BLOCK_FILL", 0.0)
    K = star(arms, arm)
    values, _, _ = sparse.lowest_pairs(K, k)
    assert np.max(np.abs(values - star_spectrum(arms, arm)[:k])) <= 1e-12 * float(abs(K).sum(axis=1).max())


def test_arpack_failing_outright_goes_to_the_block_iteration(monkeypatch) -> None:
    """ARPACK's error 3 (no shifts to apply, met on a 400-arm star asking 450 values): the block
    iteration with a column per pair serves (the error forced here on a smaller star)."""
    original, blocks = sparse._arpack, sparse._shift_invert_blocks
    calls = {"arpack": 0, "blocks": 0}

    def failing_once(*args, **kwargs):
        calls["arpack"] += 1
        if calls["arpack"] == 1:
            raise sla.ArpackError(3)
        return original(*args, **kwargs)

    def counted(*args, **kwargs):
        calls["blocks"] += 1
        return blocks(*args, **kwargs)

    monkeypatch.setattr(sparse, "_arpack", failing_once)
    monkeypatch.setattr(sparse, "_shift_invert_blocks", counted)
    K = star(60, 30)
    values, _, _ = sparse.lowest_pairs(K, 40)
    assert calls["blocks"] >= 1
    assert np.max(np.abs(values - star_spectrum(60, 30)[:40])) <= 1e-12 * float(abs(K).sum(axis=1).max())


@pytest.mark.parametrize(("arms", "arm", "k", "onsite"), [(300, 10, 50, 20.0), (60, 30, 40, 100.0), (300, 10, 50, -0.5),
                                                         (20, 5, 10, 0.0), (1000, 3, 12, 0.0), (1000, 3, 30, 0.0)])
def test_stars_on_onsite_springs_and_short_arms(arms: int, arm: int, k: int, onsite: float) -> None:
    """On-site springs (K + cI: the values bunched far above the first shift, which moves closer; c < 0: an
    indefinite K) and short arms (an operator of few distinct values, whose Krylov space closes after a few
    steps: fresh directions continue it, and among more equal Ritz values than asked the converged ones are
    taken). Each raised or came back wrong in review (the count's repair on the first shift's factor; columns
    normalised from rounding; unconverged copies of a 999-fold value taken by position). Truth shifted by c."""
    K = (star(arms, arm) + onsite * sp.identity(1 + arms * arm)).tocsr()
    values, _, _ = sparse.lowest_pairs(K, k)
    truth = star_spectrum(arms, arm)[:k] + onsite
    assert np.max(np.abs(values - truth)) <= 1e-12 * float(abs(K).sum(axis=1).max())


@settings(max_examples=40, deadline=None)
@given(n=st.integers(2, 60), seed=st.integers(0, 2**32 - 1), where=st.floats(0.0, 1.0))
def test_count_below_agrees_with_eigvalsh(n: int, seed: int, where: float) -> None:
    """The negative pivots of K - tau I count the eigenvalues below tau (Sylvester), for a random sparse
    symmetric indefinite K and tau inside its spectrum, at least 1e-3 ||K|| from every eigenvalue (closer, an
    LDL^T without pivoting may grow; the path places tau in a gap of the values found)."""
    rng = np.random.default_rng(seed)
    A = sp.random(n, n, density=min(1.0, 4.0 / n), random_state=rng) + sp.diags(rng.standard_normal(n))
    K = sp.csr_matrix(A + A.T)
    exact = la.eigvalsh(K.toarray())
    tau = exact[0] - 1.0 + where * (exact[-1] - exact[0] + 2.0)
    if np.min(np.abs(exact - tau)) < 1e-3 * max(1.0, np.abs(exact).max()):
        return
    assert below(K, tau) == int(np.sum(exact < tau))


@pytest.mark.parametrize(("arms", "arm"), [(200, 10), (60, 30), (1000, 3)])
def test_count_below_on_every_backend(arms: int, arm: int) -> None:
    """`below` at points halfway between the star's distinct values (and 1e-8 relative below each): PARDISO's LDL^T
    inertia where it serves the shifts (these stars have 1,801 to 3,001 dofs), SuperLU's pivots otherwise; both
    against the chains' spectrum."""
    from vibra.solvers.standard.pardiso import negative_eigenvalues, pardiso_available

    K = star(arms, arm)
    truth = star_spectrum(arms, arm)
    distinct = np.unique(np.round(truth, 9))[:6]
    for tau in np.r_[0.5 * (distinct[1:] + distinct[:-1]), distinct[1:] * (1 - 1e-8)]:
        expected = int(np.sum(truth < tau))
        assert below(K, tau) == expected
        if pardiso_available():
            count = negative_eigenvalues(K - tau * sp.identity(K.shape[0]))
            assert count is None or count == expected


def test_missed_counts_what_a_value_lacks() -> None:
    """Found 0, a few copies of the lowest arm value and the next values: the count says how many
    copies are missing below the highest found."""
    K = star(20, 3)
    truth = star_spectrum(20, 3)
    distinct = np.unique(np.round(truth, 10))
    found = np.r_[0.0, np.full(5, distinct[1]), distinct[2]]  # 5 of the 19 copies, then the next value
    scale = float(abs(K).sum(axis=1).max())
    below_next = int(np.sum(truth < distinct[2] - 1e-9))
    assert missed(K, found, scale) == (below_next - 6, 6)
    assert missed(K, truth[:30], scale)[0] == 0


def test_a_lower_value_missed_entirely_is_counted_and_found() -> None:
    """Found: five copies of the lowest arm value and nothing else (the zero mode below them missed, as an
    iteration whose start lacked it could): one cluster, counted below it, and the repair finds the zero mode.
    (The found pairs are exact eigenpairs, from eigh, standing in for an iteration's.)"""
    K = star(60, 30)
    truth = star_spectrum(60, 30)
    values, vectors = la.eigh(K.toarray())
    found = np.flatnonzero(np.abs(values - truth[1]) <= 1e-9)[:5]
    missing, low = missed(K, values[found], float(abs(K).sum(axis=1).max()))
    assert (missing, low) == (1, 0)
    sigma, factor = sparse.lowest_shift(K)
    repaired, _ = sparse._missing(K, 5, factor, sigma, values[found], vectors[:, found], missing, low)
    assert np.max(np.abs(repaired - truth[:5])) <= 1e-12 * float(abs(K).sum(axis=1).max())
