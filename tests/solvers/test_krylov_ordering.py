"""Block Krylov iteration and nested-dissection ordering of the sparse path (issue 14, item 2).

Truth: numpy's dense eigh of the same matrices, permutation invariants, and SuperLU's fill
with SuperLU's own minimum-degree ordering as the yardstick.
"""

from __future__ import annotations

import builtins
from typing import Any

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from vibra import networks
from vibra.solvers.standard import cholmod, krylov, ordering, pardiso, sparse
from vibra.solvers.standard.ordering import nested_dissection
from vibra.solvers.standard.sparse import ShiftedInverse, lowest_shift, semidefinite_rounding, shift_invert, sparse_path


def _lattice(n_sites: int, seed: int = 3, cutoff: float = 1.75) -> Any:
    rng = np.random.default_rng(seed)
    side = int(np.ceil(n_sites ** (1 / 3)))
    grid = np.stack(np.meshgrid(*(np.arange(side),) * 3, indexing="ij"), axis=-1).reshape(-1, 3)[:n_sites]
    return networks.anm(grid + rng.uniform(-0.2, 0.2, (n_sites, 3)), cutoff=cutoff)


def test_block_eigs_matches_dense_eigh() -> None:
    rng = np.random.default_rng(0)
    Q = np.linalg.qr(rng.standard_normal((300, 300)))[0]
    values = np.geomspace(1e-3, 1e3, 300)
    A = (Q * values) @ Q.T
    mu, Y, applied, done = krylov.block_eigs(lambda X: A @ X, 300, 10, tol=1e-13)
    assert done and applied <= 300
    np.testing.assert_allclose(mu, values[::-1][:10], rtol=1e-12)
    assert np.linalg.norm(A @ Y - Y * mu) <= 1e-10 * values.max()
    assert np.abs(Y.T @ Y - np.eye(10)).max() < 1e-13


@pytest.mark.parametrize("block", [1, 3, 8])
def test_block_eigs_deflation_keeps_directions_out(block: int) -> None:
    """Deflated directions (a free system's zero modes) never come back; the rest are exact."""
    rng = np.random.default_rng(1)
    Q = np.linalg.qr(rng.standard_normal((200, 200)))[0]
    values = np.r_[np.full(3, 1e12), np.linspace(1.0, 100.0, 197)[::-1]]  # 3 huge (zero modes inverted)
    # applied in factored form, as a factorisation's solve is: the huge values reach the result
    # only through the (rounding-sized) components along Q[:, :3], which the projection removes

    def apply(X: np.ndarray) -> np.ndarray:
        return np.asarray(Q @ (values[:, None] * (Q.T @ X)))

    mu, Y, _, done = krylov.block_eigs(apply, 200, 5, tol=1e-12, deflate=Q[:, :3], block=block)
    assert done
    np.testing.assert_allclose(mu, values[3:8], rtol=1e-11)
    assert np.abs(Q[:, :3].T @ Y).max() < 1e-12


def _operator(top: list[float], rest: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A 400 x 400 operator with the given largest values, the others log-spaced from `rest`
    down to 0.01 (F favours the wanted ones only mildly), and those values as an array."""
    rng = np.random.default_rng(seed)
    Q = np.linalg.qr(rng.standard_normal((400, 400)))[0]
    wanted = np.asarray(top, dtype=float)
    values = np.r_[wanted, np.geomspace(rest, 0.01, 400 - wanted.size)]
    return (Q * values) @ Q.T, wanted


def test_block_eigs_widening_finds_every_copy_of_an_eightfold_value() -> None:
    """A block narrower than a value's multiplicity holds its other copies only as rounding
    seeds them: one column loses some copies of an 8-fold value (measured: every seed), and
    `widen` (a cluster as wide as the block: again, wider) finds every copy, to the tolerance."""
    lost = 0
    for seed in range(4):
        A, top = _operator([10.0, 10.0, *[9.0] * 8, 8.5, 8.5, 8.5, 8.2], 3.0, seed)
        mu, _, _, _ = krylov.block_eigs(lambda X: A @ X, 400, top.size, tol=1e-13, block=1)
        lost += not np.allclose(mu, top, rtol=1e-10)
        for block in (1, 2):
            mu, Y, _, done = krylov.block_eigs(lambda X: A @ X, 400, top.size, tol=1e-13, block=block, widen=True)
            assert done
            np.testing.assert_allclose(mu, top, rtol=1e-13)  # (a lost copy moves a value by >= 3%)
            assert np.linalg.norm(A @ Y - Y * mu) <= 1e-11 * 10.0
    assert lost >= 1  # (the mechanism is needed)


def test_block_eigs_two_columns_keep_a_double_value_one_column_loses() -> None:
    """Why the sparse path's block has two columns: one column may hold a single copy of a
    double value at the top of the wanted window, and nothing then shows a cluster that
    widening could act on (measured on 25 of 25 seeds; widening from one column on every
    run would double its cost); two columns hold both copies."""
    lost = 0
    for seed in range(4):
        A, top = _operator([10.0, 9.5, 9.0, 8.5, 8.2, 8.2], 8.15, seed)
        mu, _, _, _ = krylov.block_eigs(lambda X: A @ X, 400, top.size, tol=1e-13, block=1)
        lost += not np.allclose(mu, top, rtol=1e-10) and krylov.largest_cluster(mu) == 1
        mu, _, _, done = krylov.block_eigs(lambda X: A @ X, 400, top.size, tol=1e-13, block=2, widen=True,
                                           max_dim=400)
        assert done
        np.testing.assert_allclose(mu, top, rtol=1e-12)  # (a lost copy: 8.15 for 8.2)
    assert lost >= 1
    assert sparse.BLOCK_LOWEST >= 2


def test_largest_cluster_counts_chains_of_equal_values() -> None:
    assert krylov.largest_cluster(np.array([5.0, 4.0, 3.0])) == 1
    assert krylov.largest_cluster(np.array([5.0, 5.0 * (1 + 3e-9), 5.0 * (1 + 6e-9), 1.0])) == 3
    assert krylov.largest_cluster(np.array([5.0, 5.0 * (1 + 1e-6)])) == 1
    assert krylov.largest_cluster(np.zeros(0)) == 0


def test_symmetric_lattice_keeps_its_triple_values() -> None:
    """A simple-cubic lattice (3,000 dofs, springs to 2.3 spacings: an expensive factor, the
    one-column block Krylov path): its cubic symmetry makes most low values double or triple;
    each level gives every copy, against numpy's dense eigvalsh (1e-10: the levels' promise is
    tighter; a lost copy moves the next value by over 5%)."""
    side = 10
    grid = np.stack(np.meshgrid(*(np.arange(side),) * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    system = networks.anm(grid.astype(float), cutoff=2.3)
    K = sp.csr_matrix(system.hessian())
    assert ShiftedInverse(K, -1e-9, need_inertia=False).fill >= sparse.BLOCK_FILL
    reference = np.linalg.eigvalsh(K.toarray())[:40]
    assert np.sum(np.isclose(reference[6:39], reference[7:40], rtol=1e-12)) >= 15  # many copies
    for accuracy in ("fast", "high"):
        modes = system.modes(40, accuracy=accuracy, vectors=False)
        np.testing.assert_allclose(modes.omega_squared[6:], reference[6:], rtol=1e-10)


def test_block_eigs_reports_no_convergence() -> None:
    rng = np.random.default_rng(2)
    A = np.diag(1.0 + 1e-9 * rng.random(400))  # one tight cluster: not resolved in 20 columns
    _, _, applied, done = krylov.block_eigs(lambda X: A @ X, 400, 10, tol=1e-15, max_dim=20)
    assert not done and applied == 20


def test_nested_dissection_is_a_site_permutation() -> None:
    system = _lattice(1200)
    K = sp.csr_matrix(system.hessian())
    assert ordering.site_block(K) == 3
    p = ordering.nested_dissection(K)
    assert p is not None
    assert np.array_equal(np.sort(p), np.arange(K.shape[0]))
    assert np.array_equal(p.reshape(-1, 3) % 3, np.tile(np.arange(3), (K.shape[0] // 3, 1)))  # sites stay whole


def test_site_block_of_scalar_and_chain_patterns() -> None:
    chain = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(30, 30), format="csr")
    assert ordering.site_block(chain) == 1
    assert ordering.nested_dissection(chain) is None  # small: SuperLU's own ordering


def test_dissection_fills_less_than_minimum_degree() -> None:
    """The reason for the ordering: fewer factor entries than SuperLU's best own ordering."""
    K = sp.csr_matrix(_lattice(1500).hessian())
    A = (K + 1e-9 * sp.identity(K.shape[0])).tocsr()
    p = ordering.nested_dissection(A)
    assert p is not None
    options = {"SymmetricMode": True}
    nd = sla.splu(A[p][:, p].tocsc(), permc_spec="NATURAL", diag_pivot_thresh=0.0, options=options)
    mmd = sla.splu(A.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options=options)
    assert nd.L.nnz + nd.U.nnz < 0.8 * (mmd.L.nnz + mmd.U.nnz)


def test_without_pymetis_minimum_degree_serves(monkeypatch: pytest.MonkeyPatch) -> None:
    real_import = builtins.__import__

    def no_pymetis(name: str, *args: Any, **kwargs: Any) -> Any:
        if name == "pymetis":
            raise ImportError("pymetis hidden by the test")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_pymetis)
    K = sp.csr_matrix(_lattice(1200).hessian())
    assert ordering.nested_dissection(K) is None
    factor = ShiftedInverse(K, -1e-9)
    b = np.random.default_rng(0).standard_normal(K.shape[0])
    x = factor.solve(b)
    assert np.linalg.norm((K - 1e-9 * sp.identity(K.shape[0])) @ x - b) < 1e-6 * np.linalg.norm(b) * 1e9


def test_permuted_factor_solves_blocks() -> None:
    K = sp.csr_matrix(_lattice(1200).hessian())
    A = K + 0.5 * sp.identity(K.shape[0])
    factor = ShiftedInverse(K, -0.5)
    assert factor.below_spectrum
    B = np.random.default_rng(4).standard_normal((K.shape[0], 5))
    X = factor.solve(B)
    assert np.linalg.norm(A @ X - B) <= 1e-12 * np.linalg.norm(B)
    np.testing.assert_allclose(factor.solve(B[:, 2]), X[:, 2], rtol=1e-12, atol=1e-14)


def test_large_free_network_lowest_modes_match_dense() -> None:
    """3,600 dofs (nested dissection on): 6 zero modes, then the lowest 20 to 1e-12 of eigh."""
    system = _lattice(1200)
    K = system.hessian()
    reference = np.linalg.eigvalsh(K.toarray() if sp.issparse(K) else K)
    fast = system.modes(26, accuracy="fast")
    high = system.modes(26)
    assert fast.solver == "sparse" and high.solver == "accurate-ritz"
    for modes in (fast, high):
        omega2 = modes.omega_squared
        assert np.all(np.abs(omega2[:6]) <= 1e-10 * reference[-1])
        np.testing.assert_allclose(omega2[6:], reference[6:26], rtol=1e-12)
        assert modes.residual < 1e-13


def test_anchored_network_has_no_zero_probe() -> None:
    system = _lattice(1100)
    frozen = system.freeze([0, 1, 2])
    K = frozen.hessian()
    spectrum = np.linalg.eigvalsh(K.toarray() if sp.issparse(K) else K)
    reference = spectrum[:12]
    modes = frozen.modes(12, accuracy="fast")
    # eigvalsh is accurate to ~n eps ||K|| absolute (the lowest here is 6e-7, nearly floppy)
    norm = float(spectrum[-1])
    np.testing.assert_allclose(modes.omega_squared, reference, rtol=1e-11, atol=K.shape[0] * 2.3e-16 * norm)


def test_semidefinite_rounding_only_for_nonnegative_springs() -> None:
    system = _lattice(200)
    B, w = system.spring_factor()  # type: ignore[misc]
    bound = semidefinite_rounding((B, w), 10.0)
    assert bound is not None and 0 < bound < 1e4 * np.finfo(float).eps * 10.0
    assert semidefinite_rounding((B, -w), 10.0) is None
    assert semidefinite_rounding(None, 10.0) is None


def test_shift_known_below_skips_inertia_but_stays_correct() -> None:
    K = sp.csr_matrix(_lattice(1100).hessian())
    norm = float(abs(K).sum(axis=1).max())
    sigma, factor = lowest_shift(K, rounding=1e-3 * 1e4 * np.finfo(float).eps * norm)
    assert factor.below_spectrum and sigma < 0
    values, _ = shift_invert(K, 10, sigma, factor)
    np.testing.assert_allclose(values[6:], np.linalg.eigvalsh(K.toarray())[6:10], rtol=1e-12)


def test_sparse_path_band_still_served() -> None:
    K = sp.csr_matrix(_lattice(400).hessian())
    reference = np.linalg.eigvalsh(K.toarray())
    low, high = np.sqrt(reference[20]) * 0.999, np.sqrt(reference[24]) * 1.001
    result = sparse_path(K, n_modes=None, vectors=False, band=(low, high))
    np.testing.assert_allclose(result.eigenvalues, reference[(reference >= low**2) & (reference <= high**2)],
                               rtol=1e-12)


# ---------------------------------------------------------------------- the PARDISO backend
needs_pardiso = pytest.mark.skipif(not pardiso.pardiso_available(),
                                   reason="pypardiso (MKL PARDISO, the vibra[pardiso] extra) is not installed here")


@needs_pardiso
def test_pardiso_cholesky_solves_and_refuses_indefinite() -> None:
    K = sp.csr_matrix(_lattice(1100).hessian())
    A = (K + 1e-3 * sp.identity(K.shape[0])).tocsr()
    factor = pardiso.PardisoCholesky(A)
    B = np.random.default_rng(5).standard_normal((K.shape[0], 3))
    # no iterative refinement: backward stable to ~ cond eps (cond ~ ||K|| / 1e-3 here)
    assert np.linalg.norm(A @ factor.solve(B) - B) <= 1e-9 * np.linalg.norm(B)
    factor.close()
    factor.close()  # twice is harmless
    with pytest.raises(ValueError, match="not positive definite"):
        pardiso.PardisoCholesky((K - 0.05 * sp.identity(K.shape[0])).tocsr())


@needs_pardiso
@pytest.mark.parametrize("n_sites", [400, 1000])
def test_pardiso_orders_by_minimum_degree_below_dissection_min(n_sites: int) -> None:
    """PARDISO's ordering (iparm(2)) by size: minimum degree (0) below `ordering.DISSECTION_MIN` dofs, its default nested
    dissection from there (1,200 and 3,000 dofs here), the solves checked against SuperLU's on the same matrix."""
    K = sp.csr_matrix(_lattice(n_sites).hessian())
    A = (K + 1e-3 * sp.identity(K.shape[0])).tocsr()
    factor = pardiso.PardisoCholesky(A)
    assert (factor._solver.iparm[1] == 0) == (K.shape[0] < ordering.DISSECTION_MIN)
    assert factor.factor_entries > K.nnz // 2  # (PARDISO reported its factor: iparm(18) asked)
    B = np.random.default_rng(6).standard_normal((K.shape[0], 3))
    reference = sla.splu(A.tocsc()).solve(B)
    assert np.linalg.norm(factor.solve(B) - reference) <= 1e-9 * np.linalg.norm(reference)
    factor.close()


@needs_pardiso
def test_pardiso_indefinite_shift_falls_back_to_superlu_inertia(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(pardiso, "BACKEND", "auto")
    K = sp.csr_matrix(_lattice(1100).hessian())
    reference = np.linalg.eigvalsh(K.toarray())
    factor = ShiftedInverse(K, float(reference[40]))  # 40 eigenvalues below the shift
    assert factor.backend == "superlu" and not factor.below_spectrum


def test_backend_setting_is_checked(monkeypatch: pytest.MonkeyPatch) -> None:
    K = sp.csr_matrix(_lattice(1100).hessian())
    monkeypatch.setattr(pardiso, "BACKEND", "mumps")
    with pytest.raises(ValueError, match=r"BACKEND \(or VIBRA_SPARSE_BACKEND\) is 'mumps'; expected 'auto', "
                                         r"'superlu', 'cholmod' or 'pardiso'"):
        ShiftedInverse(K, -1e-9)
    monkeypatch.setattr(pardiso, "BACKEND", "pardiso")
    monkeypatch.setattr(pardiso, "_AVAILABLE", False)
    with pytest.raises(ImportError, match=r"pip install \"vibra\[pardiso\]\""):
        ShiftedInverse(K, -1e-9)
    monkeypatch.setattr(pardiso, "BACKEND", "auto")
    assert ShiftedInverse(K, -1e-9).backend == "cholmod"  # auto without PARDISO: CHOLMOD (cvxopt)
    monkeypatch.setattr(cholmod, "_AVAILABLE", False)
    assert ShiftedInverse(K, -1e-9).backend == "superlu"  # neither: SuperLU
    monkeypatch.setattr(pardiso, "BACKEND", "cholmod")
    with pytest.raises(ImportError, match=r"'cholmod' needs cvxopt"):
        ShiftedInverse(K, -1e-9)


@pytest.mark.parametrize("backend", ["cholmod", "auto"])
def test_a_sparse_cholesky_from_its_threshold_in_cholmods_own_order(backend: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """From `ordering.CHOLESKY_FROM` (600) dofs a sparse Cholesky factorises K~ - sigma I (CHOLMOD in its own AMD order
    below `DISSECTION_MIN`: a base install's path; PARDISO where installed), SuperLU's LU below; its solves are checked
    against SuperLU's on the same shifted matrix, and an indefinite shift still falls back to SuperLU's inertia."""
    monkeypatch.setattr(pardiso, "BACKEND", backend)
    if backend == "cholmod" and not cholmod.cholmod_available():
        pytest.skip("cvxopt's CHOLMOD is not importable here")
    K = sp.csr_matrix(_lattice(ordering.CHOLESKY_FROM // 3).hessian())  # 600 dofs: the threshold itself
    n = K.shape[0]
    assert ordering.CHOLESKY_FROM == n < ordering.DISSECTION_MIN and nested_dissection(K) is None
    factor = ShiftedInverse(K, -1e-3)
    assert factor.backend in ("cholmod", "pardiso") and factor.below_spectrum
    assert factor.backend == "cholmod" or backend == "auto"
    B = np.random.default_rng(7).standard_normal((n, 4))
    reference = sla.splu((K + 1e-3 * sp.identity(n)).tocsc()).solve(B)
    assert np.linalg.norm(factor.solve(B) - reference) <= 1e-9 * np.linalg.norm(reference)
    values = np.linalg.eigvalsh(K.toarray())
    inside = ShiftedInverse(K, float(values[40]))  # 40 eigenvalues below the shift: no Cholesky
    assert inside.backend == "superlu" and not inside.below_spectrum
    smaller = sp.csr_matrix(K[:-3, :-3])  # one site fewer: SuperLU
    assert ShiftedInverse(smaller, -1e-3).backend == "superlu"


# ---------------------------------------------------------------------- the CHOLMOD backend
def test_cholmod_cholesky_solves_and_refuses_indefinite() -> None:
    K = sp.csr_matrix(_lattice(1100).hessian())
    A = (K + 1e-3 * sp.identity(K.shape[0])).tocsr()
    factor = cholmod.CholmodCholesky(A, nested_dissection(A))
    B = np.random.default_rng(5).standard_normal((K.shape[0], 3))
    # backward stable to ~ cond eps (cond ~ ||K|| / 1e-3 here)
    assert np.linalg.norm(A @ factor.solve(B) - B) <= 1e-9 * np.linalg.norm(B)
    assert factor.solve(B[:, 0]).shape == (K.shape[0],)
    with pytest.raises(ValueError, match="not positive definite"):
        cholmod.CholmodCholesky((K - 0.05 * sp.identity(K.shape[0])).tocsr(), None)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_factor_entries_count_the_dense_cholesky_nonzeros(seed: int) -> None:
    """The elimination-tree count of L's nonzeros equals those of a dense Cholesky (numpy) of
    the same matrix in the same order (random values: no entry cancels by chance)."""
    rng = np.random.default_rng(seed)
    A = sp.random(120, 120, density=0.03, random_state=seed)
    A = (A + A.T + 20 * sp.identity(120)).tocsr()
    order = rng.permutation(120)
    L = np.linalg.cholesky(A.toarray()[np.ix_(order, order)])
    assert cholmod.factor_entries(A, order) == np.count_nonzero(L)


@pytest.mark.parametrize("backend", ["cholmod", pytest.param("pardiso", marks=needs_pardiso)])
def test_backends_agree_on_the_lowest_modes(monkeypatch: pytest.MonkeyPatch, backend: str) -> None:
    """A sparse Cholesky (CHOLMOD, PARDISO) and SuperLU's LU give the modes of a dense solve
    (numpy), and each other's to rounding."""
    system = _lattice(1200)
    reference = np.linalg.eigvalsh(system.hessian().toarray())[6:26]
    found = {}
    for name in (backend, "superlu"):
        monkeypatch.setattr(pardiso, "BACKEND", name)
        K = sp.csr_matrix(system.hessian())
        factor = ShiftedInverse(K, -1e-12 * float(abs(K).sum(axis=1).max()))
        assert factor.backend == name and factor.below_spectrum
        found[name] = system.modes(26, accuracy="fast").omega_squared
        np.testing.assert_allclose(found[name][6:], reference, rtol=1e-12)
    np.testing.assert_allclose(found[backend][6:], found["superlu"][6:], rtol=1e-13)


def test_cheap_factor_keeps_arpack_and_its_small_basis(monkeypatch: pytest.MonkeyPatch) -> None:
    """A chain's factor (pttrf, 2 entries a row) runs ARPACK: the block basis (~200 columns of
    10^6 entries each) would cost more than its solves save; a 3-D factor runs the block Krylov."""
    from vibra.chains import linear_chain

    calls: list[str] = []
    monkeypatch.setattr(sparse, "block_eigs", lambda *a, **k: calls.append("block") or krylov.block_eigs(*a, **k))
    chain = linear_chain(3000, ends="fixed")
    omega = chain.modes(n_modes=5, accuracy="fast").omega
    exact = 2.0 * np.sin(np.arange(1, 6) * np.pi / (2 * 3001))  # fixed ends, unit masses and springs
    np.testing.assert_allclose(omega, exact, rtol=1e-11)
    assert calls == []
    K = sp.csr_matrix(_lattice(1200).hessian())
    factor = ShiftedInverse(K, -1e-12 * float(abs(K).sum(axis=1).max()))
    assert factor.fill >= sparse.BLOCK_FILL
    shift_invert(K, 10, -1e-12 * float(abs(K).sum(axis=1).max()), factor)
    assert calls
