"""Shared test helpers: springs."""

from __future__ import annotations

from typing import Any

import mpmath
import numpy as np
import scipy.sparse as sp

from vibra import System, normal_modes


def network(rng: np.random.Generator, n_sites: int, spring_decades: float, mass_decades: float
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(B, w, masses) of a rigid 3-D network: each random site joined to its 8 nearest neighbours,
    spring constants log-uniform over +-spring_decades, masses over +-mass_decades."""
    positions = rng.normal(size=(n_sites, 3))
    distance = np.linalg.norm(positions[:, None] - positions[None], axis=-1)
    nearest = np.argsort(distance, axis=1)[:, 1:9]
    pairs = np.array(sorted({(min(i, j), max(i, j)) for i in range(n_sites) for j in nearest[i].tolist()}))
    directions = positions[pairs[:, 1]] - positions[pairs[:, 0]]
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    B = np.zeros((len(pairs), 3 * n_sites))
    rows = np.arange(len(pairs))
    for axis in range(3):
        B[rows, 3 * pairs[:, 1] + axis] = directions[:, axis]
        B[rows, 3 * pairs[:, 0] + axis] = -directions[:, axis]
    springs = 10.0 ** rng.uniform(-spring_decades, spring_decades, len(pairs))
    masses = np.repeat(10.0 ** rng.uniform(-mass_decades, mass_decades, n_sites), 3)
    return B, springs, masses


def solve(B: np.ndarray, springs: np.ndarray, masses: np.ndarray, **kwargs: Any) -> Any:
    K = B.T @ (springs[:, None] * B)
    return normal_modes(0.5 * (K + K.T), masses, spring_factor=(sp.csr_matrix(B), springs), **kwargs)


def mp_spring_omegas(B: np.ndarray, springs: np.ndarray, masses: np.ndarray, digits: int = 50,
                     exact: bool = False) -> Any:
    """omega of K~ = M^-1/2 B^T W B M^-1/2 from mpmath.eigsy at `digits` digits, with B~ = W^1/2 B M^-1/2
    formed in mpmath from the float64 entries of B, w and M taken as exact (no float64 K);
    rounded to float64, or (`exact`) the mpmath numbers themselves, ascending."""
    with mpmath.workdps(digits):
        n_terms, n = B.shape
        root_w = [mpmath.sqrt(mpmath.mpf(float(x))) for x in springs]
        inverse_root_m = [1 / mpmath.sqrt(mpmath.mpf(float(x))) for x in masses]
        weighted = mpmath.matrix(n_terms, n)
        for row, column in zip(*np.nonzero(B)):
            weighted[int(row), int(column)] = root_w[row] * mpmath.mpf(float(B[row, column])) * inverse_root_m[column]
        values = mpmath.eigsy(weighted.T * weighted, eigvals_only=True)
        omegas = sorted(mpmath.sqrt(abs(v)) for v in values)
        return omegas if exact else np.array([float(w) for w in omegas])


# ---------------------------------------------------------------------- accurate-rayleigh
def anisotropic_lattice(side: int, stiffness: tuple[float, float, float]) -> System:
    """A simple-cubic lattice of side**3 unit masses with nearest-neighbour springs stiffness[axis]."""
    grid = np.stack(np.meshgrid(*(np.arange(side),) * 3, indexing="ij"), axis=-1).reshape(-1, 3).astype(float)
    index = np.arange(side**3).reshape((side,) * 3)
    pairs, constants = [], []
    for axis in range(3):
        lines = np.moveaxis(index, axis, 0)
        bonds = np.c_[lines[:-1].ravel(), lines[1:].ravel()]
        pairs.append(bonds)
        constants.append(np.full(len(bonds), stiffness[axis]))
    return System.from_springs(grid, 1.0, np.vstack(pairs), np.concatenate(constants))


def lattice_frequencies(side: int, stiffness: tuple[float, float, float]) -> np.ndarray:
    """Ascending omega of `anisotropic_lattice`: side^2 free chains per axis, each with the
    closed form 2 sqrt(kappa_a) sin(j pi / 2 side), j = 0..side-1."""
    j = np.arange(side)
    return np.sort(np.concatenate([np.repeat(2.0 * np.sqrt(kappa) * np.sin(j * np.pi / (2 * side)), side**2)
                                   for kappa in stiffness]))


def partial_truth(mass, springs, anchor, k: int) -> list:
    """The lowest k omega^2 of the chain by bisection on Sturm counts, 60 digits."""
    with mpmath.workdps(60):
        m = [mpmath.mpf(float(x)) for x in mass]
        s = [mpmath.mpf(float(x)) for x in springs]
        n = len(m)
        diag = [((s[i - 1] if i > 0 else 0) + (s[i] if i < n - 1 else 0)) / m[i] for i in range(n)]
        diag[0] += mpmath.mpf(anchor) / m[0]
        off2 = [s[i] ** 2 / (m[i] * m[i + 1]) for i in range(n - 1)]

        def below(x):
            count, q = 0, diag[0] - x
            for i in range(n):
                if i:
                    q = diag[i] - x - off2[i - 1] / q
                if q == 0:
                    q = mpmath.mpf("1e-80")
                count += q < 0
            return count

        top = 2 * max(diag) + 1
        values = []
        for j in range(1, k + 1):
            low, high = mpmath.mpf(0), top
            if j == 1 and anchor == 0:  # a free chain's translation: exactly zero
                values.append(mpmath.mpf(0))
                continue
            while high - low > mpmath.mpf("1e-25") * high:
                middle = mpmath.sqrt(low * high) if low > 0 else high / 2**40
                if below(middle) >= j:
                    high = middle
                else:
                    low = middle
            values.append((low + high) / 2)
        return values
