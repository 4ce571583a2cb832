"""The three accuracy levels (issue 29, item 1): "fast", "high" (the default) and "certified",
with the same meaning and keywords on `normal_modes`, `System.modes` and
`GeneralizedSystem.modes`; "high" leaves to "certified" the steps that only tighten a bound
already within 1e-10, and no step's choice depends on the clock.

Truth: closed forms (the free chain, seed 003 eq. 161), 40-digit mpmath of B~ formed from the
inputs (`tests/solvers/test_accurate_bounds.py`), and mpmath sums for the compiled error-free product.
"""

from __future__ import annotations

import mpmath
import numpy as np
import pytest
import scipy.sparse as sp

from vibra import System, normal_modes, solvers
from vibra.mechanics.lagrangian import double_pendulum
from vibra.solvers import budget
from vibra.solvers.accurate import golub_kahan, spring_ritz
from helpers.springs import network
from helpers.springs import mp_spring_omegas


def free_chain(n: int) -> System:
    return System.from_springs(np.arange(n, dtype=float), 1.0, np.c_[np.arange(n - 1), np.arange(1, n)], 1.0)


def chain_exact(n: int, k: int) -> np.ndarray:
    """omega_j = 2 sin(j pi / 2n), m = kappa = 1 (seed 003 eq. 161, free ends), in mpmath."""
    with mpmath.workdps(40):
        return np.array([float(2 * mpmath.sin(mpmath.mpf(j) * mpmath.pi / (2 * n))) for j in range(k)])


def test_the_levels_are_one_tuple_everywhere() -> None:
    assert solvers.ACCURACY_LEVELS == ("fast", "high", "certified")


@pytest.mark.parametrize("call", ["normal_modes", "System.modes", "GeneralizedSystem.modes"])
def test_an_unknown_level_is_refused_by_name(call: str) -> None:
    chain = free_chain(4)
    with pytest.raises(ValueError, match=r"accuracy"):
        if call == "normal_modes":
            normal_modes(chain.hessian(), chain.mass_matrix(), accuracy="exact")
        elif call == "System.modes":
            chain.modes(accuracy="exact")  # type: ignore[arg-type]
        else:
            double_pendulum().modes(accuracy="exact")  # type: ignore[arg-type]


def test_fast_drops_the_spring_factor_and_accurate_needs_it() -> None:
    chain = free_chain(50)
    fast = normal_modes(chain.hessian(), chain.mass_matrix(), spring_factor=chain.spring_factor(), accuracy="fast")
    assert fast.solver == "dense"
    with pytest.raises(ValueError, match=r"accuracy"):
        normal_modes(chain.hessian(), chain.mass_matrix(), spring_factor=chain.spring_factor(), accuracy="fast",
                     solver="accurate")
    for level in ("high", "certified"):
        assert chain.modes(accuracy=level).solver == "accurate-bidiagonal"


def test_generalized_modes_take_the_same_keywords() -> None:
    """GeneralizedSystem.modes: accuracy, max_memory, max_seconds, progress (and device) as
    `normal_modes`; the seed's double pendulum against eq. (15) at every level."""
    pendulum = double_pendulum(m=1.0, m_prime=1.0, a=1.0, b=1.0, g=1.0)
    seen: list[float] = []
    for level in solvers.ACCURACY_LEVELS:
        modes = pendulum.modes(accuracy=level, max_memory=1e9, max_seconds=60.0,  # type: ignore[arg-type]
                               progress=lambda fraction, message: seen.append(fraction))
        np.testing.assert_allclose(modes.omega**2, [2 - np.sqrt(2), 2 + np.sqrt(2)], rtol=1e-14)


def test_both_levels_keep_a_long_chain_on_the_ritz_path_bracketed_by_counts() -> None:
    """The lowest modes of a 30,000-site chain: spring-space Rayleigh-Ritz at any length, each
    value bracketed by Sturm counts of the chain's spring form ("high" from 3e-14; "certified"
    from 8 eps, its values the vectors' Rayleigh quotients in double-double, each bound within
    1e-15 relative); both within 1e-10 of the closed form, each bound covering it."""
    n, k = 30_000, 8
    system = free_chain(n)
    exact = chain_exact(n, k)
    for level, path in (("high", "accurate-ritz"), ("certified", "accurate-ritz")):
        modes = system.modes(k, accuracy=level)  # type: ignore[arg-type]
        assert modes.solver == path
        np.testing.assert_allclose(modes.omega[1:], exact[1:], rtol=1e-10)
        assert np.all(np.abs(modes.omega[1:] - exact[1:]) <= modes.omega_error[1:])
        plan = solvers.plan(system.hessian(), system.mass_matrix(), n_modes=k, vectors=True, band=None,
                            solver="auto", spring_factor=system.spring_factor(), accuracy=level)
        assert plan.path == path and plan.accuracy == level
        if level == "certified":
            assert np.all(modes.omega_error[1:] <= 1e-15 * modes.omega[1:])


def test_high_runs_no_triplet_step_on_a_large_network_and_its_estimate_counts_none() -> None:
    """A network whose Golub-Kahan matrix has more than `golub_kahan.HIGH_ROWS` rows: "high"
    bounds its modes without the singular-triplet step (a protein's factorisation took 115 s
    there), and the plan's estimate includes none of it; "certified" estimates it."""
    rng = np.random.default_rng(3)
    positions = rng.uniform(0.0, (1500 / 0.05) ** (1 / 3), size=(1500, 3))
    from vibra import networks

    system = networks.anm(positions, cutoff=8.5)
    B, w = system.spring_factor()
    assert B.shape[0] + B.shape[1] > golub_kahan.HIGH_ROWS
    n = system.n_dof
    high = budget.refinement_seconds(n, B.shape[0], k=26, accuracy="high")
    certified = budget.refinement_seconds(n, B.shape[0], k=26, accuracy="certified")
    assert high == 0.0 < certified
    modes = system.modes(26)
    assert modes.solver == "accurate-ritz"
    assert "singular triplets" not in (modes.refinement or "")
    fast = system.modes(26, accuracy="fast")
    np.testing.assert_allclose(modes.omega[6:], fast.omega[6:], rtol=1e-8)


@pytest.mark.parametrize("vectors", [False, True])
def test_high_and_certified_on_a_spread_network_cover_mpmath(vectors: bool) -> None:
    """A 20-site network, springs over 1e12 and masses over 1e6: at both levels every
    frequency within 1e-10 of 40-digit mpmath, every bound covering the true error; certified's
    within 1000x the error or 1e-13; high's within 1e-10 or named in `refinement`."""
    B, springs, masses = network(np.random.default_rng(4), 20, 6.0, 3.0)
    K = B.T @ (springs[:, None] * B)
    reference = mp_spring_omegas(B, springs, masses, digits=40)[6:]
    slack = 0.5 * np.spacing(reference)
    for level in ("high", "certified"):
        modes = normal_modes(0.5 * (K + K.T), masses, spring_factor=(sp.csr_matrix(B), springs), vectors=vectors,
                             accuracy=level)
        error = np.abs(modes.omega[6:] - reference)
        bound = modes.omega_error[6:]
        assert np.all(error <= 1e-10 * reference)
        assert np.all(bound + slack >= error)
        if level == "certified":
            assert np.all(bound <= np.maximum(1000 * error, 1e-13 * reference))
        else:
            assert np.all(bound <= 1e-10 * reference) or 'accuracy="certified"' in modes.refinement


def test_the_triplet_budget_is_work_not_time() -> None:
    """`golub_kahan` has no wall-clock cap: which modes get refined depends on the factors'
    sizes only, so the same input gives the same bounds on any machine."""
    assert not hasattr(golub_kahan, "TRIPLET_SECONDS")
    B, springs, masses = network(np.random.default_rng(7), 30, 6.0, 3.0)
    K = B.T @ (springs[:, None] * B)
    runs = [normal_modes(0.5 * (K + K.T), masses, spring_factor=(sp.csr_matrix(B), springs), vectors=False,
                         accuracy="certified") for _ in range(2)]
    np.testing.assert_array_equal(runs[0].omega, runs[1].omega)
    np.testing.assert_array_equal(runs[0].omega_error, runs[1].omega_error)


def test_compiled_error_free_product_is_within_one_unit_of_the_exact_sum() -> None:
    """`spring_ritz._compiled_product` (triple-double sums) against the numpy loop it replaces
    and against 80-digit mpmath sums: entries spread over 1e+-8 with cancellation, each
    result within one long-double unit of the exact sum."""
    rng = np.random.default_rng(11)
    B = sp.random(400, 300, density=0.02, random_state=5, format="csr")
    B.data = rng.standard_normal(B.nnz) * 10.0 ** rng.uniform(-8, 8, B.nnz)
    V = rng.standard_normal((300, 5)) * 10.0 ** rng.uniform(-4, 4, (300, 5))
    Bl, Vl = B.astype(np.longdouble), V.astype(np.longdouble)
    compiled = spring_ritz._compiled_product(Bl, Vl)
    loop = spring_ritz._numpy_product(Bl, Vl)
    unit = float(np.finfo(np.longdouble).eps)
    assert np.all(np.abs(compiled - loop) <= 2 * unit * np.abs(loop))
    with mpmath.workdps(80):
        for i in range(0, 400, 7):
            for j in range(5):
                exact = mpmath.fsum(mpmath.mpf(float(B.data[p])) * mpmath.mpf(float(V[B.indices[p], j]))
                                    for p in range(B.indptr[i], B.indptr[i + 1]))
                value = compiled[i, j]
                got = mpmath.mpf(float(value)) + mpmath.mpf(float(value - np.longdouble(float(value))))
                assert abs(got - exact) <= unit * abs(exact)


def test_high_brackets_a_long_chain_by_sturm_counts() -> None:
    """A free chain of 100,000 sites, lowest 12 with vectors, "high": spring-space Rayleigh-Ritz
    values each bracketed by two Sturm counts of the chain's spring form (no residual bounds):
    every bound covers the closed form's error and stays within 1e-12 relative (the brackets
    start at 3e-14; the values' rounding is ~1e-14); the rigid mode counted within
    `accurate.zero_level` of zero (((t + 12) n eps)^2 ||K~||: omega ~6e-10, far below omega_1)."""
    n, k = 100_000, 12
    modes = free_chain(n).modes(k, accuracy="high")
    exact = chain_exact(n, k)
    assert modes.solver == "accurate-ritz"
    assert np.all(np.abs(modes.omega[1:] - exact[1:]) <= modes.omega_error[1:])
    assert np.all(modes.omega_error[1:] <= 1e-12 * modes.omega[1:])
    assert modes.omega_error[0] <= 1e-4 * modes.omega[1]
    assert modes.residual <= 1e-13


def test_the_chain_form_built_at_once_equals_the_one_built_node_by_node() -> None:
    """`sturm_counts._free_form` (array operations, free chains) against the general walk
    (`_walked_form`), disordered masses and springs, several chains side by side."""
    from vibra.solvers.accurate.chain import sturm_counts

    rng = np.random.default_rng(4)
    n = 300
    bonds = np.array([(i, i + 1) for i in range(n - 1) if i % 97 != 50])  # three chains
    system = System.from_springs(np.arange(n, dtype=float), 10.0 ** rng.uniform(-3, 3, n), bonds,
                                 10.0 ** rng.uniform(-3, 3, len(bonds)))
    coupling, weights = system.spring_factor()
    B, per_row = sturm_counts.stored_factor(coupling)
    mass = np.asarray(system.mass_matrix())
    at_once = sturm_counts._free_form(B, np.asarray(weights, dtype=float), mass)
    walked = sturm_counts._walked_form(B, per_row, np.asarray(weights, dtype=float), mass)
    assert at_once is not None and walked is not None
    for name in ("site", "m", "compliance", "squares", "widening"):
        np.testing.assert_array_equal(np.asarray(getattr(at_once, name)), np.asarray(getattr(walked, name)), err_msg=name)


def test_high_leaves_a_long_rings_pairs_at_their_count_bounds() -> None:
    """A uniform ring of 60,000 sites, lowest 10, values only: "high" keeps the counts' own
    bounds (within 1e-10 relative, each covering the closed form's error) and skips the pair
    step that "certified" runs to reach 1e-13."""
    n = 60_000
    ring = System.from_springs(np.arange(n, dtype=float), 1.0,
                               np.r_[np.c_[np.arange(n - 1), np.arange(1, n)], [[n - 1, 0]]], 1.0)
    with mpmath.workdps(30):
        truth = np.sort(np.array([float(2 * mpmath.sin(mpmath.pi * min(j, n - j) / n)) for j in range(6)] * 2))[1:11]
    high = ring.modes(n_modes=10, vectors=False, accuracy="high")
    certified = ring.modes(n_modes=10, vectors=False, accuracy="certified")
    for modes in (high, certified):
        assert modes.solver == "accurate-ring"
        assert np.all(np.abs(modes.omega[1:] - truth[1:]) <= modes.omega_error[1:])
    assert np.all(high.omega_error[1:] <= 1e-10 * high.omega[1:])
    assert "tightened" not in high.refinement and "tightened" in certified.refinement
    assert np.all(certified.omega_error[1:] <= 1e-13 * certified.omega[1:])


def test_certified_brackets_a_chains_double_double_ritz_values() -> None:
    """"certified" on a chain's Ritz path: its values the vectors' Rayleigh quotients in
    double-double, bracketed by Sturm counts from 8 eps, each bound within 1e-15 relative and
    covering the closed form's error (10,000 sites, lowest 12)."""
    n, k = 10_000, 12
    modes = free_chain(n).modes(k, accuracy="certified")
    exact = chain_exact(n, k)
    assert modes.solver == "accurate-ritz"
    assert np.all(np.abs(modes.omega[1:] - exact[1:]) <= modes.omega_error[1:])
    assert np.all(modes.omega_error[1:] <= 1e-15 * modes.omega[1:])
