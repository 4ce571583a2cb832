"""`solve`: choose a solver path from the structure of K~ and what is asked, and run it."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from vibra.solvers.accurate import accurate_path
from vibra.solvers.common import (
    BAND_LIMIT, DENSE_ALL_LIMIT, DENSE_LIMIT, SolveResult, bandwidth, mass_weighted,
)
from vibra.solvers.sparse import sparse_path
from vibra.solvers.standard import banded_path, dense_path, tridiagonal_path

#: The solver names that `normal_modes(solver=...)`, `System.modes(solver=...)` and scene
#: files accept; ``"auto"`` chooses one of the others.
SOLVER_NAMES = ("auto", "dense", "tridiagonal", "banded", "sparse", "accurate")

#: The paths a result can report in `Modes.solver` (``"accurate"`` runs one of the four
#: ``accurate-*`` paths).
SOLVER_PATHS = ("dense", "tridiagonal", "banded", "sparse", "accurate-bidiagonal", "accurate-ritz",
                "accurate-rayleigh", "accurate-jacobi")


def solve(
    K: NDArray[np.float64] | sp.csr_matrix,
    mass: NDArray[np.float64],
    *,
    n_modes: int | None,
    vectors: bool,
    band: tuple[float, float] | None,
    solver: str,
    spring_factor: tuple[sp.csr_matrix, NDArray[np.float64]] | None,
) -> SolveResult:
    """Run the solver path `solver` ("auto" chooses) on K~ and return a `SolveResult`.

    Examples
    --------
    >>> import numpy as np
    >>> K = np.array([[1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])   # CO2 axial, kappa = 1
    >>> result = solve(K, np.array([1.0, 2.0, 1.0]), n_modes=None, vectors=False, band=None,
    ...                solver="dense", spring_factor=None)
    >>> np.round(result.eigenvalues, 12)          # 0, kappa / m, kappa (1/m + 2/M) (eq. 157)
    array([0., 1., 2.])
    """
    n = K.shape[0]
    Kt = mass_weighted(K, mass)
    width = bandwidth(Kt) if mass.ndim == 1 else n
    tridiagonal = width <= 1
    partial = n_modes is not None and n_modes < n
    if solver == "auto":
        if spring_factor is not None:
            solver = "accurate"
        elif n <= DENSE_LIMIT:
            solver = "dense"
        elif width <= BAND_LIMIT and not (vectors and (partial or band is not None)):
            # (LAPACK's banded and tridiagonal drivers allocate n x n vectors even for a subset)
            solver = "tridiagonal" if tridiagonal else "banded"
        elif partial or band is not None:
            solver = "sparse"
        else:
            solver = "dense"
    if solver == "dense" and n > DENSE_ALL_LIMIT:
        raise ValueError(
            f"K has {n} dofs: a dense solve would need {8 * n * n / 2**30:.1f} GiB; ask for "
            "n_modes (a partial sparse solve) or use the accurate path of a spring system"
        )
    if solver == "tridiagonal" and not tridiagonal:
        raise ValueError("solver='tridiagonal' needs a tridiagonal K and diagonal masses")
    if solver == "banded" and mass.ndim != 1:
        raise ValueError("solver='banded' needs diagonal masses")
    if solver == "sparse" and n_modes is None and band is None:
        raise ValueError("solver='sparse' computes a few modes: give n_modes or band")
    if solver == "accurate":
        if spring_factor is None:
            raise ValueError("solver='accurate' needs the spring factor (B, w) of K")
        return accurate_path(Kt, mass, spring_factor, n_modes=n_modes, vectors=vectors, band=band)
    if solver == "tridiagonal":
        result = tridiagonal_path(Kt, n_modes=n_modes, vectors=vectors, band=band)
    elif solver == "banded":
        result = banded_path(Kt, width, n_modes=n_modes, vectors=vectors, band=band)
    elif solver == "sparse":
        result = sparse_path(Kt, n_modes=n_modes, vectors=vectors, band=band)
    else:
        result = dense_path(Kt, n_modes=n_modes, vectors=vectors, band=band)
    return result


