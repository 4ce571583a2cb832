"""Shared test helpers: rings."""

from __future__ import annotations

from typing import Any

import mpmath as mp
import numpy as np
import scipy.sparse as sp

from vibra.solvers.accurate.dd import div, mul
from vibra.solvers.accurate.ring import counts as ring_counts
from vibra.solvers.accurate.ring import values as ring_values


def ring_count(mass: np.ndarray, springs: np.ndarray, x: mp.mpf, dps: int = 40,
               ground: np.ndarray | None = None) -> int:
    """How many eigenvalues of (K, M) lie below x, for the ring (mass, springs), with a spring
    ground[i] from site i to a wall where given."""
    with mp.workdps(dps):
        n = len(mass)
        k = [mp.mpf(float(s)) for s in springs]
        m = [mp.mpf(float(v)) for v in mass]
        g = [mp.mpf(0)] * n if ground is None else [mp.mpf(float(v)) for v in ground]
        x = mp.mpf(x)
        a = [k[i - 1] + k[i] + g[i] - x * m[i] for i in range(n)]
        pivot, fill, last = a[0], -k[n - 1], a[n - 1]
        negative = 0
        for i in range(n - 2):
            negative += pivot < 0
            following = a[i + 1] - k[i] ** 2 / pivot
            last -= fill * fill / pivot
            fill = k[i] * fill / pivot - (k[n - 2] if i + 1 == n - 2 else 0)
            pivot = following
        negative += pivot < 0
        last -= fill * fill / pivot
        return negative + int(last < 0)


def covered(mass: np.ndarray, springs: np.ndarray, omega: float, error: float, j: int) -> bool:
    """Whether [(omega - error)^2, (omega + error)^2] holds the j-th eigenvalue omega_j^2."""
    with mp.workdps(40):
        low = mp.mpf(omega) - mp.mpf(error)
        high = (mp.mpf(omega) + mp.mpf(error)) ** 2
        below = 0 if low <= 0 else ring_count(mass, springs, low**2)
        return below <= j < ring_count(mass, springs, high)


def mp_weighted_gram(B: np.ndarray, springs: np.ndarray, mass: np.ndarray) -> mp.matrix:
    """K~ = M^-1/2 B^T W B M^-1/2 in mpmath at the working precision, from the inputs."""
    n = B.shape[1]
    Kt = mp.matrix(n, n)
    for i in range(n):
        for j in range(n):
            Kt[i, j] = sum(mp.mpf(springs[r]) * mp.mpf(B[r, i]) * mp.mpf(B[r, j]) for r in range(len(springs))
                           ) / mp.sqrt(mp.mpf(mass[i]) * mp.mpf(mass[j]))
    return Kt


def small_ring(rng: np.random.Generator, spreads: tuple[float, ...]
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """(B, springs, mass, spread): 3-11 sites, masses and springs over one of `spreads`, B's
    entries not +-1, a spring to a wall in about 2 of 5."""
    n, spread = int(rng.integers(3, 12)), float(rng.choice(spreads))
    springs = 10.0 ** rng.uniform(-spread / 2, spread / 2, n)
    mass = 10.0 ** rng.uniform(-spread / 2, spread / 2, n)
    B = np.zeros((n, n))
    B[np.arange(n), np.arange(n)] = -rng.uniform(0.2, 1.0, n)
    B[np.arange(n), (np.arange(n) + 1) % n] = rng.uniform(0.2, 1.0, n)
    if rng.random() < 0.4:
        wall = np.zeros((1, n))
        wall[0, rng.integers(n)] = rng.uniform(0.2, 1.0)
        B, springs = np.vstack([B, wall]), np.r_[springs, 10.0 ** rng.uniform(-spread / 2, spread / 2)]
    return B, springs, mass, spread


def disordered_ring(n: int, spread: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return 10.0 ** rng.uniform(0.0, spread, n), 10.0 ** rng.uniform(0.0, spread, n)


def sampled(n: int, relative: np.ndarray, rng: np.random.Generator) -> list[int]:
    """The lowest and highest modes, the loosest bounds and a random sample."""
    loosest = np.argsort(-relative)[:8]
    return sorted({0, 1, 2, 3, n - 2, n - 1, *loosest.tolist(), *rng.choice(n, 8, replace=False).tolist()})


def walled_ring(n: int, spread: float, seed: int, walls: int | None = None
                ) -> tuple[sp.csr_matrix, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(B, w, mass, springs, ground): n sites on a ring (spring i joins sites i and i + 1 mod n),
    a spring to a wall at every site (walls None) or at `walls` random sites (ground[i] the
    wall spring at site i, 0 where none); masses and springs log-uniform over 10^spread."""
    rng = np.random.default_rng(seed)
    springs = 10.0 ** rng.uniform(-spread / 2, spread / 2, n)
    mass = 10.0 ** rng.uniform(-spread / 2, spread / 2, n)
    where = np.arange(n) if walls is None else np.sort(rng.choice(n, walls, replace=False))
    ground = np.zeros(n)
    ground[where] = 10.0 ** rng.uniform(-spread / 2, spread / 2, where.shape[0])
    sites = np.arange(n)
    cycle_part = sp.csr_matrix((np.r_[-np.ones(n), np.ones(n)], (np.r_[sites, sites], np.r_[sites, (sites + 1) % n])),
                               shape=(n, n))
    wall_part = sp.csr_matrix((np.ones(where.shape[0]), (np.arange(where.shape[0]), where)), shape=(where.shape[0], n))
    return sp.vstack([cycle_part, wall_part]).tocsr(), np.r_[springs, ground[where]], mass, springs, ground


def walled_covered(mass: np.ndarray, springs: np.ndarray, ground: np.ndarray, omega: float, error: float, j: int,
            dps: int = 40) -> bool:
    """Whether [(omega - error)^2, (omega + error)^2] holds the j-th eigenvalue."""
    with mp.workdps(dps):
        low, high = (mp.mpf(omega) - mp.mpf(error)) ** 2, (mp.mpf(omega) + mp.mpf(error)) ** 2
        return ring_count(mass, springs, low, dps, ground) <= j < ring_count(mass, springs, high, dps, ground)


def certified_by_eigsy(B: np.ndarray, springs: np.ndarray, mass: np.ndarray, solve: Any) -> None:
    """All values and the lowest 1 and 2 (`solve(count)`): each certified, walled_covered by its bound
    against mpmath.eigsy of K~ at 80 digits, and within 2e-13 relative in omega^2."""
    with mp.workdps(80):
        exact = sorted(mp.eigsy(mp_weighted_gram(B, springs, mass), eigvals_only=True))
    for count in (None, 1, 2):
        found = solve(count)
        assert found is not None and found.certified.all()
        assert np.all(found.bound <= 2e-13 * found.values)
        with mp.workdps(80):
            for j in range(found.values.shape[0]):
                assert abs(mp.mpf(found.values[j]) - exact[j]) <= found.bound[j], (B.shape, count, j)


def kernel_arrays(pencil: ring_counts.RingPencil) -> tuple:
    m, w, c_in, c_out = ring_values.spring_arrays(pencil)
    n = pencil.n
    compliance = div(np.ones(n), np.zeros(n), w, np.zeros(n))
    off = np.empty(2 * n - 1)
    off[0::2], off[1::2] = c_in, c_out[: n - 1]
    return m, compliance, off, mul(off, np.zeros_like(off), off, np.zeros_like(off)), float(c_out[n - 1])
