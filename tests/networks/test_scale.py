"""Free 3-D networks past the dense limit: the sparse shift-invert paths (issue 14, item 2).

Truth: numpy's dense `eigh` of the same K~ (well-conditioned networks: absolute accuracy
suffices), residual norms computed here, and rigid-body mechanics (six zero modes).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from vibra import networks, solvers


@pytest.fixture(scope="module")
def free_network() -> tuple[object, np.ndarray]:
    """A random free 3-D network of 600 sites (1,800 dofs > DENSE_LIMIT) and its dense eigenvalues."""
    rng = np.random.default_rng(14)
    side = (600 / 0.05) ** (1.0 / 3.0)
    system = networks.anm(rng.uniform(0.0, side, size=(600, 3)), cutoff=7.0)
    assert system.n_dof > solvers.DENSE_LIMIT
    K = system.hessian()
    dense = K.toarray() if sp.issparse(K) else np.asarray(K)
    return system, np.linalg.eigvalsh(dense)


@pytest.mark.parametrize("accuracy", ["fast", "high"])
def test_lowest_modes_of_a_free_network(free_network: tuple[object, np.ndarray], accuracy: str) -> None:
    """26 lowest modes: exactly six zero modes, the others within 1e-10 of dense eigh, and the vectors
    accurate (relative residual below 1e-12: the zero modes deflated before the rest converge)."""
    system, reference = free_network
    modes = system.modes(26, accuracy=accuracy)  # type: ignore[attr-defined]
    assert modes.solver == ("sparse" if accuracy == "fast" else "accurate-ritz")
    assert int(modes.zero_modes().sum()) == 6
    flexible = slice(6, 26)
    assert np.max(np.abs(modes.omega_squared[flexible] / reference[flexible] - 1.0)) < 1e-10
    K = system.hessian()  # type: ignore[attr-defined]
    V = modes.vectors  # unit masses: mass-weighted vectors are the shapes
    residual = np.linalg.norm(K @ V - V * modes.omega_squared, axis=0)
    assert residual.max() < 1e-12 * reference.max()
    assert modes.residual < 1e-12


def test_bounds_of_the_partial_paths_cover_the_error(free_network: tuple[object, np.ndarray]) -> None:
    """The reported omega^2 error is never below the true one (against dense eigh's values, whose own
    error, ~n eps ||K~||, is added to the comparison)."""
    system, reference = free_network
    n = reference.shape[0]
    slack = n * np.finfo(float).eps * reference.max()
    for accuracy in ("fast", "high"):
        modes = system.modes(26, accuracy=accuracy)  # type: ignore[attr-defined]
        error = np.abs(modes.omega_squared[6:] - reference[6:26])
        bound = 2 * np.abs(modes.omega[6:]) * modes.omega_error[6:]
        assert np.all(bound + slack >= error)
