"""When "high" expects loose bounds (issue 45, item 4: estimates from the problem, not its size).

The accurate dense paths check every mode in spring space; a bound that still misses 1e-10
relative sends the solve to one-sided Jacobi and the triplet step. Whether that happens depends
on the data (springs and masses over decades), so the estimate asks `Problem.loose` (K~'s
diagonal spread over `common.LOOSE_SPREAD`), not the Golub-Kahan matrix's size: a protein's
uniform ANM under `golub_kahan.HIGH_ROWS` rows no longer pays for a step that never runs.

Truth: what the solve itself does on the same input (the path it reports, the steps its
`refinement` names), seeded inputs, no clock.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.sparse as sp

from vibra import networks, normal_modes, solvers
from vibra.solvers import budget
from vibra.solvers.accurate import golub_kahan
from helpers.springs import network

UBIQUITIN = Path(__file__).resolve().parents[2] / "networks" / "ubiquitin" / "1ubi.pdb"


def _plan(K: np.ndarray | sp.spmatrix, mass: np.ndarray, factor: tuple, n_modes: int | None) -> solvers.SolvePlan:
    return solvers.plan(K, mass, n_modes=n_modes, vectors=True, band=None, solver="auto", spring_factor=factor)


def _spring_system(seed: int, sites: int, spring_decades: float, mass_decades: float):
    B, w, masses = network(np.random.default_rng(seed), sites, spring_decades, mass_decades)
    K = B.T @ (w[:, None] * B)
    return 0.5 * (K + K.T), masses, (sp.csr_matrix(B), w)


def test_a_uniform_protein_network_expects_no_loose_bound_and_has_none() -> None:
    """Ubiquitin's ANM (228 dofs, H of 1,656 rows, under HIGH_ROWS): K~'s diagonal spreads ~10,
    the plan expects no loose bound and counts no triplet; the solve runs none and stays on the
    checked path."""
    system = networks.anm(networks.from_pdb(UBIQUITIN).positions)
    factor = system.spring_factor()
    plan = _plan(system.hessian(), system.mass_matrix(), factor, 26)
    assert factor[0].shape[0] + factor[0].shape[1] <= golub_kahan.HIGH_ROWS
    assert plan.problem.spread > 1.0 and plan.problem.spread < 100.0 and not plan.problem.loose
    n, terms = plan.problem.n, plan.problem.n_terms
    assert budget.refinement_seconds(n, terms, k=26, loose=False) == 0.0
    assert budget.refinement_seconds(n, terms, k=26, loose=True) > 0.0  # what it used to count
    modes = system.modes(26)
    assert modes.path == plan.path == "accurate-checked"
    assert "singular triplets" not in (modes.refinement or "") and "Jacobi" not in (modes.refinement or "")


def test_springs_and_masses_over_decades_are_expected_loose_and_fall_back() -> None:
    """Springs over +-6 decades, masses over +-3 (150 sites): K~'s diagonal spreads past 1e8, where
    every measured network fell back; the plan counts the fallback and the solve takes it."""
    K, masses, factor = _spring_system(3, 150, 6.0, 3.0)
    plan = _plan(K, masses, factor, 20)
    assert plan.problem.spread > 1e8 and plan.problem.loose
    modes = normal_modes(K, masses, spring_factor=factor, n_modes=20)
    assert modes.path == "accurate-jacobi"  # the fallback the estimate counted


def test_the_fallback_is_counted_only_where_loose() -> None:
    """The same springs' pattern, uniform and spread: the spread one's estimate exceeds the uniform
    one's by at least the Jacobi fallback (JACOBI_FALLBACK_S n_terms n^2)."""
    K_spread, m_spread, f_spread = _spring_system(4, 150, 6.0, 3.0)
    B, _ = f_spread
    w = np.ones(B.shape[0])
    K_uniform = (B.T @ B).toarray()
    uniform = _plan(K_uniform, np.ones(B.shape[1]), (B, w), 20)
    spread = _plan(K_spread, m_spread, f_spread, 20)
    assert uniform.path == spread.path == "accurate-checked"
    assert not uniform.problem.loose and spread.problem.loose
    fallback = budget.JACOBI_FALLBACK_S * float(max(B.shape)) * B.shape[1] ** 2
    assert spread.cost.seconds - uniform.cost.seconds >= fallback

