"""Tests of vibra.chains: builders against independently built matrices and closed forms.

Truth comes from (a) stiffness matrices assembled here element by element, (b) scipy's
dense `eigh` of those matrices, (c) textbook closed forms (seed 003 section 5.3; Lagrange's
beaded string; Montroll-Potts), never from vibra's own assembly or solvers.
"""

from __future__ import annotations

import dataclasses

import mpmath
import numpy as np
import pytest
import scipy.linalg as la

from vibra import Modes, System, chains

EPS = np.finfo(float).eps
ENDS = ("free", "fixed", "periodic")


def explicit_stiffness(n: int, k: np.ndarray, ends: str) -> np.ndarray:
    """K of a 1-D chain written out bond by bond (bond order as documented by linear_chain)."""
    K = np.zeros((n, n))

    def spring(i: int, j: int | None, kappa: float) -> None:  # j None: a wall
        K[i, i] += kappa
        if j is not None:
            K[j, j] += kappa
            K[i, j] -= kappa
            K[j, i] -= kappa

    if ends == "free":
        for i in range(n - 1):
            spring(i, i + 1, k[i])
    elif ends == "fixed":
        spring(0, None, k[0])
        for i in range(n - 1):
            spring(i, i + 1, k[i + 1])
        spring(n - 1, None, k[n])
    else:
        for i in range(n):
            spring(i, (i + 1) % n, k[i])
    return K


def dense_omega(K: np.ndarray, masses: np.ndarray) -> np.ndarray:
    """Independent reference: scipy's generalised symmetric eigensolver, sqrt of |lambda|."""
    return np.sqrt(np.abs(la.eigh(K, np.diag(masses), eigvals_only=True)))


def n_bonds(n: int, ends: str) -> int:
    return {"free": n - 1, "fixed": n + 1, "periodic": n}[ends]


# ---------------------------------------------------------------------- assembly
@pytest.mark.parametrize("ends", ENDS)
@pytest.mark.parametrize("n", [2, 3, 9])
def test_linear_chain_hessian_matches_explicit_matrix(rng, ends, n):
    masses = rng.uniform(0.5, 2.0, n)
    k = rng.uniform(0.5, 2.0, n_bonds(n, ends))
    system = chains.linear_chain(n, mass=masses, stiffness=k, spacing=0.3, ends=ends)
    # Assembly is a sum of a few products of exact inputs: equal to rounding (1e-14 relative).
    np.testing.assert_allclose(system.hessian().toarray(), explicit_stiffness(n, k, ends), rtol=0, atol=1e-14 * k.max())
    np.testing.assert_array_equal(system.mass_matrix(), masses)
    np.testing.assert_allclose(system.positions[:, 0], 0.3 * np.arange(n))
    assert system.n_dof == n and system.spring_factor() is not None


def test_diatomic_chain_layout():
    system = chains.diatomic_chain(3, masses=(1.0, 5.0), stiffness=(2.0, 7.0), spacing=0.5, ends="fixed")
    np.testing.assert_array_equal(system.masses, [1, 5, 1, 5, 1, 5])
    # wall -k2- m1 -k1- m2 -k2- m1 ... m2 -k2- wall: bonds [k2, k1, k2, k1, k2, k1, k2]
    expected = explicit_stiffness(6, np.array([7, 2, 7, 2, 7, 2, 7.0]), "fixed")
    np.testing.assert_allclose(system.hessian().toarray(), expected, rtol=0, atol=1e-13)
    ring = chains.diatomic_chain(2, masses=(1.0, 5.0), stiffness=(2.0, 7.0), ends="periodic")
    np.testing.assert_allclose(ring.hessian().toarray(), explicit_stiffness(4, np.array([2, 7, 2, 7.0]), "periodic"),
                               rtol=0, atol=1e-13)


@pytest.mark.parametrize("ends", ENDS)
def test_beaded_string_is_transverse_chain_of_tension_over_spacing(ends):
    n, tension, spacing = 6, 3.0, 0.25
    system = chains.beaded_string(n, mass=2.0, tension=tension, spacing=spacing, ends=ends)
    assert system.dim == 2 and system.n_dof == n
    assert [system.labels[i] for i in system.free_dofs] == [f"{i}y" for i in range(n)]
    K = explicit_stiffness(n, np.full(n_bonds(n, ends), tension / spacing), ends)
    np.testing.assert_allclose(system.hessian().toarray(), K, rtol=0, atol=1e-13)


def test_beaded_string_three_beads_lagrange():
    # Three beads on a fixed string: omega^2 = (T / m d) (2 - sqrt 2, 2, 2 + sqrt 2) (classic result).
    T, m, d = 5.0, 0.2, 0.1
    expected = np.sqrt(T / (m * d) * np.array([2 - np.sqrt(2), 2.0, 2 + np.sqrt(2)]))
    np.testing.assert_allclose(chains.beaded_string_frequencies(3, m, T, d), expected, rtol=4 * EPS)
    omega = chains.beaded_string(3, mass=m, tension=T, spacing=d).modes().omega
    np.testing.assert_allclose(omega, expected, rtol=1e-13)  # accurate path: a few ulps


# ---------------------------------------------------------------------- closed forms
@pytest.mark.parametrize("ends", ENDS)
@pytest.mark.parametrize("n", [2, 3, 8, 51])
def test_monatomic_closed_form_against_scipy(ends, n):
    m, k = 1.7, 2.9
    reference = dense_omega(explicit_stiffness(n, np.full(n_bonds(n, ends), k), ends), np.full(n, m))
    closed = chains.monatomic_frequencies(n, m, k, ends=ends)
    # eigh is accurate to ~eps ||K~|| = eps * 4k/m in omega^2: compare omega^2 at 1e-13 * omega_max^2.
    np.testing.assert_allclose(closed**2, reference**2, rtol=0, atol=1e-13 * 4 * k / m)


@pytest.mark.parametrize("ends", ENDS)
def test_monatomic_shapes_are_eigenvectors(ends):
    n, m, k = 12, 1.0, 1.0
    K = explicit_stiffness(n, np.full(n_bonds(n, ends), k), ends)
    shapes = chains.monatomic_shapes(n, ends=ends)
    omega = chains.monatomic_frequencies(n, m, k, ends=ends)
    # Exact closed forms: residual at rounding level (1e-13 of ||K|| = 4).
    np.testing.assert_allclose(K @ shapes, shapes * omega**2, rtol=0, atol=1e-13)
    np.testing.assert_allclose(shapes.T @ shapes, np.eye(n), rtol=0, atol=1e-13)


@pytest.mark.parametrize("n_cells", [1, 2, 5, 16])
def test_diatomic_periodic_closed_form_against_scipy(n_cells):
    masses, stiffness = (1.0, 3.5), (2.0, 0.7)
    k = np.tile(stiffness, n_cells)
    reference = dense_omega(explicit_stiffness(2 * n_cells, k, "periodic"), np.tile(masses, n_cells))
    closed = chains.diatomic_frequencies(n_cells, masses, stiffness)
    np.testing.assert_allclose(closed**2, reference**2, rtol=0, atol=1e-13 * 8)  # eps ||K~||, ||K~|| < 8


def test_diatomic_branches_textbook_limits():
    m1, m2, k = 1.0, 4.0, 2.0
    acoustic, optical = chains.diatomic_branches([0.0, np.pi], m1, m2, k, k, cell_length=1.0)
    # Equal springs: omega_A(pi/a) = sqrt(2k/M), omega_O(pi/a) = sqrt(2k/m), omega_O(0) = sqrt(2k(1/m1 + 1/m2)).
    np.testing.assert_allclose(acoustic, [0.0, np.sqrt(2 * k / m2)], rtol=4 * EPS, atol=0)
    np.testing.assert_allclose(optical, [np.sqrt(2 * k * (1 / m1 + 1 / m2)), np.sqrt(2 * k / m1)], rtol=4 * EPS)
    # Long waves: omega_A ~ c q with c = a sqrt(k1 k2 / ((k1 + k2)(m1 + m2))) = a sqrt(k / 2(m1 + m2)).
    q = 1e-7
    acoustic_small, _ = chains.diatomic_branches(q, m1, m2, k, k)
    np.testing.assert_allclose(acoustic_small, q * np.sqrt(k / (2 * (m1 + m2))), rtol=1e-12)
    edges = chains.diatomic_band_edges((m1, m2), k)
    np.testing.assert_allclose(edges, [[0, np.sqrt(2 * k / m2)], [np.sqrt(2 * k / m1), np.sqrt(2 * k * 1.25)]],
                               rtol=4 * EPS)


@pytest.mark.parametrize("ends", ["free", "fixed"])
def test_diatomic_free_and_fixed_within_bands(ends):
    n_cells, masses, stiffness = 60, (1.0, 3.0), (1.0, 1.6)
    system = chains.diatomic_chain(n_cells, masses=masses, stiffness=stiffness, ends=ends)
    k = {"free": np.tile(stiffness, n_cells)[:-1],
         "fixed": np.concatenate([[stiffness[1]], np.tile(stiffness, n_cells)[:-1], [stiffness[1]]])}[ends]
    reference = dense_omega(explicit_stiffness(2 * n_cells, k, ends), system.masses)
    omega = system.modes(vectors=False).omega
    np.testing.assert_allclose(omega**2, reference**2, rtol=0, atol=1e-12 * 8)
    edges = chains.diatomic_band_edges(masses, stiffness)
    inside = ((omega <= edges[0, 1] * (1 + 1e-12)) | ((omega >= edges[1, 0] * (1 - 1e-12)) & (omega <= edges[1, 1] * (1 + 1e-12))))
    # Bulk modes lie in the bands; a finite chain may add at most one surface mode per end in the gap.
    assert (~inside).sum() <= 2
    assert omega.max() <= edges[1, 1] * (1 + 1e-12)


# ---------------------------------------------------------------------- System.modes against closed forms
@pytest.mark.parametrize("ends", ENDS)
@pytest.mark.parametrize("n", [2, 3, 10, 300])
def test_linear_chain_modes_full_spectrum(ends, n):
    m, k = 0.8, 5.0
    modes = chains.linear_chain(n, mass=m, stiffness=k, ends=ends).modes()
    exact = chains.monatomic_frequencies(n, m, k, ends=ends)
    nonzero = exact > 0
    # The accurate path promises high relative accuracy: 1e-12 per mode (observed ~1e-14).
    np.testing.assert_allclose(modes.omega[nonzero], exact[nonzero], rtol=1e-12)
    assert np.all(np.abs(modes.omega[~nonzero]) <= 1e-6 * exact.max())  # the rigid translation
    M = np.diag(modes.mass)
    np.testing.assert_allclose(modes.shapes.T @ M @ modes.shapes, np.eye(n), rtol=0, atol=1e-10)


@pytest.mark.parametrize("ends", ["free", "fixed"])
def test_linear_chain_2000_frequencies(ends):
    m, k = 1.0, 1.0
    omega = chains.linear_chain(2000, mass=m, stiffness=k, ends=ends).modes(vectors=False).omega
    exact = chains.monatomic_frequencies(2000, m, k, ends=ends)
    np.testing.assert_allclose(omega[1:], exact[1:], rtol=1e-12)


@pytest.mark.parametrize("ends", ENDS)
def test_lowest_modes_of_a_long_chain_to_high_relative_accuracy(ends):
    n = 100_000
    modes = chains.linear_chain(n, mass=1.0, stiffness=1.0, ends=ends).modes(n_modes=5)
    exact = chains.monatomic_frequencies(n, 1.0, 1.0, ends=ends)[:5]
    nonzero = exact > 0
    # Issue requirement: the lowest mode of a 10^5 chain to 1e-10 relative (a standard
    # tridiagonal solver keeps ~6 digits here: omega_1 ~ 3e-5 * omega_max).
    np.testing.assert_allclose(modes.omega[nonzero], exact[nonzero], rtol=1e-10)


def test_diatomic_chain_modes_periodic_against_closed_form():
    modes = chains.diatomic_chain(40, masses=(1.0, 2.5), stiffness=(1.0, 3.0), ends="periodic").modes()
    exact = chains.diatomic_frequencies(40, (1.0, 2.5), (1.0, 3.0))
    np.testing.assert_allclose(modes.omega[1:], exact[1:], rtol=1e-12)


def test_long_diatomic_ring_lowest_modes_against_closed_form():
    # 10^5 sites (50,000 cells): the lowest acoustic modes, omega_1 ~ 1e-4 omega_max, through
    # System.modes against the Bloch closed form. The accurate path keeps relative accuracy
    # (observed ~3e-15); 1e-10 as for the monatomic 10^5 chain.
    n_cells, masses, stiffness = 50_000, (1.0, 2.5), (1.0, 3.0)
    modes = chains.diatomic_chain(n_cells, masses=masses, stiffness=stiffness, ends="periodic").modes(n_modes=5)
    exact = chains.diatomic_frequencies(n_cells, masses, stiffness)[:5]
    np.testing.assert_allclose(modes.omega[1:], exact[1:], rtol=1e-10)


def test_beaded_string_modes_against_closed_form():
    modes = chains.beaded_string(200, mass=0.01, tension=50.0, spacing=0.005).modes(n_modes=4)
    exact = chains.beaded_string_frequencies(200, 0.01, 50.0, 0.005)[:4]
    np.testing.assert_allclose(modes.omega, exact, rtol=1e-12)
    # and the continuum string: omega_k = k pi sqrt(T / mu) / L, mu = m / d, L = (n + 1) d,
    # to within the chain's (k pi)^2 / 24 (n + 1)^2 dispersion (< 2e-4 here).
    mu, L = 0.01 / 0.005, 201 * 0.005
    string = np.arange(1, 5) * np.pi * np.sqrt(50.0 / mu) / L
    np.testing.assert_allclose(modes.omega, string, rtol=(4 * np.pi) ** 2 / 24 / 201**2 * 1.01)


# ---------------------------------------------------------------------- mass defect
def test_light_mass_defect_localised_mode_montroll_potts():
    n, m, k = 401, 1.0, 1.0
    defect, centre = 0.5, 200  # eps = 0.5
    masses = np.full(n, m)
    masses[centre] = defect
    modes = chains.linear_chain(n, mass=masses, stiffness=k, ends="fixed").modes()
    omega_max = 2.0 * np.sqrt(k / m)
    expected = chains.montroll_potts_frequency(omega_max, m, defect)
    np.testing.assert_allclose(expected, omega_max / np.sqrt(1 - 0.5**2), rtol=4 * EPS)
    # Finite-size error: the mode decays as r^|i - 200|, r = 1/3, so the walls 200 sites away
    # shift it by ~r^400 ~ 1e-190: the infinite-chain value holds to rounding (1e-12 here).
    np.testing.assert_allclose(modes.omega[-1], expected, rtol=1e-12)
    assert modes.omega[-2] < omega_max  # the rest stays in the band
    shape = modes.shapes[:, -1]
    ratio = chains.montroll_potts_decay(m, defect)
    assert ratio == pytest.approx(1.0 / 3.0, rel=4 * EPS)
    near = shape[centre: centre + 12]
    # Exponential decay with alternating sign; components down to 1e-6 of the peak keep
    # ~1e-8 relative accuracy (residual ~1e-15 ||K~||), hence rtol 1e-6.
    np.testing.assert_allclose(near[1:] / near[:-1], -ratio, rtol=1e-6)
    np.testing.assert_allclose(shape[centre - 11: centre + 1][::-1], near, rtol=1e-6)


# ---------------------------------------------------------------------- Fourier modes
@pytest.mark.parametrize("n", [2, 3, 4, 9, 64])
def test_periodic_modes_monatomic(n):
    system = chains.linear_chain(n, mass=2.0, stiffness=3.0, ends="periodic")
    modes = chains.periodic_modes(system)
    assert modes.solver == "fourier"
    np.testing.assert_allclose(modes.omega, chains.monatomic_frequencies(n, 2.0, 3.0, ends="periodic"), rtol=4 * EPS)
    K = explicit_stiffness(n, np.full(n, 3.0), "periodic")
    shapes = modes.shapes
    # Independent eigen-check on the explicit matrix: K u = omega^2 M u, u^T M u = I.
    np.testing.assert_allclose(K @ shapes, 2.0 * shapes * modes.omega**2, rtol=0, atol=1e-13 * 12)
    np.testing.assert_allclose(shapes.T @ (2.0 * shapes), np.eye(n), rtol=0, atol=1e-13)
    assert modes.residual < 1e-14 and modes.orthogonality < 1e-13


@pytest.mark.parametrize("n_cells", [1, 2, 3, 10])
def test_periodic_modes_diatomic(n_cells):
    masses, stiffness = (1.0, 3.0), (2.0, 0.5)
    system = chains.diatomic_chain(n_cells, masses=masses, stiffness=stiffness, ends="periodic")
    modes = chains.periodic_modes(system)
    k = np.tile(stiffness, n_cells)
    K = explicit_stiffness(2 * n_cells, k, "periodic")
    mass = np.tile(masses, n_cells)
    np.testing.assert_allclose(modes.omega**2, dense_omega(K, mass) ** 2, rtol=0, atol=1e-13 * 8)
    np.testing.assert_allclose(K @ modes.shapes, mass[:, None] * modes.shapes * modes.omega**2, rtol=0, atol=1e-12)
    np.testing.assert_allclose(modes.shapes.T @ (mass[:, None] * modes.shapes), np.eye(2 * n_cells), rtol=0, atol=1e-13)


@pytest.mark.slow  # ~3 s alone, more on a loaded machine: 10^6-site build + Fourier modes
def test_periodic_modes_million_sites_lowest_only():
    n = 1_000_000
    system = chains.linear_chain(n, ends="periodic", units="dimensionless")
    modes = chains.periodic_modes(system, n_modes=6)
    assert modes.vectors.shape == (n, 6)
    exact = chains.monatomic_frequencies(n, 1.0, 1.0, ends="periodic")[:6]
    np.testing.assert_allclose(modes.omega, exact, rtol=4 * EPS)
    assert [list(g) for g in modes.degenerate_groups()] == [[1, 2], [3, 4]]
    # The orthogonality of 10^6-long cos/sin columns is measured with sums of 10^6 terms:
    # rounding up to ~1e6 * eps ~ 1e-10.
    assert modes.residual < 1e-13 and modes.orthogonality < 1e-10


def test_periodic_modes_values_only_and_partial():
    system = chains.diatomic_chain(50, masses=(1.0, 2.0), ends="periodic")
    modes = chains.periodic_modes(system, n_modes=7, vectors=False)
    assert modes.vectors is None and modes.shapes is None and modes.n_modes == 7
    np.testing.assert_allclose(modes.omega, chains.diatomic_frequencies(50, (1.0, 2.0), 1.0)[:7], rtol=4 * EPS)
    string = chains.periodic_modes(chains.beaded_string(10, tension=2.0, spacing=0.5, ends="periodic"))
    np.testing.assert_allclose(string.omega, chains.beaded_string_frequencies(10, 1.0, 2.0, 0.5, ends="periodic"),
                               rtol=4 * EPS)


def test_periodic_modes_result_is_immutable():
    modes = chains.periodic_modes(chains.linear_chain(5, ends="periodic"))
    assert isinstance(modes, Modes)
    with pytest.raises(dataclasses.FrozenInstanceError):
        modes.omega = np.zeros(5)  # type: ignore[misc]
    for array in (modes.omega, modes.vectors, modes.shapes, modes.mass, modes.omega_error):
        with pytest.raises(ValueError, match="read-only"):
            array[0] = 1.0


def test_periodic_modes_rejects_other_systems():
    with pytest.raises(TypeError, match="system must be a vibra.System"):
        chains.periodic_modes("chain")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="not a periodic chain"):
        chains.periodic_modes(chains.linear_chain(5, ends="free"))
    with pytest.raises(ValueError, match="not a periodic chain"):
        chains.periodic_modes(chains.linear_chain(5, ends="fixed"))
    with pytest.raises(ValueError, match="period 1 or 2"):
        chains.periodic_modes(chains.linear_chain(6, mass=[1, 2, 3, 1, 2, 3], ends="periodic"))
    with pytest.raises(ValueError, match="Hessian given directly"):
        chains.periodic_modes(System.from_hessian(np.arange(2.0), [1.0, 1.0], np.eye(2)))
    with pytest.raises(ValueError, match="n_modes is 7"):
        chains.periodic_modes(chains.linear_chain(5, ends="periodic"), n_modes=7)


# ---------------------------------------------------------------------- validation
def test_builder_validation_messages():
    with pytest.raises(ValueError, match=r"n is 1; a chain needs n >= 2"):
        chains.linear_chain(1)
    with pytest.raises(TypeError, match=r"n must be an int, got float"):
        chains.linear_chain(5.0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"mass\[3\] is 0.0; every mass must be positive"):
        chains.linear_chain(5, mass=[1, 1, 1, 0, 1])
    with pytest.raises(ValueError, match=r"mass must have 5 entries \(one per site\), got 4"):
        chains.linear_chain(5, mass=[1, 1, 1, 1])
    with pytest.raises(ValueError, match=r"stiffness\[0\] is -1.0; every spring constant must be positive"):
        chains.linear_chain(3, stiffness=[-1.0, 1.0])
    with pytest.raises(ValueError, match=r"stiffness\[0\] is 0.0; every spring constant must be positive"):
        chains.linear_chain(3, stiffness=0.0)
    with pytest.raises(ValueError, match=r"stiffness must have 6 entries for 5 sites with fixed ends"):
        chains.linear_chain(5, stiffness=np.ones(4), ends="fixed")
    with pytest.raises(ValueError, match=r"stiffness must have 4 entries for 4 sites with periodic ends"):
        chains.linear_chain(4, stiffness=np.ones(3), ends="periodic")
    with pytest.raises(ValueError, match=r"stiffness must have 3 entries for 4 sites with free ends"):
        chains.linear_chain(4, stiffness=np.ones(4))
    with pytest.raises(ValueError, match=r"ends is 'open'; expected one of 'free', 'fixed', 'periodic'"):
        chains.linear_chain(4, ends="open")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"spacing is 0.0; a spacing must be positive"):
        chains.linear_chain(4, spacing=0.0)
    with pytest.raises(ValueError, match=r"n_cells is 0; a chain needs n_cells >= 1"):
        chains.diatomic_chain(0)
    with pytest.raises(ValueError, match=r"masses must be one value or a pair"):
        chains.diatomic_chain(3, masses=(1.0, 2.0, 3.0))
    with pytest.raises(ValueError, match=r"masses\[1\] is -2.0"):
        chains.diatomic_chain(3, masses=(1.0, -2.0))
    with pytest.raises(ValueError, match=r"stiffness\[1\] is 0.0"):
        chains.diatomic_chain(3, stiffness=(1.0, 0.0))
    with pytest.raises(ValueError, match=r"ends is 'open'"):
        chains.diatomic_chain(3, ends="open")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"tension is -1.0; a tension must be positive"):
        chains.beaded_string(4, tension=-1.0)
    with pytest.raises(ValueError, match=r"n is 1"):
        chains.beaded_string(1)
    with pytest.raises(ValueError, match=r"mass must have 4 entries"):
        chains.beaded_string(4, mass=[1.0, 2.0])


def test_closed_form_validation_messages():
    with pytest.raises(ValueError, match=r"ends is 'free'; diatomic_frequencies has a closed form for ends='periodic' only"):
        chains.diatomic_frequencies(4, ends="free")
    with pytest.raises(ValueError, match=r"defect_mass is 2.0 >= mass 1.0"):
        chains.montroll_potts_frequency(2.0, 1.0, 2.0)
    with pytest.raises(ValueError, match=r"defect_mass is 1.0 >= mass 1.0"):
        chains.montroll_potts_decay(1.0, 1.0)
    with pytest.raises(ValueError, match=r"omega_max is 0.0; a frequency must be positive"):
        chains.montroll_potts_frequency(0.0, 1.0, 0.5)
    with pytest.raises(ValueError, match=r"modes must be 1-D mode indices in \[0, 3\]"):
        chains.monatomic_shapes(4, modes=[4])
    with pytest.raises(ValueError, match=r"n is 1"):
        chains.monatomic_frequencies(1)
    with pytest.raises(ValueError, match=r"k1 is -1.0; a spring constant must be positive"):
        chains.diatomic_branches(0.1, 1.0, 1.0, -1.0, 1.0)
    with pytest.raises(ValueError, match=r"cell_length is 0.0"):
        chains.diatomic_branches(0.1, 1.0, 1.0, 1.0, 1.0, cell_length=0.0)


def test_scalar_arguments_are_named_without_an_index():
    # A bad scalar is reported by name alone ("spacing is nan"), not as "spacing[] is nan".
    with pytest.raises(ValueError, match=r"^spacing is nan; it must be finite$"):
        chains.linear_chain(4, spacing=float("nan"))
    with pytest.raises(ValueError, match=r"^mass is nan; it must be finite$"):
        chains.linear_chain(4, mass=float("nan"))
    with pytest.raises(ValueError, match=r"^stiffness is inf; it must be finite$"):
        chains.linear_chain(4, stiffness=np.inf)
    with pytest.raises(ValueError, match=r"^tension is inf; it must be finite$"):
        chains.beaded_string(4, tension=np.inf)
    with pytest.raises(TypeError, match=r"^spacing must be a real number, got str$"):
        chains.linear_chain(4, spacing="1 m")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"^mass must be 1-D, got shape \(2, 2\)$"):
        chains.linear_chain(4, mass=np.ones((2, 2)))
    with pytest.raises(ValueError, match=r"^masses\[0\] is nan; every entry must be finite$"):
        chains.diatomic_chain(3, masses=(np.nan, 1.0))


def test_monatomic_shapes_rejects_non_integer_mode_indices():
    # 1.7 used to be truncated to mode 1 silently.
    with pytest.raises(ValueError, match=r"modes must be 1-D mode indices in \[0, 3\] \(ints\), got \[1.7\]"):
        chains.monatomic_shapes(4, modes=[1.7])
    np.testing.assert_array_equal(chains.monatomic_shapes(4, modes=[2]), chains.monatomic_shapes(4)[:, [2]])


def test_periodic_modes_rejects_rings_that_are_not_chains():
    # n springs, each a difference of two dofs with unit weight, but one joins 0 and 2.
    shortcut = System.from_springs(np.arange(4.0), 1.0, [[0, 1], [1, 2], [2, 3], [0, 2]], 1.0)
    with pytest.raises(ValueError, match=r"^system is not a periodic chain: its springs do not join i to i \+ 1"):
        chains.periodic_modes(shortcut)
    # A term measuring u_0 + u_1 (a sum, not a difference), closing a 2-site ring.
    summed = System.from_terms(np.arange(2.0), 1.0, [[-1.0, 1.0], [1.0, 1.0]], [1.0, 1.0])
    with pytest.raises(ValueError, match=r"^system is not a periodic chain: a spring does not measure a difference"):
        chains.periodic_modes(summed)
    pendulums = System.generalized(np.eye(2), [[2.0, -1.0], [-1.0, 2.0]])
    with pytest.raises(ValueError, match=r"^system is in generalised coordinates; periodic_modes needs a ring"):
        chains.periodic_modes(pendulums)
    with pytest.raises(TypeError, match=r"^n_modes must be an int, got float$"):
        chains.periodic_modes(chains.linear_chain(5, ends="periodic"), n_modes=2.0)  # type: ignore[arg-type]


def bloch_matrix(phase: float, m1: float, m2: float, k1: float, k2: float) -> np.ndarray:
    """Mass-weighted 2x2 dynamical matrix of the cell m1 -k1- m2 -k2- at Bloch phase q a (Hermitian)."""
    off = -(k1 + k2 * np.exp(-1j * phase)) / np.sqrt(m1 * m2)
    return np.array([[(k1 + k2) / m1, off], [np.conj(off), (k1 + k2) / m2]])


@pytest.mark.parametrize(("m1", "m2", "k1", "k2"), [(1.0, 2.0, 1.0, 1.0), (1.0, 1.0, 3.0, 0.5), (2.0, 7.0, 0.3, 4.0)])
def test_diatomic_eigenvalues_are_those_of_the_bloch_matrix(m1, m2, k1, k2):
    phases = np.linspace(-np.pi, np.pi, 9)
    low, high = chains.diatomic_eigenvalues(phases, m1, m2, k1, k2)
    expected = np.array([la.eigvalsh(bloch_matrix(p, m1, m2, k1, k2)) for p in phases])
    scale = (k1 + k2) * (m1 + m2) / (m1 * m2)
    np.testing.assert_allclose(low, expected[:, 0], atol=8 * EPS * scale)
    np.testing.assert_allclose(high, expected[:, 1], atol=8 * EPS * scale)
    half = chains.diatomic_half_splitting(phases, m1, m2, k1, k2)
    np.testing.assert_allclose(half, (expected[:, 1] - expected[:, 0]) / 2, atol=8 * EPS * scale)


def test_diatomic_eigenvalues_keep_relative_accuracy_near_q_zero():
    """Truth: lambda = S/2 -+ sqrt(S^2/4 - P) evaluated with mpmath at 50 digits."""
    m1, m2, k1, k2 = 1.0, 3.0, 2.0, 0.5
    for phase in (1e-3, 1e-6, 1e-9):
        low, high = chains.diatomic_eigenvalues(phase, m1, m2, k1, k2)
        with mpmath.workdps(50):
            S = mpmath.mpf(k1 + k2) * (m1 + m2) / (m1 * m2)
            P = 4 * mpmath.mpf(k1 * k2) * mpmath.sin(mpmath.mpf(phase) / 2) ** 2 / (m1 * m2)
            root = mpmath.sqrt(S ** 2 / 4 - P)
            low_exact, high_exact = float(S / 2 - root), float(S / 2 + root)
        assert float(low) == pytest.approx(low_exact, rel=8 * EPS)
        assert float(high) == pytest.approx(high_exact, rel=8 * EPS)
        assert float(chains.diatomic_half_splitting(phase, m1, m2, k1, k2)) == pytest.approx(float(root), rel=8 * EPS)


def test_bloch_problem_validation_messages():
    with pytest.raises(ValueError, match=r"^phase\[1\] is nan; every entry must be finite$"):
        chains.diatomic_eigenvalues([0.0, np.nan], 1.0, 1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match=r"^m2 is -1.0; a mass must be positive and finite$"):
        chains.diatomic_eigenvalues(0.0, 1.0, -1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match=r"^k2 is 0.0; a spring constant must be positive and finite$"):
        chains.diatomic_half_splitting(0.0, 1.0, 1.0, 1.0, 0.0)
    with pytest.raises(ValueError, match=r"^phase must be 1-D, got shape \(1, 1\)$"):
        chains.diatomic_half_splitting([[0.0]], 1.0, 1.0, 1.0, 1.0)
