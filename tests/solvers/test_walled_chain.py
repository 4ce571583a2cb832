"""``accurate-walled``: chains with springs to a wall at their sites (a chain of pendulums, a string
on an elastic foundation, a chain pinned inside).

Before, such a chain was no path for the chain solvers and "high" took the checked dense solve
(15.7 s at 5,000 sites). Truth from outside the code under test: the closed form of the uniform
chain on walls (free ends), omega_j^2 = (g + 4 k sin^2(pi j / 2n)) / m in 30-digit mpmath;
eigenvalues of K~ formed in 80-digit mpmath from the inputs (`mpmath.eigsy`); Sylvester
inertia counts of K - x M in mpmath (`chain_count`, checked against a dense solve) for long
disordered chains.
"""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pytest
import scipy.linalg as la
import scipy.sparse as sp

from vibra import System, normal_modes
from vibra.solvers.accurate.chain import walled

from helpers.rings import certified_by_eigsy


def chain_on_walls(n: int, spread: float, seed: int, walls: int | None = None
                   ) -> tuple[sp.csr_matrix, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(B, w, mass, springs, ground): n sites, springs i-(i+1), a spring to a wall at every site
    (walls None) or at `walls` random sites; masses and springs log-uniform over 10^spread."""
    rng = np.random.default_rng(seed)
    springs = 10.0 ** rng.uniform(-spread / 2, spread / 2, n - 1)
    mass = 10.0 ** rng.uniform(-spread / 2, spread / 2, n)
    where = np.arange(n) if walls is None else np.sort(rng.choice(np.arange(1, n - 1), walls, replace=False))
    ground = np.zeros(n)
    ground[where] = 10.0 ** rng.uniform(-spread / 2, spread / 2, where.shape[0])
    sites = np.arange(n - 1)
    pairs = sp.csr_matrix((np.r_[-np.ones(n - 1), np.ones(n - 1)], (np.r_[sites, sites], np.r_[sites, sites + 1])),
                          shape=(n - 1, n))
    anchors = sp.csr_matrix((np.ones(where.shape[0]), (np.arange(where.shape[0]), where)), shape=(where.shape[0], n))
    return sp.vstack([pairs, anchors]).tocsr(), np.r_[springs, ground[where]], mass, springs, ground


def chain_count(mass: np.ndarray, springs: np.ndarray, ground: np.ndarray, x: mp.mpf, dps: int = 40) -> int:
    """How many eigenvalues of (K, M) lie below x: the negative pivots of K - x M's LDL^T in mpmath."""
    with mp.workdps(dps):
        n = len(mass)
        k = [mp.mpf(0)] + [mp.mpf(float(s)) for s in springs] + [mp.mpf(0)]
        x = mp.mpf(x)
        pivot, negative = None, 0
        for i in range(n):
            a = k[i] + k[i + 1] + mp.mpf(float(ground[i])) - x * mp.mpf(float(mass[i]))
            pivot = a if i == 0 else a - k[i] ** 2 / pivot
            negative += pivot < 0
        return negative


def covered(mass, springs, ground, omega: float, error: float, j: int, dps: int) -> bool:  # type: ignore[no-untyped-def]
    with mp.workdps(dps):
        low, high = (mp.mpf(omega) - mp.mpf(error)) ** 2, (mp.mpf(omega) + mp.mpf(error)) ** 2
        return chain_count(mass, springs, ground, low, dps) <= j < chain_count(mass, springs, ground, high, dps)


@pytest.mark.parametrize("n", [2, 3, 7, 12])
def test_chain_count_matches_a_dense_solve(n: int) -> None:
    B, w, mass, springs, ground = chain_on_walls(n, 1.0, n, walls=None)
    values = la.eigh((B.T @ sp.diags(w) @ B).toarray(), np.diag(mass), eigvals_only=True)
    middles = np.r_[0.5 * values[0], 0.5 * (values[1:] + values[:-1]), 2 * values[-1]]
    assert [chain_count(mass, springs, ground, mp.mpf(float(x))) for x in middles] == list(range(n + 1))


def test_only_chains_with_walls_inside_are_taken() -> None:
    """`walled.walled_chain`: a chain with a wall inside (or two at one end) yes; a free or
    fixed chain (a path: `bidiagonal`), a ring, parallel springs or a branch no."""
    n = 6
    B, w, mass, _, _ = chain_on_walls(n, 0.0, 1, walls=1)
    assert walled.walled_chain(B, w, mass) is not None
    assert walled.has_inner_walls(B)
    pairs = B[: n - 1]
    end = sp.csr_matrix(([1.0], ([0], [0])), shape=(1, n))
    other_end = sp.csr_matrix(([1.0], ([0], [n - 1])), shape=(1, n))
    fixed = sp.vstack([pairs, end, other_end]).tocsr()
    assert walled.walled_chain(fixed, np.ones(n + 1), mass) is None and not walled.has_inner_walls(fixed)
    doubled = sp.vstack([pairs, end, end]).tocsr()
    assert walled.walled_chain(doubled, np.ones(n + 1), mass) is not None
    ring = sp.vstack([pairs, sp.csr_matrix(([-1.0, 1.0], ([0, 0], [n - 1, 0])), shape=(1, n)), B[n - 1:]]).tocsr()
    assert walled.walled_chain(ring, np.ones(ring.shape[0]), mass) is None
    parallel = sp.vstack([pairs, pairs[2], B[n - 1:]]).tocsr()
    assert walled.walled_chain(parallel, np.ones(parallel.shape[0]), mass) is None
    branch = sp.vstack([pairs[:-1], sp.csr_matrix(([-1.0, 1.0], ([0, 0], [2, n - 1])), shape=(1, n)), B[n - 1:]]).tocsr()
    assert walled.walled_chain(branch, np.ones(branch.shape[0]), mass) is None
    assert walled.walled_chain(B, w, np.diag(mass)) is None


def test_small_chains_on_walls_are_certified_against_80_digit_eigenvalues() -> None:
    """60 small chains (2-13 sites; masses, springs and walls over up to 1e12; B's entries not
    always +-1; walls at random sites, sometimes two at one): all values and the lowest 1 and
    2 by `walled_values`: every value certified, covered by its bound against mpmath.eigsy of
    K~ at 80 digits, the bound within 2e-13 relative in omega^2 (1e-13 in omega)."""
    rng = np.random.default_rng(8)
    taken = 0
    for _ in range(60):
        n, spread = int(rng.integers(2, 14)), float(rng.choice([0.3, 6.0, 12.0]))
        springs, mass = 10.0 ** rng.uniform(-spread / 2, spread / 2, n - 1), 10.0 ** rng.uniform(-spread / 2, spread / 2, n)
        B = np.zeros((n - 1, n))
        B[np.arange(n - 1), np.arange(n - 1)] = -rng.uniform(0.2, 1.0, n - 1) if rng.random() < 0.5 else -1.0
        B[np.arange(n - 1), np.arange(1, n)] = rng.uniform(0.2, 1.0, n - 1) if rng.random() < 0.5 else 1.0
        k = int(rng.integers(1, n + 2))
        W = np.zeros((k, n))
        W[np.arange(k), rng.integers(0, n, k)] = rng.uniform(0.2, 1.0, k)
        B, springs = np.vstack([B, W]), np.r_[springs, 10.0 ** rng.uniform(-spread / 2, spread / 2, k)]
        chain = walled.walled_chain(sp.csr_matrix(B), springs, mass)
        if chain is None:  # walls at the two ends only: a path, not this module's
            continue
        taken += 1
        certified_by_eigsy(B, springs, mass, lambda count: walled.walled_values(chain, count))
    assert taken >= 40


def _pendulums(n: int, g: float = 0.01) -> System:
    bonds = np.c_[np.arange(n - 1), np.arange(1, n)]
    return System.from_springs(np.arange(n) * 1.0, np.ones(n), bonds, np.ones(n - 1), anchors=np.arange(n),
                               anchor_stiffness=np.full(n, g), units="dimensionless")


def test_a_chain_of_5000_pendulums_meets_the_criterion() -> None:
    """5,000 unit masses and springs, each site on a wall spring 0.01 (free ends): omega_j^2 =
    0.01 + 4 sin^2(pi j / 2n). All values, and the lowest 10 with vectors: ``accurate-walled``,
    every bound covering the closed form and within 1e-13 relative; the vectors' residuals
    ||K~ v - omega^2 v|| / omega^2 below 1e-10. (Before: the checked dense solve, 15.7 s.)"""
    n = 5000
    chain = _pendulums(n)
    with mp.workdps(30):
        truth = np.array([float(mp.sqrt(mp.mpf("0.01") + 4 * mp.sin(mp.pi * j / (2 * n)) ** 2)) for j in range(n)])
    every = chain.modes(vectors=False)
    lowest = chain.modes(n_modes=10)
    for modes in (every, lowest):
        k = modes.n_modes
        assert modes.solver == "accurate-walled"
        assert f"{k} of {k} bounds certified" in modes.refinement
        assert np.all(np.maximum(np.abs(modes.omega - truth[:k]) - 1e-16 * truth[:k], 0.0) <= modes.omega_error)
        assert np.all(modes.omega_error <= 1e-13 * modes.omega)
    K = chain.hessian()
    V = lowest.vectors
    residual = np.linalg.norm(K @ V - V * lowest.omega**2, axis=0)
    assert np.all(residual <= 1e-10 * lowest.omega**2)


@pytest.mark.parametrize(("spread", "walls", "seed"), [(6.0, None, 1), (12.0, 3, 2), (24.0, 1, 3), (24.0, None, 4)])
def test_disordered_chains_on_walls_against_mpmath_counts(spread: float, walls: int | None, seed: int) -> None:
    """2,000 sites, masses, springs and walls log-uniform over 10^spread (to 1e-12..1e12), walls
    at every site, at 3 or at 1 inner site: every bound within 1e-13 relative; the lowest 3, the
    loosest 3 and 4 random modes covered by mpmath counts (40 + 2 spread digits) and within
    1e-13 of the truth; the lowest 5 alone agree with all."""
    n = 2000
    B, w, mass, springs, ground = chain_on_walls(n, spread, seed, walls)
    K = (B.T @ sp.diags(w) @ B).tocsr()
    modes = normal_modes(K, mass, spring_factor=(B, w), vectors=False)
    assert modes.solver == "accurate-walled"
    relative = modes.omega_error / modes.omega
    assert np.all(relative <= 1e-13)
    rng = np.random.default_rng(seed)
    digits = 40 + int(2 * spread)
    for j in np.unique(np.r_[0, 1, 2, np.argsort(-relative)[:3], rng.choice(n, 4, replace=False)]).tolist():
        omega = float(modes.omega[j])
        assert covered(mass, springs, ground, omega, float(modes.omega_error[j]), j, digits), j
        assert covered(mass, springs, ground, omega, 1e-13 * omega, j, digits), j
    lowest = normal_modes(K, mass, spring_factor=(B, w), n_modes=5, vectors=False)
    assert lowest.solver == "accurate-walled"
    assert np.all(np.abs(lowest.omega - modes.omega[:5]) <= lowest.omega_error + modes.omega_error[:5])


def test_the_plan_names_the_path_and_small_or_full_requests_keep_the_dense_solve() -> None:
    """The cost estimate names ``accurate-walled`` for what will take it; under 100 sites, and
    all modes with vectors, the checked dense solve answers (every bound within 1e-10)."""
    from vibra import solvers

    chain = _pendulums(300)
    B, w = chain.spring_factor()
    K, mass = chain.hessian(), np.ones(300)
    plan = solvers.plan(K, mass, n_modes=None, vectors=False, band=None, solver="auto", spring_factor=(B, w))
    assert plan.path == "accurate-walled"
    assert chain.modes(vectors=False).solver == "accurate-walled"
    full = chain.modes()
    assert full.solver in ("accurate-checked", "accurate-jacobi")
    assert np.all(full.omega_error <= 1e-10 * full.omega)
    assert _pendulums(99).modes(vectors=False).solver in ("accurate-checked", "accurate-jacobi")


def test_the_chains_doc_example_runs_as_written() -> None:
    """docs/chains.md's chain of pendulums: the block runs and says what it computes (the path,
    and the lowest two against the closed form)."""
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "docs" / "chains.md").read_text(encoding="utf-8")
    block = next(b for b in re.findall(r"```python\n(.*?)```", text, flags=re.S) if "anchor_stiffness" in b)
    namespace: dict = {}
    exec(compile(block, "docs/chains.md", "exec"), namespace)
    modes, n, g = namespace["modes"], namespace["n"], namespace["g"]
    assert modes.solver == "accurate-walled"
    exact = np.sqrt(g + 4 * np.sin(np.pi * np.arange(2) / (2 * n)) ** 2)
    assert np.allclose(modes.omega[:2], exact, rtol=1e-14)


def test_all_modes_with_vectors_over_dense_limit_pair_stemr_vectors_with_certified_values() -> None:
    """2,000 pendulums, all modes with vectors (over DENSE_LIMIT: before, the Rayleigh path's
    dense O(n^3) solve): the values certified as above, covering the closed form; the vectors
    LAPACK stemr's, paired by rank (a chain's eigenvalues are simple), each with a residual
    ||K~ v - omega^2 v|| within 1e-13 of ||K~|| (~4.01) and orthonormal to 1e-13."""
    from vibra import solvers

    n = 2000
    chain = _pendulums(n)
    B, w = chain.spring_factor()
    plan = solvers.plan(chain.hessian(), np.ones(n), n_modes=None, vectors=True, band=None, solver="auto",
                        spring_factor=(B, w))
    assert plan.path == "accurate-walled"
    modes = chain.modes()
    assert modes.solver == "accurate-walled" and "paired by rank" in modes.refinement
    with mp.workdps(30):
        truth = np.array([float(mp.sqrt(mp.mpf("0.01") + 4 * mp.sin(mp.pi * j / (2 * n)) ** 2)) for j in range(n)])
    assert np.all(np.maximum(np.abs(modes.omega - truth) - 1e-16 * truth, 0.0) <= modes.omega_error)
    assert np.all(modes.omega_error <= 1e-13 * modes.omega)
    V = modes.vectors
    residual = np.linalg.norm(chain.hessian() @ V - V * modes.omega**2, axis=0)
    assert residual.max() <= 1e-13 * 4.01
    assert np.abs(V.T @ V - np.eye(n)).max() <= 1e-13
