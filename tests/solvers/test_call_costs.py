"""Per-call shortcuts keep their answers (twenty-fourth session, RESULTS.md "The dense path's checks, and per-call costs").

Truth: scipy's own `triu` and `sum_duplicates` for the upper triangle; a ring built by hand for `ring_ordering`;
LAPACK's `eigh` of K~ for the dense path's values, and the same solve with B~'s exact deviations formed up front
(the path as it was) for its bounds: two rigorous bounds of one value must overlap.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as la
import scipy.sparse as sp

import vibra.solvers.accurate.springs as springs
from vibra import networks
from vibra.solvers.accurate.spring_ritz import forming_deviation
from vibra.solvers.common import BAND_LIMIT, ring_ordering
from vibra.solvers.standard.pardiso import upper_triangle


def _untidy(rng: np.random.Generator, n: int) -> sp.csr_matrix:
    """A square CSR matrix with duplicates, unsorted rows, empty rows and explicit zeros."""
    A = sp.random(n, n, density=rng.uniform(0.0, 0.4), random_state=rng, format="csr")
    data, indices, counts = list(A.data), list(A.indices), np.diff(A.indptr).tolist()
    pieces_d, pieces_i = [], []
    for i in range(n):  # each row reversed (unsorted), its first entry repeated (a duplicate), row 0 an explicit zero
        d = data[A.indptr[i]:A.indptr[i + 1]][::-1]
        c = indices[A.indptr[i]:A.indptr[i + 1]][::-1]
        if c and rng.random() < 0.5:
            d, c = d + [rng.normal()], c + [c[0]]
            counts[i] += 1
        if i == 0:
            d, c = d + [0.0], c + [n - 1]
            counts[i] += 1
        pieces_d += d
        pieces_i += c
    indptr = np.r_[0, np.cumsum(counts)]
    M = sp.csr_matrix((np.array(pieces_d, dtype=float), np.array(pieces_i, dtype=np.int32), indptr), shape=(n, n))
    M.has_sorted_indices = False
    return M


@pytest.mark.parametrize("seed", range(40))
def test_upper_triangle_is_scipys_with_duplicates_summed(seed: int) -> None:
    rng = np.random.default_rng(seed)
    A = _untidy(rng, int(rng.integers(1, 40)))
    before = A.copy()
    U = upper_triangle(A)
    reference = sp.triu(A, format="csr")
    reference.sum_duplicates()
    assert U.has_canonical_format
    np.testing.assert_allclose(U.toarray(), reference.toarray(), rtol=4 * np.finfo(float).eps, atol=0.0)
    assert np.array_equal(U.indptr, reference.indptr) and np.array_equal(U.indices, reference.indices)
    assert np.array_equal(A.indices, before.indices) and np.array_equal(A.data, before.data)  # the caller's, untouched


def _ring(n: int, rng: np.random.Generator) -> sp.csr_matrix:
    k = rng.uniform(0.5, 2.0, n)
    K = sp.diags(k + np.roll(k, 1)).tolil()
    for i in range(n):
        K[i, (i + 1) % n] = K[(i + 1) % n, i] = -k[i]
    return K.tocsr()


@pytest.mark.parametrize("canonical", [True, False])
def test_a_ring_is_still_found_and_a_full_row_is_not_one(canonical: bool) -> None:
    rng = np.random.default_rng(7)
    K = _ring(300, rng)
    if not canonical:  # a duplicate entry: the row counts no longer settle it, the full check runs
        data, indices = np.insert(K.data, 1, 0.0), np.insert(K.indices, 1, K.indices[0])  # row 0's first column twice
        indptr = K.indptr + np.r_[0, np.ones(K.shape[0], dtype=K.indptr.dtype)]
        K = sp.csr_matrix((data, indices, indptr), shape=K.shape)
        assert not K.has_canonical_format
    found = ring_ordering(K)
    assert found is not None and found[1] <= 2
    # a row with more entries than any periodic band of half-width BAND_LIMIT holds (4 L + 3)
    dense_row = K.tolil()
    for j in range(4 * BAND_LIMIT + 4):
        dense_row[150, (150 + 20 + j) % 300] = dense_row[(150 + 20 + j) % 300, 150] = -1e-3
    assert ring_ordering(dense_row.tocsr()) is None


def _counting(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    calls: list[int] = []
    original = springs.cluster_bounds

    def counted(*args, **kwargs):  # type: ignore[no-untyped-def]
        calls.append(kwargs.get("deviation") is not None)
        return original(*args, **kwargs)

    monkeypatch.setattr(springs, "cluster_bounds", counted)
    return calls


def test_a_proteins_dense_check_forms_no_deviations_and_keeps_its_bounds(monkeypatch: pytest.MonkeyPatch) -> None:
    positions = np.random.default_rng(3).uniform(0.0, 30.0, (120, 3))
    system = networks.anm(positions, cutoff=12.0)
    B, w = system.spring_factor()
    weighted = springs.weighted_factor(B, w, np.ones(B.shape[1]))
    formed: list[int] = []

    def lazy():  # type: ignore[no-untyped-def]
        formed.append(1)
        return forming_deviation(weighted, B, w, np.ones(B.shape[1]))

    calls = _counting(monkeypatch)
    cheap = springs.checked_dense(weighted, n_modes=26, vectors=True, band=None, deviation=lazy)
    assert formed == [] and calls == [False]  # one pass, at the worst case
    exact = springs.checked_dense(weighted, n_modes=26, vectors=True, band=None,
                                  deviation=forming_deviation(weighted, B, w, np.ones(B.shape[1])))
    assert cheap.solver == exact.solver == "accurate-checked"
    moving = exact.eigenvalues > 1e-8 * exact.eigenvalues.max()
    assert np.all(cheap.error[moving] <= 1e-10 * cheap.eigenvalues[moving])  # "high"'s promise, still kept
    assert np.all(np.abs(cheap.eigenvalues - exact.eigenvalues) <= cheap.error + exact.error)  # both bounds hold
    lapack = la.eigh(system.hessian().toarray(), eigvals_only=True, subset_by_index=(0, 25))
    scale = np.abs(lapack).max() * 300 * np.finfo(float).eps
    np.testing.assert_allclose(cheap.eigenvalues, lapack, rtol=0, atol=scale * 10)


def test_springs_over_decades_take_the_exact_deviations(monkeypatch: pytest.MonkeyPatch) -> None:
    """A lattice whose stiffnesses span eight decades: every mode asked, the exact deviations needed, and the answer
    the same as with them formed up front."""
    side, stiffness = 5, (1.0, 1e-4, 1e4)
    index = np.arange(side**3).reshape((side,) * 3)
    rows, cols, values, w = [], [], [], []
    for axis in range(3):
        lines = np.moveaxis(index, axis, 0)
        for i, j in zip(lines[:-1].ravel(), lines[1:].ravel()):
            r = len(w)
            rows += [r, r]
            cols += [3 * i + axis, 3 * j + axis]
            values += [-1.0, 1.0]
            w.append(stiffness[axis])
    B = sp.csr_matrix((values, (rows, cols)), shape=(len(w), 3 * side**3))
    w_arr, mass = np.array(w), np.full(3 * side**3, 1.7)
    weighted = springs.weighted_factor(B, w_arr, mass)
    deviation = forming_deviation(weighted, B, w_arr, mass)
    calls = _counting(monkeypatch)
    lazy = springs.checked_dense(weighted, n_modes=None, vectors=True, band=None, deviation=lambda: deviation)
    assert any(calls)  # some pass had the exact deviations
    eager = springs.checked_dense(weighted, n_modes=None, vectors=True, band=None, deviation=deviation)
    assert lazy.solver == eager.solver
    assert np.all(np.abs(lazy.eigenvalues - eager.eigenvalues) <= lazy.error + eager.error)
    assert np.array_equal(lazy.refined, eager.refined)
