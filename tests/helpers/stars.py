"""A star of M identical arms and its spectrum from two small chains (apart from any solver under test).

Site 0 is the hub; ARM sites an arm, springs 1 to the hub and 1 + 0.3 s along the arm; unit masses. A mode in which
the hub stays still moves each arm as a chain walled at the hub, M - 1 independent ways (amplitudes summing to zero);
a mode in which every arm moves alike is a chain of the hub and one arm whose masses and springs are M times heavier.
Their values, with those multiplicities, are the star's whole spectrum (`tests/solvers/test_multiple_values.py`
checks the split against eigvalsh of the whole matrix).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp


def _springs(arm: int) -> np.ndarray:
    return np.r_[1.0, 1.0 + 0.3 * np.arange(1, arm)]  # hub-first bond, then along the arm


def star(arms: int, arm: int) -> sp.csr_matrix:
    """K of the star: site 0 the hub, arm a's sites 1 + a arm ... (a + 1) arm, hub side first."""
    springs = _springs(arm)
    first, second, weight = [], [], []
    for a in range(arms):
        sites = 1 + a * arm + np.arange(arm)
        first += [0, *sites[:-1]]
        second += list(sites)
        weight += list(springs)
    m = len(weight)
    B = sp.csr_matrix((np.r_[np.ones(m), -np.ones(m)], (np.r_[np.arange(m), np.arange(m)], np.r_[first, second])),
                      shape=(m, 1 + arms * arm))
    return (B.T @ sp.diags(weight) @ B).tocsr()


def star_spectrum(arms: int, arm: int) -> np.ndarray:
    """The star's eigenvalues from its two small chains (see the module's docstring), ascending."""
    k = _springs(arm)
    inner = np.r_[k[1:], 0.0]  # the spring beyond each site (none past the tip)
    walled = np.diag(k + inner) - np.diag(k[1:], 1) - np.diag(k[1:], -1)
    together = np.zeros((arm + 1, arm + 1))  # hub (mass 1) and one arm carrying all M
    together[0, 0] = arms * k[0]
    together[0, 1] = together[1, 0] = -arms * k[0]
    together[1:, 1:] = arms * walled
    scale = np.r_[1.0, np.full(arm, 1.0 / np.sqrt(arms))]  # M^-1/2 K M^-1/2, the arm's masses M
    together = scale[:, None] * together * scale[None, :]
    values = np.r_[np.repeat(la.eigvalsh(walled), arms - 1), la.eigvalsh(together)]
    return np.sort(values)
