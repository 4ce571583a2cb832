"""The iterative path's lean parts (`vibra.solvers.standard.iterative`, issue 47: 10^6 dofs in 12 GB).

One copy of K~'s entries serves the preconditioner's finest level and LOBPCG's products
(`shifted_blocks`, `Unshifted`); the 3 x 3 block count reads slabs of rows (`ordering.blocked`);
LOBPCG's second Gram-Schmidt and SVQB passes run only where the first lost accuracy (`_outside`,
`_orthonormal`). Truth from outside them: scipy's own sum K~ + sigma I and product, the block count
of a COO-to-CSR conversion of the block indices (scipy's duplicate summing), and the definitions
(B^T V = 0, V^T V = I) to a bound stated per test.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from helpers.assemblies import synthetic_assembly
from vibra import networks
from vibra.solvers.standard import iterative, lobpcg, ordering
from vibra.solvers.standard.rows import SiteBlocks, Unshifted, products

EPS = np.finfo(float).eps


def _anm(n_sites: int, seed: int = 0) -> sp.csr_matrix:
    rng = np.random.default_rng(seed)
    positions = rng.uniform(0.0, (n_sites / 0.05) ** (1 / 3), size=(n_sites, 3))
    return sp.csr_matrix(networks.anm(positions, cutoff=8.5).hessian())


def _blocks_by_scipy(pattern: sp.spmatrix, b: int) -> bool:
    """The rule as a whole-matrix count: scipy sums duplicate block indices into one entry each."""
    coo = sp.coo_matrix(pattern)
    tiles = sp.csr_matrix((np.ones(coo.nnz), (coo.row // b, coo.col // b)),
                          shape=(pattern.shape[0] // b, pattern.shape[1] // b))
    return bool(tiles.nnz * b * b <= 1.5 * max(coo.nnz, 1))


@pytest.mark.parametrize("slab", [1, 7, 1 << 22])
def test_blocked_counts_as_the_whole_matrix(monkeypatch, slab):
    """Slabs of any size (one block row at least) give the whole matrix's verdict, on random
    patterns of every density, on block patterns (kron with a full 3 x 3) and on rows whose column
    indices are not sorted (a user's CSR need not be canonical)."""
    monkeypatch.setattr(ordering, "SLAB", slab)
    rng = np.random.default_rng(11)
    for trial in range(60):
        n, m = 6 * int(rng.integers(1, 12)), 6 * int(rng.integers(1, 12))
        pattern = sp.random(n, m, density=float(rng.uniform(0.0, 1.0)), random_state=trial, format="csr")
        if trial % 3 == 0:
            pattern = sp.kron(sp.random(n // 3, m // 3, density=0.3, random_state=trial), np.ones((3, 3))).tocsr()
        if trial % 4 == 0:  # each row's entries reversed: unsorted indices
            for row in range(n):
                part = slice(pattern.indptr[row], pattern.indptr[row + 1])
                pattern.indices[part], pattern.data[part] = pattern.indices[part][::-1], pattern.data[part][::-1]
            pattern.has_sorted_indices = False
        for b in (1, 2, 3):
            assert ordering.blocked(pattern, b) == _blocks_by_scipy(pattern, b), (trial, b)


def test_shifted_blocks_is_the_sum_in_site_blocks():
    """K~ + sigma I in 3 x 3 blocks, equal entry for entry to scipy's own sum; K~ left as it was."""
    Kt = _anm(300)
    before = Kt.copy()
    shift = 1e-4 * float(abs(Kt).sum(axis=1).max())
    tiled = iterative.shifted_blocks(Kt, shift)
    assert isinstance(tiled, sp.bsr_matrix) and tiled.blocksize == (3, 3)
    assert abs(tiled - (Kt + shift * sp.identity(Kt.shape[0]))).max() == 0.0
    assert abs(Kt - before).max() == 0.0 and Kt.nnz == before.nnz


def test_shifted_blocks_without_a_sites_own_block_or_sites():
    """A site with no spring has no diagonal block to shift: the sum is made in CSR (its dofs must be
    shifted all the same) and returned in blocks, so that the rest of the path stays on one copy; a
    matrix not in sites of three is summed in CSR."""
    Kt = _anm(60).tolil()
    Kt[:3, :] = 0.0
    Kt[:, :3] = 0.0
    Kt = sp.csr_matrix(Kt)
    Kt.eliminate_zeros()
    shifted = iterative.shifted_blocks(Kt, 0.5)
    assert isinstance(shifted, sp.bsr_matrix) and shifted.blocksize == (3, 3)
    assert np.allclose(shifted.diagonal()[:3], 0.5)
    assert abs(shifted - (Kt + 0.5 * sp.identity(Kt.shape[0]))).max() == 0.0
    chain = sp.diags([-np.ones(9), 2 * np.ones(10), -np.ones(9)], [-1, 0, 1], format="csr")
    assert isinstance(iterative.shifted_blocks(chain, 0.25), sp.csr_matrix)


def test_unshifted_product_is_the_matrix_product():
    """(K~ + sigma I) X - sigma X against scipy's K~ X: the difference is rounding of the shifted
    sum, at most a few eps (||K~||_inf + sigma) per entry's row sum (bound 8 eps ||K~||_inf ||X||_max)."""
    Kt = _anm(400, seed=2)
    norm = float(abs(Kt).sum(axis=1).max())
    shift = 1e-4 * norm
    product = Unshifted(products(iterative.shifted_blocks(Kt, shift)), shift)
    assert isinstance(product.product, SiteBlocks) and product.shape == Kt.shape and product.nnz > Kt.nnz // 2
    X = np.random.default_rng(0).standard_normal((Kt.shape[0], 5))
    assert np.abs(product @ X - Kt @ X).max() <= 8 * EPS * norm * np.abs(X).max()


def test_outside_removes_the_basis_with_one_pass_or_two():
    """V's columns leave the orthonormal basis B to B^T V <= 10 eps ||V||, both for columns far from
    span(B) (one pass) and for columns 1e-10 from it (the second pass, without which B^T V stays ~1e-7
    of what is left: cancellation), and V is overwritten in place."""
    rng = np.random.default_rng(4)
    n = 2_000
    B = np.linalg.qr(rng.standard_normal((n, 6)))[0]
    far = rng.standard_normal((n, 3))
    near = B @ rng.standard_normal((6, 3)) + 1e-10 * rng.standard_normal((n, 3))
    V = np.column_stack([far, near])
    norms = np.linalg.norm(V, axis=0)
    out = lobpcg._outside(V, B)
    assert out is V
    left = np.linalg.norm(out, axis=0)
    assert np.all(np.abs(B.T @ out) <= 10 * EPS * left)
    assert np.all(left[3:] < 1e-8 * norms[3:])  # (the near columns were mostly in span(B))


@pytest.mark.parametrize("condition", [1e1, 1e6, 1e12])
def test_orthonormal_to_rounding_whatever_the_condition(condition):
    """SVQB once where V's Gram condition is under `SVQB_CONDITION`, twice above: the result is
    orthonormal to 1e-13 either way, and spans V (the projection of V on it returns V to 1e-9 of
    its norm where no direction was dropped)."""
    rng = np.random.default_rng(5)
    n, m = 3_000, 12
    left = np.linalg.qr(rng.standard_normal((n, m)))[0]
    right = np.linalg.qr(rng.standard_normal((m, m)))[0]
    V = (left * np.geomspace(1.0, 1.0 / np.sqrt(condition), m)) @ right
    original = V.copy()
    Q = lobpcg._orthonormal(V)
    assert Q.shape == (n, m)
    assert np.abs(Q.T @ Q - np.eye(m)).max() <= 1e-13
    assert np.linalg.norm(original - Q @ (Q.T @ original)) <= 1e-9 * np.linalg.norm(original)


def test_block_inverse_reads_blocks_as_they_are():
    """The 3 x 3 diagonal blocks' inverses from a BSR matrix equal those from its CSR form, and a
    missing diagonal block gives a zero inverse (pinv of zero)."""
    Kt = _anm(200, seed=6)
    shifted = iterative.shifted_blocks(Kt, 1.0)
    from_blocks = iterative._block_inverse(shifted, 3)
    from_rows = iterative._block_inverse(sp.csr_matrix(shifted), 3)
    assert np.allclose(from_blocks, from_rows, rtol=1e-12, atol=0.0)
    empty = sp.bsr_matrix((np.ones((1, 3, 3)), np.array([1]), np.array([0, 1, 1])), shape=(6, 6))
    inverse = iterative._block_inverse(empty, 3)
    assert np.all(inverse == 0.0)


def test_shifted_blocks_in_double_and_never_in_place():
    """An integer or single-precision K~ is shifted in a double-precision copy (in single, the shift
    would perturb the operator by ~1e-8 ||K~||, the accepted residual), and a K~ given in 3 x 3 blocks
    already is left as it was (scipy's tobsr returns the same object there)."""
    Kt = _anm(100, seed=7)
    exact = Kt + 0.5 * sp.identity(Kt.shape[0])
    as_single = iterative.shifted_blocks(Kt.astype(np.float32), 0.5)
    assert as_single.dtype == np.float64
    assert abs(as_single - (Kt.astype(np.float32).astype(np.float64) + 0.5 * sp.identity(Kt.shape[0]))).max() == 0.0
    integer = sp.csr_matrix(np.rint(Kt.toarray()).astype(np.int64))
    assert abs(iterative.shifted_blocks(integer, 0.5) - (integer + 0.5 * sp.identity(Kt.shape[0]))).max() == 0.0
    blocks = Kt.tobsr(blocksize=(3, 3))
    before = blocks.data.copy()
    shifted = iterative.shifted_blocks(blocks, 0.5)
    assert np.array_equal(blocks.data, before) and abs(shifted - exact).max() <= 1e-12 * abs(exact).max()


def test_block_lobpcg_in_double_with_a_single_precision_preconditioner():
    """A preconditioner that answers in single precision (as `BlockMultigrid` computes) does not pull
    the iteration into single: the block stays orthonormal to 1e-12 and outside its constraints, and
    the wanted values are LAPACK's to the tolerance."""
    rng = np.random.default_rng(8)
    n = 300
    diagonal = np.concatenate([np.zeros(2), np.arange(1.0, 9.0), np.linspace(20.0, 60.0, n - 10)])
    basis = np.linalg.qr(rng.standard_normal((n, n)))[0]
    A = sp.csr_matrix((basis * diagonal) @ basis.T)
    norm = float(abs(A).sum(axis=1).max())
    solve = np.linalg.inv(A.toarray() + 0.5 * np.eye(n)).astype(np.float32)
    start = rng.standard_normal((n, 12)).astype(np.float32)
    X, iterations = lobpcg.block_lobpcg(A, lambda R: solve @ R.astype(np.float32), basis[:, :2], start, 6,
                                           1e-9 * norm, 300)
    values = np.einsum("ij,ij->j", X, A @ X)
    assert X.dtype == np.float64 and iterations < 300
    assert np.abs(X.T @ X - np.eye(X.shape[1])).max() <= 1e-12
    assert np.abs(basis[:, :2].T @ X).max() <= 1e-12
    assert np.allclose(values[:6], diagonal[2:8], rtol=0, atol=1e-8 * norm)


def test_orthonormal_drops_a_column_of_nothing():
    """A zero column, or one of not-a-number (a preconditioner's overflow), is dropped, not spread."""
    rng = np.random.default_rng(9)
    V = rng.standard_normal((500, 5))
    V[:, 1] = 0.0
    V[:, 3] = np.nan
    Q = lobpcg._orthonormal(V)
    assert Q.shape == (500, 3) and np.isfinite(Q).all()
    assert np.abs(Q.T @ Q - np.eye(3)).max() <= 1e-13
    V = rng.standard_normal((500, 4))
    V[:, 2] = np.nan  # (alone: no zero column beside it)
    assert lobpcg._orthonormal(V).shape == (500, 3)


def test_blocked_with_a_partial_last_block_column(monkeypatch):
    """Columns not a multiple of b: the last, partial, block column is a block of its own (two rows'
    entries in different block columns never share a block)."""
    monkeypatch.setattr(ordering, "SLAB", 5)
    rng = np.random.default_rng(10)
    for trial in range(40):
        n, m = 3 * int(rng.integers(1, 8)), int(rng.integers(1, 25))
        pattern = sp.random(n, m, density=float(rng.uniform(0.05, 1.0)), random_state=trial, format="csr")
        coo = pattern.tocoo()
        tiles = sp.csr_matrix((np.ones(coo.nnz), (coo.row // 3, coo.col // 3)), shape=(n // 3, -(-m // 3)))
        assert ordering.blocked(pattern, 3) == bool(tiles.nnz * 9 <= 1.5 * max(coo.nnz, 1)), trial


def test_high_stops_lobpcg_tighter_than_fast(monkeypatch):
    """"High" hands LOBPCG's vectors to the spring-space Rayleigh-Ritz, whose bounds go as the residual
    squared: `runners.accurate_iterative` asks `RITZ_TOLERANCE` (under "fast"'s `TOLERANCE`), and the
    iterative path itself reaches the residual it is asked for (measured here, not taken from it)."""
    from vibra.solvers import registry, runners

    assert iterative.RITZ_TOLERANCE < iterative.TOLERANCE
    asked: list[float] = []
    real = runners.lowest_modes
    monkeypatch.setattr(runners, "lowest_modes", lambda *a, **k: asked.append(k.get("tolerance")) or real(*a, **k))
    monkeypatch.setattr(registry, "SPARSE_FACTOR_S", 1.0)  # (the factorisation priced out: the plan takes the iteration)
    rng = np.random.default_rng(12)
    positions = rng.uniform(0.0, (4_000 / 0.05) ** (1 / 3), size=(4_000, 3))
    system = networks.anm(positions, cutoff=8.5)
    modes = system.modes(8, accuracy="high", max_seconds=float("inf"), max_memory=float("inf"))
    assert asked == [iterative.RITZ_TOLERANCE] and modes.path == "accurate-iterative"
    Kt = _anm(1_000, seed=13)
    norm = float(abs(Kt).sum(axis=1).max())
    for tolerance in (iterative.TOLERANCE, iterative.RITZ_TOLERANCE):
        result = iterative.lowest_modes(Kt, 10, tolerance=tolerance)
        residuals = np.linalg.norm(Kt @ result.vectors - result.vectors * result.eigenvalues, axis=0)
        assert residuals.max() <= tolerance * norm


def test_high_bounds_meet_their_target_against_shift_invert(monkeypatch):
    """"High" on the iterative path keeps its promise on an assembly's cluster (9,000 dofs: with LOBPCG
    stopped at 1e-9, 13 of the 14 moving modes missed 1e-10, up to 3.2e-8; bounds ~ residual^2 / gap):
    every moving mode's relative bound within `TARGET`, and each value within its bound of scipy's
    shift-invert `eigsh` (SuperLU, tol 0), whose own error is at most its residual (Weyl)."""
    import scipy.sparse.linalg as sla

    from vibra.solvers import registry
    from vibra.solvers.accurate.spring_ritz import TARGET

    monkeypatch.setattr(registry, "SPARSE_FACTOR_S", 1.0)  # (the plan takes the iteration)
    monkeypatch.setattr(registry, "ITERATIVE_FROM", 0)
    system = synthetic_assembly(3_000)
    modes = system.modes(20, accuracy="high", max_seconds=float("inf"), max_memory=float("inf"))
    assert modes.path == "accurate-iterative" and "above" not in (modes.refinement or "")
    K = sp.csr_matrix(system.hessian())
    norm = float(abs(K).sum(axis=1).max())
    values, vectors = sla.eigsh(K.tocsc(), k=20, sigma=-1e-4 * norm, which="LM", tol=0.0)
    order = np.argsort(values)
    values, vectors = values[order], vectors[:, order]
    weyl = np.linalg.norm(K @ vectors - vectors * values, axis=0)
    squared = modes.omega_squared
    bound = 2 * np.abs(modes.omega) * modes.omega_error + modes.omega_error ** 2  # |omega^2 - omega_true^2|
    moving = squared > 1e-6 * norm  # (the six rigid-body modes: zero, within their own absolute bounds)
    assert np.count_nonzero(moving) == 14
    assert np.all(bound[moving] <= 1.01 * TARGET * squared[moving])  # (1 % for the omega <-> omega^2 conversion)
    assert np.all(np.abs(squared - values) <= bound + weyl)


def test_unit_masses_share_K_and_no_path_writes_it(monkeypatch):
    """With unit masses a canonical CSR K is its own K~: `solve` hands it on without a second copy of its
    entries (2 GB at 10^6 dofs), so no path may write it: K's arrays are made read-only (any write
    raises) and the factorisation and the iteration run at "fast" and "high". The public
    `mass_weighted` still returns a new matrix unless asked to share."""
    from vibra import normal_modes
    from vibra.solvers import registry
    from vibra.solvers.common import mass_weighted

    rng = np.random.default_rng(22)
    positions = rng.uniform(0.0, (800 / 0.05) ** (1 / 3), size=(800, 3))
    system = networks.anm(positions, cutoff=8.5)
    K = sp.csr_matrix(system.hessian())
    ones = np.ones(K.shape[0])
    assert np.shares_memory(mass_weighted(K, ones, share=True).data, K.data)
    assert not np.shares_memory(mass_weighted(K, ones).data, K.data)  # (the public default: a copy)
    assert not np.shares_memory(mass_weighted(K, np.full(K.shape[0], 2.0), share=True).data, K.data)
    unsorted = K.copy()
    unsorted.has_canonical_format = False  # (as scipy marks a matrix it has not checked)
    assert not np.shares_memory(mass_weighted(unsorted, ones, share=True).data, unsorted.data)
    for array in (K.data, K.indices, K.indptr):
        array.flags.writeable = False
    taken = set()
    for factor_s in (None, 1.0):
        if factor_s is not None:
            monkeypatch.setattr(registry, "SPARSE_FACTOR_S", factor_s)
            monkeypatch.setattr(registry, "ITERATIVE_FROM", 0)
        for accuracy in ("fast", "high"):
            modes = normal_modes(K, ones, n_modes=10, accuracy=accuracy, spring_factor=system.spring_factor(),
                                 positions=system.positions, max_seconds=float("inf"), max_memory=float("inf"))
            taken.add(modes.path)
    assert taken == {"sparse", "accurate-ritz", "iterative", "accurate-iterative"}
