"""Shared test helpers: chains."""

from __future__ import annotations

import mpmath
import numpy as np
import scipy.sparse as sp

from vibra.solvers.accurate.chain.bidiagonal import (
    bidiagonal_path,
    chain_bidiagonals,
)


# ------------------------------------------------------------------------------------------ chains
def chain(mass: np.ndarray, springs: np.ndarray, walls: tuple[float, float] = (0.0, 0.0)):
    """(B, w, K) of a chain: springs between neighbours, then wall springs at the first / last site."""
    n = mass.shape[0]
    rows = np.repeat(np.arange(n - 1), 2)
    cols = np.ravel(np.c_[np.arange(n - 1), np.arange(1, n)])
    vals = np.tile([-1.0, 1.0], n - 1)
    weights = list(springs)
    for site, wall in ((0, walls[0]), (n - 1, walls[1])):
        if wall > 0:
            rows, cols, vals = np.r_[rows, len(weights)], np.r_[cols, site], np.r_[vals, 1.0]
            weights.append(wall)
    w = np.array(weights)
    B = sp.csr_matrix((vals, (rows, cols)), shape=(w.shape[0], n))
    return B, w, sp.csr_matrix(B.T @ sp.diags(w) @ B)


def weighted_factor(B: sp.csr_matrix, w: np.ndarray, mass: np.ndarray) -> sp.csr_matrix:
    return sp.csr_matrix(sp.diags(np.sqrt(w)) @ B @ sp.diags(1.0 / np.sqrt(mass)))


def mass_weighted(K: sp.csr_matrix, mass: np.ndarray) -> sp.csr_matrix:
    return sp.csr_matrix(sp.diags(mass**-0.5) @ K @ sp.diags(mass**-0.5))


def all_modes(mass, springs, walls, vectors):
    """Every mode by the accurate-bidiagonal path, with the spring factor and masses it was formed from."""
    B, w, K = chain(mass, springs, walls)
    weighted = weighted_factor(B, w, mass)
    segments = chain_bidiagonals(weighted)
    return bidiagonal_path(mass_weighted(K, mass), weighted, segments, n_modes=None, vectors=vectors, band=None,
                           factor=(B, w), mass=mass)


def sturm_count(mass, springs, walls, x) -> int:
    """Eigenvalues of K~ below x, 40-digit mpmath (LDL^T pivots of K~ - x)."""
    with mpmath.workdps(40):
        m = [mpmath.mpf(float(v)) for v in mass]
        s = [mpmath.mpf(float(v)) for v in springs]
        n = len(m)
        x = mpmath.mpf(float(x)) if not isinstance(x, mpmath.mpf) else x
        count, pivot = 0, None
        for i in range(n):
            diagonal = (s[i - 1] if i else 0) + (s[i] if i < n - 1 else 0)
            diagonal += mpmath.mpf(walls[0]) if i == 0 else 0
            diagonal += mpmath.mpf(walls[1]) if i == n - 1 else 0
            value = diagonal / m[i] - x
            if i:
                value -= s[i - 1] ** 2 / (m[i] * m[i - 1]) / pivot
            pivot = value if value != 0 else mpmath.mpf("1e-80")
            count += pivot < 0
        return count


def assert_guides_by_counts(mass, springs, walls, eigenvalues, error, modes) -> None:
    """The interval of each listed mode holds the j-th eigenvalue; shrunk 1000x it does not (or is < 1e-13)."""
    for j in modes:
        low, high = eigenvalues[j] - error[j], eigenvalues[j] + error[j]
        with mpmath.workdps(40):
            low_x, high_x = mpmath.mpf(float(eigenvalues[j])) - mpmath.mpf(float(error[j])), \
                mpmath.mpf(float(eigenvalues[j])) + mpmath.mpf(float(error[j]))
        assert sturm_count(mass, springs, walls, low_x) <= j < sturm_count(mass, springs, walls, high_x), (j, low, high)
        tight = mpmath.mpf(float(error[j])) / 1000
        if tight <= 1e-13 * eigenvalues[j]:
            continue
        with mpmath.workdps(40):
            inner_low = mpmath.mpf(float(eigenvalues[j])) - tight
            inner_high = mpmath.mpf(float(eigenvalues[j])) + tight
        holds = sturm_count(mass, springs, walls, inner_low) <= j < sturm_count(mass, springs, walls, inner_high)
        assert not holds, (j, "the bound is over 1000 times the true error")


def disordered(n: int, spread: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return 10.0 ** rng.uniform(0, np.log10(spread), n), 10.0 ** rng.uniform(0, np.log10(spread), n - 1)
