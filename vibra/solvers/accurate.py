"""Accurate paths for a system that knows its springs, K = B^T W B.

The frequencies are the singular values of B~ = W^1/2 B M^-1/2, computed to high relative
accuracy where the structure allows (`accurate_path` chooses):

- ``accurate-bidiagonal``: the springs form a path (a chain); see `vibra.solvers.bidiagonal`;
- ``accurate-ritz``: a few modes of a large system: shift-invert vectors, then Rayleigh-Ritz
  in spring space (H = (B~V)^T (B~V), O(N k));
- ``accurate-rayleigh``: all modes of a large (n > DENSE_LIMIT) non-path system: dense
  vectors, then per-vector Rayleigh quotients ||B~ v||^2;
- ``accurate-checked`` / ``accurate-jacobi``: any other system (n <= DENSE_LIMIT): the fast
  dense solve first, spring-space Rayleigh-Ritz on each cluster of its vectors and a
  gap-based (Kato-Temple) bound per mode (`checked_dense`); only when some requested mode's
  bound misses `TARGET` relative does one-sided Jacobi SVD (LAPACK gejsv) of B~ run
  (``accurate-jacobi``; ``accurate-checked`` when the fast result passed).
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
from vibra.solvers.sparse import lowest_shift, semidefinite_rounding, shift_invert, sparse_path
from vibra.solvers.standard import banded_path, dense_path

#: Relative accuracy of omega^2 that `checked_dense` asks of each requested mode before it
#: accepts the fast solve's result for it (omega then to ~TARGET / 2).
TARGET = 1e-10

#: Columns per block in `checked_dense`'s bounds (memory n_terms x BLOCK).
BLOCK = 128


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
    return "accurate-checked"


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
        k = int(n_modes)  # type: ignore[arg-type]
        rounding = semidefinite_rounding(factor, float(abs(sp.csr_matrix(Kt)).sum(axis=1).max()))
        sigma, shifted = lowest_shift(sp.csr_matrix(Kt), rounding=rounding)
        _, basis = shift_invert(sp.csr_matrix(Kt), min(k + 1, n - 2), sigma, shifted)  # one more: the gap
        return _checked_ritz(weighted, basis, k, vectors=vectors)
    if few:
        standard = sparse_path(Kt, n_modes=None, vectors=True, band=band)
        return _spring_ritz(weighted, standard.vectors, vectors=vectors)  # type: ignore[arg-type]
    if n > DENSE_LIMIT:
        standard = dense_path(Kt, n_modes=None, vectors=True, band=band)
        return _spring_rayleigh(weighted, standard.vectors, vectors=vectors)  # type: ignore[arg-type]
    return checked_dense(Kt, weighted, n_modes=n_modes, vectors=vectors, band=band)


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


def _checked_ritz(weighted: Any, basis: NDArray[np.float64], k: int, *, vectors: bool) -> SolveResult:
    """Spring-space Rayleigh-Ritz on k + 1 shift-invert vectors; the lowest k kept, each with the
    quadratic residual bound of `_cluster_bounds` (the (k+1)-th value, less its residual, bounds
    the gap of the k-th from above)."""
    B = sp.csr_matrix(weighted)
    elongations = np.asarray(B @ basis)
    values, rotation = small_pencil(elongations.T @ elongations, basis.T @ basis)
    values = np.maximum(values, 0.0)
    basis = basis @ rotation
    residuals = np.linalg.norm(np.asarray(B.T @ (B @ basis)) - basis * values, axis=0)
    terms = _most_terms(B)
    theta, basis, error = _cluster_bounds(B, values, basis, 2 * residuals, terms, complete=False, precise=True)
    result = _spring_figures(B, theta[:k], basis[:, :k], vectors, "accurate-ritz")
    result.error = np.maximum(error[:k], 4 * EPS * theta[:k])
    return result


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



def checked_dense(Kt: Any, weighted: Any, *, n_modes: int | None, vectors: bool,
                  band: tuple[float, float] | None) -> SolveResult:
    """The fast dense solve, checked mode by mode; Jacobi only for the modes that need it.

    1. LAPACK eigh on K~ (one mode beyond a requested subset, for the gap), absolute error
       <= `delta` = n eps ||K~|| per eigenvalue (backward stable).
    2. The eigenvalues are grouped into clusters (closer than 2 delta + TARGET |value|); on each
       cluster's vectors, Rayleigh-Ritz in spring space: H = (B~V)^T (B~V), whose small
       eigenvalues keep their relative accuracy.
    3. Per cluster, the quadratic residual bound |lambda_i - theta_i| <= ||R||_F^2 / gap (Kato-
       Temple for one vector), gap from the cluster's Ritz values to the neighbouring eigenvalues
       (each moved by delta towards it); ||R||_F with a margin for its own rounding. A cluster
       with no valid gap is bounded by ||R||_F (Weyl).
    4. If a requested mode's bound exceeds TARGET theta, and it is not a zero mode within rounding
       (theta + bound <= (t n eps)^2 ||K~||, t the most terms in a row or column of B~: omega
       below ~1e-11 of the largest, where B~'s own rounding leaves no relative digit), the
       result is gejsv's on B~ (``accurate-jacobi``); else the checked fast result
       (``accurate-checked``), its bounds as `error`.
    """
    dense = Kt.toarray() if sp.issparse(Kt) else np.asarray(Kt)
    n = dense.shape[0]
    B = sp.csr_matrix(weighted)
    subset = n_modes is not None and n_modes < n
    kwargs: dict[str, Any] = {"check_finite": False}
    if subset:
        kwargs["subset_by_index"] = (0, int(n_modes))  # type: ignore[arg-type]  # one beyond, for the gap
    values, basis = la.eigh(dense, **kwargs)
    norm = max(float(np.abs(np.diag(dense)).max(initial=0.0)), float(np.abs(values).max(initial=0.0)), 1e-300)
    delta = n * EPS * norm
    terms = _most_terms(B)
    theta, basis, error = _cluster_bounds(B, values, basis, delta, terms, complete=not subset)
    keep = np.zeros(theta.shape[0], dtype=bool)
    keep[selected(np.sqrt(np.maximum(theta, 0.0)), n_modes=n_modes, band=band)] = True
    zero = theta + error <= (terms * n * EPS) ** 2 * norm
    refine = keep & (error > TARGET * np.abs(theta)) & ~zero
    solver = "accurate-checked"
    if refine.any():
        # One-sided Jacobi on B~ (gejsv reduces the tall B~ by a pivoted QR first). Its vectors
        # are taken for every mode (mixing them with the fast vectors would cost orthogonality)
        # and checked the same way: its own estimate (eps times a condition number it cannot
        # see) is not a bound, a ring's 1e12 springs beat it by 1e4.
        exact = _accurate_jacobi(weighted, n_modes=None, vectors=True, band=None)
        theta, basis, error = _cluster_bounds(B, exact.eigenvalues, exact.vectors,  # type: ignore[arg-type]
                                              delta, terms, complete=True, precise=True)
        keep = np.zeros(theta.shape[0], dtype=bool)
        keep[selected(np.sqrt(np.maximum(theta, 0.0)), n_modes=n_modes, band=band)] = True
        solver = "accurate-jacobi"
    theta, basis, error = theta[keep], basis[:, keep], error[keep]
    result = _spring_figures(B, theta, basis, vectors, solver)
    result.error = error
    return result


def _most_terms(B: sp.csr_matrix) -> float:
    """The most stored entries in a row or a column of B~ (the length of its dot products)."""
    return float(max(np.diff(B.indptr).max(initial=1), np.bincount(B.indices, minlength=B.shape[1]).max(initial=1)))


def _cluster_bounds(B: sp.csr_matrix, values: NDArray[np.float64], basis: NDArray[np.float64], delta: Any,
                    terms: float, *, complete: bool, precise: bool = False) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Spring-space Ritz values, vectors and quadratic residual bounds per cluster (see checked_dense).

    Works through blocks of whole clusters (~BLOCK columns): O(nnz(B~) k) in all, n_terms x BLOCK memory.
    `precise`: products in extended precision (np.longdouble), whose rounding margin is ~2000
    times smaller; the bound, quadratic in the residual, then stays near the true error where
    stiff springs make the float64 margin (eps |B~|^T |B~| |v|) dominate.
    """
    unit = float(np.finfo(np.longdouble).eps) if precise else EPS
    if precise:
        B = B.astype(np.longdouble)
    k = values.shape[0]
    delta = np.broadcast_to(np.asarray(delta, dtype=float), values.shape)  # each value's absolute error
    breaks = np.flatnonzero(np.diff(values) > delta[:-1] + delta[1:] + TARGET * np.abs(values[1:]))
    starts, stops = np.r_[0, breaks + 1], np.r_[breaks + 1, k]
    theta, error = np.empty(k), np.empty(k)
    vectors = np.empty_like(basis)
    A = abs(B)
    first = 0
    while first < len(starts):
        last = int(np.searchsorted(stops, stops[first] + BLOCK - 1, side="right")) if first < len(starts) else first
        last = max(last, first + 1)
        columns = slice(int(starts[first]), int(stops[last - 1]))
        V = basis[:, columns].astype(B.dtype)
        E = np.asarray(B @ V)
        w = np.empty(V.shape[1])
        for start, stop in zip(starts[first:last] - columns.start, stops[first:last] - columns.start):
            if stop - start == 1:
                w[start] = float((E[:, start] @ E[:, start]) / (V[:, start] @ V[:, start]))
                continue
            part, rotation = small_pencil((E[:, start:stop].T @ E[:, start:stop]).astype(float),
                                          (V[:, start:stop].T @ V[:, start:stop]).astype(float))
            w[start:stop] = part
            V[:, start:stop] = V[:, start:stop] @ rotation
            E[:, start:stop] = E[:, start:stop] @ rotation
        w = np.maximum(w, 0.0)  # H is a Gram matrix
        squares = np.sum((np.asarray(B.T @ E) - V * w) ** 2, axis=0)
        # rounding of B~^T (B~ V) (sums of <= `terms` products)
        margins = 2 * terms * unit * np.linalg.norm(np.asarray(A.T @ (A @ np.abs(V))), axis=0).astype(float)
        vectors[:, columns], theta[columns] = V, w
        for start, stop in zip(starts[first:last], stops[first:last]):
            local = slice(start - columns.start, stop - columns.start)
            residual = float(np.sqrt(squares[local].sum())) + float(margins[local].max())  # (to float64)
            lower = values[start - 1] + delta[start - 1] if start > 0 else -np.inf
            upper = values[stop] - delta[stop] if stop < k else (np.inf if complete else -np.inf)
            gap = min(float(w[local].min()) - lower, upper - float(w[local].max()))
            bound = residual**2 / gap if gap > residual else residual
            error[start:stop] = bound + (2 * terms * unit + EPS) * w[local]
        first = last
    return theta, vectors, error
