"""High accuracy that costs only what it buys, and says what it did (issue 14, item 1).

`Modes.refined` / `Modes.refinement` on every accurate path, None on the standard ones; the
checked path (vectors for every mode, Rayleigh-Ritz only below the a-priori bound's reach) and
the large-system branch (``accurate-rayleigh``).

Truth: closed forms (CO2 axial; the anisotropic simple-cubic lattice whose x, y and z motions
split into uniform free chains, 4 kappa_a sin^2(j pi / 2 side)), 50-digit mpmath
(`tests/solvers/test_solvers.mp_spring_omegas`), numpy's dense eigh of a well-conditioned network, and the
six rigid-body zero modes of a free 3-D cluster.
"""

from __future__ import annotations

import dataclasses
import pickle
import re
from pathlib import Path

import mpmath
import numpy as np
import pytest
import scipy.linalg
import scipy.sparse as sp
from helpers.springs import (
    anisotropic_lattice,
    lattice_frequencies,
    mp_spring_omegas,
    network,
    solve,
)

from vibra import System, normal_modes, solvers
from vibra.chains.builders import linear_chain

SOLVERS_PAGE = Path(__file__).resolve().parents[2] / "docs" / "solvers.md"


def random_network(n_sites: int, seed: int = 0) -> System:
    """Uniform random sites at density 0.05 with unit springs within 8.5 units (well conditioned)."""
    rng = np.random.default_rng(seed)
    side = (n_sites / 0.05) ** (1.0 / 3.0)
    positions = rng.uniform(0.0, side, size=(n_sites, 3))
    distance = np.linalg.norm(positions[:, None] - positions[None], axis=-1)
    pairs = np.argwhere(np.triu(distance < 8.5, 1))
    return System.from_springs(positions, 1.0, pairs, 1.0)


# ---------------------------------------------------------------------- the fields
def test_standard_paths_leave_refinement_none() -> None:
    K = np.array([[1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])  # CO2 axial, kappa = 1
    modes = normal_modes(K, [16.0, 12.0, 16.0])
    assert modes.solver == "dense" and modes.refined is None and modes.refinement is None
    assert "refined" not in modes.summary()


def test_refined_is_frozen_and_survives_pickling() -> None:
    system = linear_chain(5, ends="periodic", stiffness=[1.0, 1e12, 1.0, 1e12, 1.0])  # a ring: accurate-*
    modes = system.modes()
    assert modes.solver.startswith("accurate-") and modes.refined is not None
    assert modes.refined.dtype == bool and modes.refined.shape == modes.omega.shape
    with pytest.raises(ValueError):
        modes.refined[0] = not modes.refined[0]
    with pytest.raises(dataclasses.FrozenInstanceError):
        modes.refinement = "edited"  # type: ignore[misc]
    copy = pickle.loads(pickle.dumps(modes))
    np.testing.assert_array_equal(copy.refined, modes.refined)
    assert copy.refinement == modes.refinement and not copy.refined.flags.writeable
    assert copy != modes and modes == modes  # eq=False: identity, as before


def test_summary_reports_path_accuracy_and_refinement(rng: np.random.Generator) -> None:
    B, springs, masses = network(rng, 30, 6.0, 3.0)
    modes = solve(B, springs, masses)
    text = modes.summary()
    assert text.splitlines()[0] == f"{modes.n_modes} modes of {modes.n_dof} dofs by the accurate-jacobi path"
    assert f"refined: {modes.n_modes} of {modes.n_modes}: " in text and "Jacobi" in text
    assert "residual" in text and "orthogonality" in text


# ---------------------------------------------------------------------- each accurate path fills it
def test_jacobi_refines_every_mode_and_says_why(rng: np.random.Generator) -> None:
    """Springs 1e-6..1e6, masses 1e-3..1e3: the spring-space bounds of the lowest modes miss;
    every mode then comes from Jacobi (within 1e-10 of mpmath), and the text counts the misses."""
    B, springs, masses = network(rng, 30, 6.0, 3.0)
    modes = solve(B, springs, masses, vectors=False)
    assert modes.solver == "accurate-jacobi"
    assert modes.refined is not None and modes.refined.all()
    match = re.match(r"(\d+) of 90 modes missed 1e-10 relative after spring-space Rayleigh-Ritz "
                     r"\(error/omega\^2 up to [^)]+\): one-sided Jacobi SVD \(gejsv\) of B~ on all"
                     r"(; (\d+) bounds tightened by singular triplets \(Golub-Kahan inverse iteration\)"
                     r"(, \d+ still above 2e-13 omega\^2)?)?"
                     r"(; (\d+) bounds tightened by inverse iteration in double-double)?$", modes.refinement)
    assert match and 1 <= int(match.group(1)) <= 90
    reference = mp_spring_omegas(B, springs, masses)
    assert np.max(np.abs(modes.omega[6:] - reference[6:]) / reference[6:]) < 1e-10


@pytest.mark.parametrize("vectors", [False, True])
def test_checked_path_refines_only_below_the_a_priori_reach(vectors: bool) -> None:
    """A well-conditioned 900-dof network: only the six rigid-body modes (omega^2 ~ 0, out of any relative bound's reach) are
    refined; every flexible frequency within 1e-10 relative of numpy's dense eigh (itself within
    ~1e-13 here), bounds within 1e-10 relative and covering that difference less eigh's error."""
    system = random_network(300)
    modes = system.modes(vectors=vectors)
    assert modes.solver == "accurate-checked"
    assert modes.refined is not None and int(modes.refined.sum()) == 6 and modes.refined[:6].all()
    assert modes.refinement.startswith("6 of 900 modes below that bound's reach refined by spring-space "
                                       "Rayleigh-Ritz (6 zero within rounding); 894 kept from the dense solve")
    assert int(modes.zero_modes().sum()) == 6
    K = system.hessian().toarray()
    reference = np.sqrt(np.maximum(scipy.linalg.eigh(K, eigvals_only=True), 0.0))
    flexible = slice(6, None)
    difference = np.abs(modes.omega[flexible] - reference[flexible])
    assert np.all(difference <= 1e-10 * reference[flexible])
    assert np.all(modes.omega_error[flexible] <= 1e-10 * reference[flexible])
    eigh_error = 1e-13 * reference[flexible]  # well conditioned: omega^2 >= 1e-2 ||K~||
    assert np.all(modes.omega_error[flexible] + eigh_error >= difference)


def test_ritz_and_bidiagonal_and_bisection_paths_fill_it() -> None:
    ritz = linear_chain(10_000).modes(n_modes=5)
    assert ritz.solver == "accurate-ritz" and ritz.refined is not None and ritz.refined.all()
    assert ritz.refinement.startswith("all 5 modes by spring-space Rayleigh-Ritz on 6 shift-invert vectors")
    chain = linear_chain(50).modes()
    assert chain.solver == "accurate-bidiagonal" and chain.refined is not None and chain.refined.all()
    assert chain.refinement.startswith("all 50 modes from the relative-accuracy SVD")
    rng = np.random.default_rng(5)
    disordered = linear_chain(2000, mass=10.0 ** rng.uniform(0, 12, 2000), stiffness=10.0 ** rng.uniform(0, 12, 1999),
                              units="dimensionless")
    lowest = disordered.modes(n_modes=4, vectors=False)
    assert lowest.solver == "accurate-bisection" and lowest.refined is not None and lowest.refined.all()
    assert lowest.refinement.startswith("all 4 modes by bisection")
    # the closed form of the uniform free chain: omega_k = 2 sin(k pi / 2N) (unit mass and spring)
    k = np.arange(50)
    np.testing.assert_allclose(chain.omega[1:], 2.0 * np.sin(k[1:] * np.pi / 100), rtol=1e-13)


@pytest.mark.parametrize("vectors", [False, True])
def test_rayleigh_path_reached_on_purpose_values_and_vectors(vectors: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    """All modes of a 1,536-dof lattice (over DENSE_LIMIT, not a path) with JACOBI_WORK set to
    0 (as for a network whose n_terms n^2 exceeds it): ``accurate-rayleigh``, the checked solve
    without Jacobi. Truth: the lattice's closed form (see the module doc);
    stiffnesses 1e-4, 1, 1e4: the soft and unit chains' modes lie below the a-priori bound's
    reach and are refined, the stiff chains' upper modes keep the fast values."""
    monkeypatch.setattr(solvers.common, "JACOBI_WORK", 0)
    side, stiffness = 8, (1.0, 1e-4, 1e4)
    system = anisotropic_lattice(side, stiffness)
    assert system.n_dof > solvers.DENSE_LIMIT
    modes = system.modes(vectors=vectors)
    assert modes.solver == "accurate-rayleigh"
    exact = lattice_frequencies(side, stiffness)
    flexible = exact > 0
    assert np.max(np.abs(modes.omega[flexible] - exact[flexible]) / exact[flexible]) < 1e-10
    # the bound covers the error (the float64 closed form is itself rounded: 4 eps relative)
    slack = 4 * np.finfo(float).eps * exact[flexible]
    assert np.all(modes.omega_error[flexible] + slack >= np.abs(modes.omega[flexible] - exact[flexible]))
    assert modes.refined is not None and 0 < int(modes.refined.sum()) < modes.n_modes
    assert modes.refined[exact < 1.0].all()  # every soft- and unit-chain mode is below the reach
    assert modes.refinement.startswith(f"{int(modes.refined.sum())} of 1536 modes below that bound's reach")


# ---------------------------------------------------------------------- docs/solvers.md's table
def test_every_path_auto_can_pick_is_in_the_solver_page_table() -> None:
    table = [line for line in SOLVERS_PAGE.read_text(encoding="utf-8").splitlines() if line.startswith("| `")]
    listed = {name for line in table for name in re.findall(r"`([a-z][a-z +-]*)`", line.split("|")[1])}  # (a crystal's "hermitian-eigh + spring-svd")
    missing = [path for path in solvers.SOLVER_PATHS if path not in listed]
    assert not missing, f"docs/solvers.md's table lacks {missing}"


def test_spring_factor_rounding_enters_the_a_priori_bound() -> None:
    """The bound of a certified mode covers the difference between K (assembled by the caller)
    and B^T W B within the factor check's tolerance: K here is B^T W B to rounding, and the
    certified values equal numpy's eigh of that K~ within the reported bound plus eigh's own."""
    system = random_network(100)
    K = system.hessian().toarray()
    modes = normal_modes(K, np.ones(K.shape[0]), spring_factor=system.spring_factor(), vectors=False)
    assert modes.solver == "accurate-checked"
    reference = np.sqrt(np.maximum(scipy.linalg.eigh(K, eigvals_only=True), 0.0))
    kept = ~modes.refined
    norm = float(np.abs(K).sum(axis=1).max())
    eigh_error = (K.shape[0] + 32) * np.finfo(float).eps * norm / (2 * reference[kept])
    assert np.all(np.abs(modes.omega[kept] - reference[kept]) <= modes.omega_error[kept] + eigh_error)
    assert sp.issparse(system.spring_factor()[0])


def test_triplet_work_cap_leaves_the_rest_as_they_were_and_says_so(rng: np.random.Generator,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """"high"'s triplet budget (`golub_kahan.HIGH_WORK`, counted in fill, never in seconds)
    spent after the first mode: one bound tightened, the count of those still above 1e-10
    omega^2 in the text, and every bound still covers 50-digit mpmath."""
    from vibra.solvers.accurate import springs as accurate_springs

    B, springs, masses = network(rng, 30, 6.0, 3.0)
    monkeypatch.setattr(accurate_springs, "HIGH_WORK", 1.0)
    modes = solve(B, springs, masses, vectors=False, accuracy="high")
    match = re.search(r"; 1 bounds tightened by singular triplets \(Golub-Kahan inverse iteration\), "
                      r"(\d+) still above 1e-10 omega\^2", modes.refinement)
    assert match and int(match.group(1)) >= 1
    exact = mp_spring_omegas(B, springs, masses, exact=True)
    with mpmath.workdps(50):  # the error in mpmath: a float64 truth rounds by ~1e-16 itself
        errors = [float(abs(mpmath.mpf(float(w)) - value)) for w, value in zip(modes.omega[6:], exact[6:])]
    assert np.all(modes.omega_error[6:] >= np.array(errors))
