"""Chain values in clusters: certified by Sturm counts of the chain's spring form (`chain.sturm_counts`).

A chain's values are certified one by one from their singular triplets (Kato-Temple), which
need a gap; two identical disordered chains joined by a weak spring have every mode in a pair
split by ~the weak spring, far below the a-priori bound that such values kept (up to 9e-12 at
2,000 sites, 2.3e-11 at 10,000, where the true errors are ~1e-15: over 1000 times them).

Truth from outside the code under test: Sturm counts of K~ - x in 40-digit mpmath built from
the masses and springs (`tests/solvers/test_chain_bounds_large.sturm_count`), and a dense eigh for the counts
themselves on small chains.
"""

from __future__ import annotations

import mpmath
import numpy as np
import pytest
import scipy.linalg as la
import scipy.sparse as sp

from vibra import normal_modes
from vibra.chains import linear_chain
from vibra.solvers.accurate.chain import sturm_counts

from helpers.chains import sturm_count
from helpers.rings import sampled


def dimer(half: int, weak: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Masses and the n - 1 springs of a disordered chain and its mirror image joined by `weak`."""
    rng = np.random.default_rng(seed)
    mass, springs = 10.0 ** rng.uniform(0, 1, half), 10.0 ** rng.uniform(0, 1, half - 1)
    return np.r_[mass, mass[::-1]], np.r_[springs, weak, springs[::-1]]


@pytest.mark.parametrize(("half", "weak", "vectors"), [(1000, 1e-8, False), (200, 1e-12, True)])
def test_a_weakly_joined_pair_of_chains_is_certified_mode_by_mode(half: int, weak: float, vectors: bool) -> None:
    """Every nonzero bound within 1e-13 relative (before: up to 9e-12 at 2,000 sites); the lowest,
    loosest and 8 random modes covered by mpmath counts."""
    mass, springs = dimer(half, weak, half)
    modes = linear_chain(2 * half, mass=mass, stiffness=springs, units="dimensionless").modes(vectors=vectors)
    assert modes.solver == "accurate-bidiagonal"
    assert "certified by Sturm counts of the chain's spring form" in modes.refinement
    omega, error = modes.omega, modes.omega_error
    relative = error[1:] / omega[1:]
    assert relative.max() <= 1e-13
    values, value_error = modes.omega_squared, 2 * omega * error + error**2
    for j in sampled(2 * half, np.r_[0.0, relative], np.random.default_rng(3)):
        if j == 0:
            continue
        with mpmath.workdps(40):
            low = mpmath.mpf(float(values[j])) - mpmath.mpf(float(value_error[j])) * (1 + mpmath.mpf(1e-12))
            high = mpmath.mpf(float(values[j])) + mpmath.mpf(float(value_error[j])) * (1 + mpmath.mpf(1e-12))
        assert sturm_count(mass, springs, (0.0, 0.0), low) <= j < sturm_count(mass, springs, (0.0, 0.0), high), j


@pytest.mark.parametrize("ends", ["free", "fixed"])
def test_path_counts_agree_with_a_dense_solve(ends: str) -> None:
    """The spring form of one chain (free or with springs to walls at both ends) and of two
    separate chains at once: counts at points between the eigenvalues of a dense eigh."""
    rng = np.random.default_rng(5)
    for n in (2, 3, 7, 40):
        mass, springs = 10.0 ** rng.uniform(0, 2, n), 10.0 ** rng.uniform(0, 2, n + 1)
        chain = linear_chain(n, mass=mass, stiffness=springs if ends == "fixed" else springs[: n - 1], ends=ends,
                             units="dimensionless")
        B, w = chain.spring_factor()
        two = sp.block_diag([B, B]).tocsr()  # two copies: their spring form joined by a zero coupling
        for coupling, weights, masses in ((B, w, mass), (two, np.r_[w, w], np.r_[mass, mass])):
            form = sturm_counts.chain_form(coupling, weights, masses)
            assert form is not None
            K = (coupling.T @ sp.diags(weights) @ coupling).toarray()
            values = la.eigh(K, np.diag(masses), eigvals_only=True)
            if ends == "free":
                values[: 2 if masses.shape[0] > n else 1] = 0.0  # the rigid modes are exactly 0
            points = np.unique(np.r_[0.5 * (values[:-1] + values[1:]), 2 * values[-1], 1e-3 * values[-1]])
            points = points[np.min(np.abs(points[:, None] - values[None, :]), axis=1) > 1e-8 * values[-1]]
            count, certain = form.counts(points)
            assert certain.all()
            assert np.array_equal(count, np.searchsorted(values, points)), (n, ends)


def test_path_form_refuses_what_is_not_a_path() -> None:
    """A ring, a branched network and a full mass matrix give no path form."""
    ring = linear_chain(6, ends="periodic")
    assert sturm_counts.chain_form(*ring.spring_factor(), np.ones(6)) is None
    star = sp.csr_matrix(np.array([[1.0, -1.0, 0, 0], [1.0, 0, -1.0, 0], [1.0, 0, 0, -1.0]]))
    assert sturm_counts.chain_form(star, np.ones(3), np.ones(4)) is None
    chain = linear_chain(4)
    assert sturm_counts.chain_form(*chain.spring_factor(), np.eye(4)) is None


def test_a_chain_given_as_its_spring_factor_gets_the_same_certificates() -> None:
    """`normal_modes` with the spring factor of the dimer chain: the same bounds as the builder's."""
    mass, springs = dimer(100, 1e-10, 2)
    chain = linear_chain(200, mass=mass, stiffness=springs, units="dimensionless")
    B, w = chain.spring_factor()
    K = chain.hessian()
    modes = normal_modes(K, mass, spring_factor=(B, w), vectors=False)
    assert modes.solver == "accurate-bidiagonal"
    assert np.all(modes.omega_error[1:] <= 1e-13 * modes.omega[1:])
