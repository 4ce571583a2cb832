"""Accurate paths for a system that knows its springs, K = B^T W B.

The frequencies are the singular values of B~ = W^1/2 B M^-1/2, computed to high relative
accuracy where the structure allows (`accurate_path` chooses):

- ``accurate-bidiagonal``: the springs form a path (a chain); see `vibra.solvers.bidiagonal`;
- ``accurate-ritz``: a few modes of a large system: shift-invert vectors, then Rayleigh-Ritz
  in spring space (H = (B~V)^T (B~V), O(N k));
- ``accurate-rayleigh``: all modes of a large (n > DENSE_LIMIT) non-path system: dense
  vectors, then per-vector Rayleigh quotients ||B~ v||^2;
- ``accurate-jacobi``: any other system: one-sided Jacobi SVD (LAPACK gejsv) of B~.
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
from numpy.typing import NDArray

from vibra.solvers.bidiagonal import bidiagonal_path, path_bidiagonals
from vibra.solvers.common import (
    DENSE_LIMIT, EPS, SolveResult, mass_power, sample_columns, selected, small_pencil,
)
from vibra.solvers.sparse import lowest_shift, shift_invert, sparse_path
from vibra.solvers.standard import banded_path, dense_path


def accurate_subpath(n: int, mass: NDArray[np.float64], *, n_modes: int | None,
                     band: tuple[float, float] | None, tridiagonal: bool, banded: bool) -> str:
    """The path `accurate_path` will take (for the cost estimate), without touching B.

    Springs that form a path join dofs c and c + 1 only, so K is tridiagonal: a tridiagonal
    K with diagonal masses is estimated as a path (parallel springs between one pair, the
    exception, take the Rayleigh path, at most the dense cost).
    """
    few = (n_modes is not None and n_modes < n - 1 or band is not None) and n > DENSE_LIMIT
    if mass.ndim == 1 and not few and tridiagonal:
        return "accurate-bidiagonal"
    if few:
        return "accurate-ritz"
    if n > DENSE_LIMIT:
        return "banded" if banded else "accurate-rayleigh"
    return "accurate-jacobi"


def accurate_path(Kt: Any, mass: NDArray[np.float64], factor: tuple[sp.csr_matrix, NDArray[np.float64]], *,
                  n_modes: int | None, vectors: bool, band: tuple[float, float] | None,
                  ordering: NDArray[np.intp] | None = None, width: int = 0,
                  on_stage: Callable[[float, str], None] | None = None) -> SolveResult:
    """Frequencies as singular values of B~ = W^1/2 B M^-1/2: picks the accurate-* path that fits.

    A large ring (`ordering` given: K~ banded once reordered) is not a path: its frequencies
    come from the banded solver (absolute accuracy, reported as ``"banded"``), and with
    vectors from the spring-space Rayleigh quotients of the banded vectors.
    """
    coupling, weights = factor
    n = Kt.shape[0]
    weighted = _weighted_factor(coupling, weights, mass)  # B~ (n_terms, n)
    few = (n_modes is not None and n_modes < n - 1 or band is not None) and n > DENSE_LIMIT
    path = path_bidiagonals(weighted) if mass.ndim == 1 and not few else None
    if path is not None:
        return bidiagonal_path(Kt, weighted, path, n_modes=n_modes, vectors=vectors, band=band, on_stage=on_stage)
    if ordering is not None and not few and n > DENSE_LIMIT:
        ring = banded_path(Kt, width, n_modes=n_modes, vectors=vectors, band=band, ordering=ordering)
        if ring.vectors is None:
            return ring
        return _spring_rayleigh(weighted, ring.vectors, vectors=vectors)
    if few and band is None:
        sigma, shifted = lowest_shift(sp.csr_matrix(Kt))
        _, basis = shift_invert(sp.csr_matrix(Kt), int(n_modes), sigma, shifted)  # type: ignore[arg-type]
        return _spring_ritz(weighted, basis, vectors=vectors)
    if few:
        standard = sparse_path(Kt, n_modes=None, vectors=True, band=band)
        return _spring_ritz(weighted, standard.vectors, vectors=vectors)  # type: ignore[arg-type]
    if n > DENSE_LIMIT:
        standard = dense_path(Kt, n_modes=None, vectors=True, band=band)
        return _spring_rayleigh(weighted, standard.vectors, vectors=vectors)  # type: ignore[arg-type]
    return _accurate_jacobi(weighted, n_modes=n_modes, vectors=vectors, band=band)


def _weighted_factor(coupling: sp.csr_matrix, weights: NDArray[np.float64], mass: NDArray[np.float64]) -> Any:
    left = sp.diags(np.sqrt(weights))
    if mass.ndim == 1:
        return sp.csr_matrix(left @ coupling @ sp.diags(1.0 / np.sqrt(mass)))
    return np.asarray((left @ coupling).toarray() @ mass_power(mass, -0.5))


def _spring_products(weighted: Any, basis: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.asarray(weighted @ basis)


def _spring_ritz(weighted: Any, basis: NDArray[np.float64], *, vectors: bool) -> SolveResult:
    """Rayleigh-Ritz in spring space: H = (B~V)^T (B~V) keeps small eigenvalues' relative accuracy."""
    elongations = _spring_products(weighted, basis)
    values, rotation = small_pencil(elongations.T @ elongations, basis.T @ basis)
    values = np.maximum(values, 0.0)  # H is a Gram matrix: positive semi-definite
    return _spring_figures(weighted, values, basis @ rotation, vectors, "accurate-ritz")


def _spring_rayleigh(weighted: Any, basis: NDArray[np.float64], *, vectors: bool) -> SolveResult:
    """Per-vector Rayleigh quotients ||B~ v||^2 (all modes of a large non-path system)."""
    elongations = _spring_products(weighted, basis)
    values = np.sum(elongations**2, axis=0) / np.sum(basis**2, axis=0)
    order = np.argsort(values)
    return _spring_figures(weighted, values[order], basis[:, order], vectors, "accurate-rayleigh")


def _spring_figures(weighted: Any, values: NDArray[np.float64], basis: NDArray[np.float64], vectors: bool,
                    solver: str) -> SolveResult:
    columns = sample_columns(basis.shape[1])
    sample = basis[:, columns]
    product = np.asarray(weighted.T @ (weighted @ sample))
    residuals = np.linalg.norm(product - sample * values[columns], axis=0)
    squares = weighted.multiply(weighted) if sp.issparse(weighted) else np.asarray(weighted) ** 2
    norm = max(float(values.max(initial=0.0)), float(np.asarray(squares.sum(axis=0)).max()))  # max diag of K~
    # Kato-Temple: |lambda - theta| <= r^2 / gap, gap to the nearest other Ritz value;
    # plus the rounding of the Gram sums (a few eps relative).
    gaps = np.full(values.shape, norm)
    if values.shape[0] > 1:
        spacing = np.diff(values)
        gaps = np.minimum(np.r_[spacing, np.inf], np.r_[np.inf, spacing])
        gaps = np.where(gaps > 0, gaps, norm)
    error = 4 * EPS * np.abs(values)
    error[columns] += residuals**2 / gaps[columns]
    gram = basis.T @ sample
    gram[columns, np.arange(len(columns))] -= 1.0
    return SolveResult(values, basis if vectors else None, error, float(residuals.max(initial=0.0) / norm),
                       float(np.abs(gram).max(initial=0.0)), solver)


def _accurate_jacobi(weighted: Any, *, n_modes: int | None, vectors: bool, band: tuple[float, float] | None
                     ) -> SolveResult:
    """One-sided Jacobi SVD (LAPACK gejsv) of the dense B~: relative accuracy for scaled B."""
    dense = weighted.toarray() if sp.issparse(weighted) else np.asarray(weighted)
    n_terms, n = dense.shape
    padded = np.zeros((max(n_terms, n), n))  # gejsv needs rows >= columns; zero rows add null space
    padded[:n_terms] = dense
    gejsv = la.get_lapack_funcs("gejsv", dtype=np.float64)
    sva, u, v, work, iwork, info = gejsv(padded, joba=1, jobu=3, jobv=0 if vectors else 3, jobr=1,
                                         jobt=0, jobp=0)
    if info != 0:
        raise RuntimeError(f"LAPACK gejsv failed with info={info}")
    scale = work[0] / work[1] if work[1] != 0 else 1.0  # sigma = scale * sva (LAPACK convention)
    sigma = scale * sva
    order = np.argsort(sigma)
    omega = sigma[order]
    select = selected(omega, n_modes=n_modes, band=band)
    eigenvalues = omega[select] ** 2
    # Jacobi: relative error ~ eps * cond(B~ with columns scaled to unit norm) per value;
    # reported with the residual of the Gram form below.
    if not vectors:
        error = 2.0 * 4 * n * EPS * eigenvalues
        return SolveResult(eigenvalues, None, error, float("nan"), float("nan"), "accurate-jacobi")
    basis = v[:, order][:, select]
    result = _spring_figures(sp.csr_matrix(dense), eigenvalues, basis, True, "accurate-jacobi")
    return result

