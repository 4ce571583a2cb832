"""vibra.crystals: D(q), its frequencies and eigenvectors (issue 30, items 1-2 and 7).

Truth: closed forms of nearest-neighbour spring lattices (sc, fcc, the square lattice, the
diatomic chain), each built here from the textbook sum D(k) = sum_nn (k/m)(1 - cos k.r) e e^T
or its explicit branches; phonopy on the same force constants (its own D(q) and eigh); the
acoustic sum rule and the invariants of D(q) under reciprocal lattice vectors and phases.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from vibra import crystals
from vibra.crystals import Crystal

RNG = np.random.default_rng(30)
# Away from Gamma every |omega| here is O(1) in its units and LAPACK's absolute error is
# ~(3n + 32) eps ||D||, a few 1e-15 relative: 1e-12 leaves a factor 100 for the assembly's rounding.
CLOSED_RTOL = 1e-12


def cartesian(crystal: Crystal, q: np.ndarray) -> np.ndarray:
    """Cartesian wave vectors 2 pi q @ inv(cell)^T (the definition, not the code's helper)."""
    return 2.0 * np.pi * q @ np.linalg.inv(crystal.cell).T


def textbook(k_vectors: np.ndarray, neighbours: np.ndarray, stiffness: float, mass: float) -> np.ndarray:
    """Sorted omega of D(k) = sum_nn (k/m)(1 - cos k.r) e e^T, one atom per cell."""
    unit = neighbours / np.linalg.norm(neighbours, axis=1)[:, None]
    weight = 1.0 - np.cos(k_vectors @ neighbours.T)  # (n_q, n_nn)
    d = stiffness / mass * np.einsum("qn,na,nb->qab", weight, unit, unit)
    return np.sqrt(np.clip(np.linalg.eigvalsh(d), 0.0, None))


def test_fcc_nearest_neighbours_match_the_textbook_sum_and_the_lines() -> None:
    a, m, k = 1.7, 2.3, 0.9
    crystal = crystals.fcc(a, m, k)
    neighbours = np.array([[s1, s2, 0] for s1 in (-1, 1) for s2 in (-1, 1)]
                          + [[s1, 0, s2] for s1 in (-1, 1) for s2 in (-1, 1)]
                          + [[0, s1, s2] for s1 in (-1, 1) for s2 in (-1, 1)], dtype=float) * a / 2
    q = RNG.random((200, 3))
    np.testing.assert_allclose(crystal.frequencies(q), textbook(cartesian(crystal, q), neighbours, k, m),
                               rtol=CLOSED_RTOL, atol=1e-7)  # atol: the zero modes at Gamma (sqrt of eps)
    # Gamma -> X along [100]: omega_L^2 = (8k/m) sin^2(pi xi / 2), omega_T^2 = (4k/m) sin^2(pi xi / 2)
    xi = np.linspace(0.05, 1.0, 20)
    q_line = (xi[:, None] * np.array([1.0, 0.0, 0.0])) @ crystal.cell.T / a  # fractional of k = (2 pi / a)(xi,0,0)
    omega = crystal.frequencies(q_line)
    s = np.abs(np.sin(np.pi * xi / 2))
    np.testing.assert_allclose(omega[:, 2], np.sqrt(8 * k / m) * s, rtol=CLOSED_RTOL)
    np.testing.assert_allclose(omega[:, :2], (np.sqrt(4 * k / m) * s)[:, None].repeat(2, 1), rtol=CLOSED_RTOL)
    assert crystal.frequencies([[0.5, 0.0, 0.5]])[0, 2] == pytest.approx(np.sqrt(8 * k / m), rel=CLOSED_RTOL)


def test_simple_cubic_branches_are_the_three_chains() -> None:
    a, m, k = 2.0, 3.0, 5.0
    crystal = crystals.simple_cubic(a, m, k)
    q = RNG.random((100, 3))
    expected = np.sort(np.sqrt(2 * k / m * (1 - np.cos(2 * np.pi * q))), axis=1)  # omega_x^2 = (2k/m)(1 - cos k_x a)
    np.testing.assert_allclose(crystal.frequencies(q), expected, rtol=CLOSED_RTOL, atol=1e-7)


def test_square_lattice_in_plane_and_membrane_branches() -> None:
    a, m, k, kt = 1.0, 1.5, 2.0, 0.3
    crystal = crystals.square(a, m, k, transverse=kt)
    q = RNG.random((100, 3)) * np.array([1.0, 1.0, 0.0])
    cx, cy = np.cos(2 * np.pi * q[:, 0]), np.cos(2 * np.pi * q[:, 1])
    # a bond along x gives k to xx and kt to yy and zz (and likewise along y)
    expected = np.sort(np.stack([2 * k / m * (1 - cx) + 2 * kt / m * (1 - cy),
                                 2 * k / m * (1 - cy) + 2 * kt / m * (1 - cx),
                                 2 * kt / m * (2 - cx - cy)], axis=1), axis=1)
    np.testing.assert_allclose(crystal.frequencies(q), np.sqrt(expected), rtol=CLOSED_RTOL, atol=1e-7)
    assert crystal.periodic == (True, True, False)


def test_diatomic_chain_as_a_one_dimensional_crystal_has_the_textbook_gap() -> None:
    a, m1, m2, k = 2.0, 1.0, 3.0, 4.0
    chain = Crystal.from_cell(np.diag([a, 10 * a, 10 * a]), [[0.0, 0, 0], [0.5, 0, 0]], [m1, m2], fractional=True,
                              periodic=(True, False, False))
    chain = crystals.springs(chain, shells=1, stiffness=k)
    assert chain.springs is not None and chain.springs.first.size == 2  # two bonds per cell
    xi = np.linspace(0.0, 0.5, 51)
    omega = chain.frequencies(np.stack([xi, 0 * xi, 0 * xi], axis=1))
    s = 1 / m1 + 1 / m2
    root = np.sqrt(s ** 2 - 4 * np.sin(np.pi * xi) ** 2 / (m1 * m2))
    np.testing.assert_allclose(omega[:, -1], np.sqrt(k * (s + root)), rtol=CLOSED_RTOL)
    np.testing.assert_allclose(omega[1:, -2], np.sqrt(k * (s - root))[1:], rtol=1e-10)  # acoustic: cancellation in s - root
    assert omega[-1, -2] == pytest.approx(np.sqrt(2 * k / m2), rel=CLOSED_RTOL)  # the gap: sqrt(2k/M) .. sqrt(2k/m)
    assert omega[-1, -1] == pytest.approx(np.sqrt(2 * k / m1), rel=CLOSED_RTOL)
    assert np.abs(omega[:, :4]).max() < 1e-6  # transverse: no restoring force from central springs


def test_fcc_maximum_at_x_in_si_units() -> None:
    a, m, k = 5.26e-10, 6.63e-26, 0.52  # argon-like, kg and N/m
    crystal = crystals.fcc(a, m, k, units="SI")
    assert crystal.frequencies([[0.5, 0.0, 0.5]]).max() == pytest.approx(np.sqrt(8 * k / m), rel=CLOSED_RTOL)


# ---------------------------------------------------------------------- invariants
@pytest.fixture(scope="module")
def silicon_like() -> Crystal:
    return crystals.diamond(5.43, [28.0, 12.0], 10.0, shells=3, transverse=[1.0, 0.5, 0.2], units="ASE")


def test_acoustic_sum_rule_and_zero_modes_at_gamma(silicon_like: Crystal) -> None:
    fc = silicon_like.force_constants
    assert fc is not None
    total = np.zeros((silicon_like.n_atoms, 3, 3))
    np.add.at(total, fc.first, fc.blocks)
    assert np.abs(total).max() <= 1e-13 * np.abs(fc.blocks).max()
    result = silicon_like.phonons([[0.0, 0.0, 0.0]])
    assert (np.abs(result.omega[0, :3]) <= result.omega_error[0, :3]).all()
    assert (result.omega[0, 3:] > 100 * result.omega_error[0, 3:]).all()


def test_phase_conventions_give_the_same_frequencies_and_their_own_periodicity(silicon_like: Crystal) -> None:
    q = RNG.random((20, 3))
    shift = np.array([1.0, -2.0, 1.0])  # a reciprocal lattice vector in fractional terms
    d_cell = crystals.dynamical_matrices(silicon_like, q, phase="cell")
    np.testing.assert_allclose(crystals.dynamical_matrices(silicon_like, q + shift, phase="cell"), d_cell,
                               atol=1e-12 * np.abs(d_cell).max())
    d_pos = crystals.dynamical_matrices(silicon_like, q)
    phase = np.exp(2j * np.pi * q @ silicon_like.fractional.T).repeat(3, axis=1)  # (n_q, 3n)
    np.testing.assert_allclose(d_pos, phase.conj()[:, :, None] * d_cell * phase[:, None, :],
                               atol=1e-12 * np.abs(d_cell).max())
    np.testing.assert_allclose(d_pos, np.conj(np.transpose(d_pos, (0, 2, 1))), atol=1e-14 * np.abs(d_pos).max())
    np.testing.assert_allclose(silicon_like.phonons(q, phase="cell").omega, silicon_like.frequencies(q), rtol=1e-12)


def test_modes_at_gives_orthonormal_eigenvectors(silicon_like: Crystal) -> None:
    modes = silicon_like.modes_at([0.1, 0.2, 0.3])
    vectors = modes.vectors[0]
    np.testing.assert_allclose(vectors.conj().T @ vectors, np.eye(6), atol=1e-13)
    d = crystals.dynamical_matrices(silicon_like, [[0.1, 0.2, 0.3]])[0]
    residual = d @ vectors - vectors * (np.sign(modes.omega[0]) * modes.omega[0] ** 2)
    assert np.abs(residual).max() < 1e-12 * np.abs(d).max()
    shapes = modes.displacements()[0]
    np.testing.assert_allclose(shapes.conj().T @ np.diag(np.repeat(silicon_like.masses, 3)) @ shapes, np.eye(6),
                               atol=1e-13)


def test_results_are_frozen(silicon_like: Crystal) -> None:
    result = silicon_like.phonons([[0.1, 0.0, 0.0]])
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.omega = result.omega  # type: ignore[misc]
    with pytest.raises(ValueError):
        result.omega[0, 0] = 1.0
    with pytest.raises(ValueError):
        silicon_like.positions[0, 0] = 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        silicon_like.cell = silicon_like.cell  # type: ignore[misc]


def test_reprs_are_one_short_line_with_the_figures_that_matter() -> None:
    # issue 30: a band structure of 2,000 q-points printed ~10^5 characters of arrays
    from phonopy.physical_units import get_physical_units

    argon = crystals.fcc(5.26, 39.948, 0.0325, units="ASE")
    bands = argon.band_structure(npoints=2000)
    top = float(bands.omega.max()) * get_physical_units().DefaultToTHz  # phonopy's factor, not the code's
    results = {
        "Crystal('fcc', 1 atom (X)": argon,
        "BandStructure(2000 q-points x 3 branches, along Γ-": bands,
        "DensityOfStates(201 points on a 8x8x8 mesh": argon.dos(8),
        "ThermalProperties(3 temperatures 10..300 K, mesh 6x6x6": argon.thermal_properties([10, 100, 300], mesh=6),
        "SoundVelocities(direction (1, 0, 0), velocities": argon.sound_velocities([1, 0, 0]),
        "Phonons(2000 q-points x 3 branches": argon.phonons(bands.qpoints, vectors=True),
        "SupercellMode(branch 2 at q (0.5, 0.5, 0)": argon.supercell_mode([0.5, 0.5, 0.0], 2, (2, 2, 2)),
        "SpringModel(6 springs, 1 shell": argon.springs,
        "ForceConstants(13 terms, 1 atom": argon.force_constants,
    }
    for start, result in results.items():
        text = repr(result)
        assert "\n" not in text and len(text) < 200 and "array(" not in text, text
        assert text.startswith(start), text
    labels = [("Γ" if label == "GAMMA" else label) for _, label in bands.labels]
    assert all(label in repr(bands) for label in labels)
    assert f"0..{top:.4g} THz" in repr(bands)


def test_a_mode_on_conventional_cubes_obeys_the_equations_of_motion() -> None:
    # issue 30: an fcc primitive supercell is a rhombohedron that is hard to read; a supercell
    # matrix (here 2 x 2 x 2 conventional cubes) writes the mode on cubes. Truth: the fcc sites
    # of a cube of edge 2a, listed by hand, and Newton's equations with the force constants
    # applied through the positions (minimum image in the cube: the springs are nearest-neighbour).
    a = 5.26
    crystal = crystals.fcc(a, 39.948, 0.0325, units="ASE")
    cube = crystals.conventional_cube(crystal)
    assert cube is not None and np.allclose(cube @ crystal.cell, a * np.eye(3))
    assert crystals.conventional_cube(crystals.bcc(3.0, 1.0, 1.0)) is not None
    assert crystals.conventional_cube(crystals.honeycomb(2.46, 12.0, 1.0)) is None
    mode = crystal.supercell_mode([0.5, 0.5, 0.0], 2, 2 * cube)  # X: commensurate with the cube
    basis = np.array([[0, 0, 0], [0, 0.5, 0.5], [0.5, 0, 0.5], [0.5, 0.5, 0]])
    sites = np.array([(np.array(c) + b) * a for c in np.ndindex(2, 2, 2) for b in basis])
    found = np.mod(mode.positions + 1e-9, 2 * a) - 1e-9
    order = np.lexsort(found.T)
    np.testing.assert_allclose(found[order], sites[np.lexsort(sites.T)], atol=1e-9)
    np.testing.assert_allclose(mode.cell, 2 * a * np.eye(3), atol=1e-12)
    u = mode.amplitudes
    for i in range(len(u)):
        gap = mode.positions - mode.positions[i]
        gap -= 2 * a * np.round(gap / (2 * a))
        near = np.flatnonzero(np.isclose(np.linalg.norm(gap, axis=1), a / np.sqrt(2)))
        assert near.size == 12
        force = sum(0.0325 * np.outer(g, g) / (g @ g) @ (u[j] - u[i]) for g, j in zip(gap[near], near))
        np.testing.assert_allclose(force, -mode.omega ** 2 * 39.948 * u[i], atol=1e-12)
    with pytest.raises(ValueError, match="holds 0 cells"):
        crystal.supercell_mode([0.5, 0.5, 0.0], 2, [[1, 0, 0], [0, 1, 0], [0, 0, 0]])


def test_from_ase_reads_cell_positions_masses() -> None:
    from ase.build import bulk

    atoms = bulk("Si", "diamond", a=5.43)
    crystal = Crystal.from_ase(atoms)
    np.testing.assert_allclose(crystal.cell, atoms.cell.array)
    np.testing.assert_allclose(crystal.positions, atoms.positions, atol=1e-12)
    np.testing.assert_allclose(crystal.masses, atoms.get_masses())
    assert crystal.symbols == ("Si", "Si") and crystal.units.name == "ASE"
    spring = crystals.springs(crystal, shells=1, stiffness=10.0)
    q = RNG.random((5, 3))  # ASE's diamond cell is the builder's: the same q means the same wave vector
    np.testing.assert_allclose(spring.frequencies(q),
                               crystals.diamond(5.43, atoms.get_masses()[0], 10.0, units="ASE").frequencies(q),
                               rtol=1e-12)


def test_supercell_mode_obeys_the_equations_of_motion() -> None:
    # Truth: Newton's equations on the supercell, from the force-constant terms directly:
    # sum_{j, R} Phi(i 0; j R) u_j(n + R) = omega^2 m_i u_i(n) at every atom of the periodic supercell.
    crystal = crystals.rock_salt(5.64, [22.99, 35.45], 2.0, shells=2, transverse=0.3, units="ASE")
    size = np.array([4, 4, 4])
    q = np.array([0.25, 0.5, 0.0])                    # commensurate with 4 x 4 x 4
    mode = crystal.supercell_mode(q, 4, size)
    fc = crystal.force_constants
    n = crystal.n_atoms
    u = mode.amplitudes.reshape(*size, n, 3)
    for cell in [(0, 0, 0), (1, 2, 3), (3, 0, 1)]:
        for i in range(n):
            force = np.zeros(3, dtype=complex)
            for t in np.flatnonzero(fc.first == i):
                target = (np.array(cell) + fc.translations[t]) % size
                force += fc.blocks[t] @ u[tuple(target)][fc.second[t]]
            np.testing.assert_allclose(force, mode.omega ** 2 * crystal.masses[i] * u[cell][i], atol=1e-12)
    assert np.abs(mode.amplitudes).max() == pytest.approx(1.0)
    assert mode.positions.shape == (64 * n, 3) and len(mode.symbols) == 64 * n
    with pytest.raises(ValueError, match="branch"):
        crystal.supercell_mode(q, 6, size)
    with pytest.raises(ValueError, match="supercell"):
        crystal.supercell_mode(q, 0, [4, 0, 4])
