"""vibra.crystals DOS, thermal properties and sound velocities (issue 30, items 4-5).

Truth: phonopy on the same force constants (its tetrahedron and Gaussian DOS, its thermal
properties), given scipy's CODATA constants for the comparison (``set_physical_units``: its
defaults are older, 1e-7 apart, which would hide the 1e-8 targets); sum rules (the DOS
integrates to 3 n_atoms, the projections add up); the classical limit C_v -> 3 n k_B; the
Christoffel equation with the closed-form elastic constants of nearest-neighbour springs.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import constants

from vibra import crystals
from vibra.crystals import Crystal


def spring_crystals() -> list[Crystal]:
    return [crystals.fcc(4.0, 39.95, 1.2, units="ASE"),
            crystals.diamond(5.43, 28.09, 10.0, shells=3, transverse=[1.0, 0.5, 0.2], units="ASE")]


@pytest.mark.parametrize("crystal", spring_crystals(), ids=lambda c: c.name)
def test_tetrahedron_and_gaussian_dos_match_phonopy(crystal: Crystal, codata_phonopy: None) -> None:
    to_thz = crystal.units.omega_to_thz(1.0)
    phonon = crystal.to_phonopy()
    phonon.run_mesh([12, 12, 12], is_gamma_center=True)
    phonon.run_total_dos(use_tetrahedron_method=True)
    points, reference = phonon.total_dos.frequency_points, phonon.total_dos.dos
    ours = crystal.dos([12, 12, 12], omega=points / to_thz)
    # same tetrahedra, same linear interpolation: rounding only (measured 5e-10 and 2e-11)
    np.testing.assert_allclose(ours.dos_per_thz(), reference, atol=1e-6 * reference.max())
    phonon.run_total_dos(sigma=0.05, use_tetrahedron_method=False)
    points, reference = phonon.total_dos.frequency_points, phonon.total_dos.dos
    smeared = crystal.dos([12, 12, 12], method="gaussian", sigma=0.05 / to_thz, omega=points / to_thz)
    np.testing.assert_allclose(smeared.dos_per_thz(), reference, atol=1e-6 * reference.max())


@pytest.mark.parametrize("crystal", spring_crystals(), ids=lambda c: c.name)
def test_thermal_properties_match_phonopy(crystal: Crystal, codata_phonopy: None) -> None:
    temperatures = np.array([0.0, 5.0, 50.0, 300.0, 1000.0])
    phonon = crystal.to_phonopy()
    phonon.run_mesh([10, 10, 10], is_gamma_center=True)
    phonon.run_thermal_properties(temperatures=temperatures, exclude_gamma_acoustic=True)
    _, free, entropy, heat = phonon.thermal_properties.thermal_properties
    ours = crystal.thermal_properties(temperatures, mesh=[10, 10, 10])
    # the same sums of the same frequencies (to 1e-15): 1e-8 is the target, met with room
    np.testing.assert_allclose(ours.free_energy_kj_mol(), free, rtol=1e-8)
    np.testing.assert_allclose(ours.entropy_j_k_mol()[1:], entropy[1:], rtol=1e-8)
    np.testing.assert_allclose(ours.heat_capacity_j_k_mol()[1:], heat[1:], rtol=1e-8)
    assert ours.zero_point_energy_kj_mol() == pytest.approx(free[0], rel=1e-8)
    assert ours.excluded == 3  # the acoustic modes at Gamma


def test_dos_sum_rules_and_projections() -> None:
    crystal = crystals.rock_salt(5.64, [22.99, 35.45], 2.0, shells=2, transverse=0.3, units="ASE")
    span = crystal.dos([6, 6, 6]).omega  # the default points cover the spectrum with a margin
    result = crystal.dos([6, 6, 6], projected=True, omega=np.linspace(span[0], span[-1], 2001))
    step = result.omega[1] - result.omega[0]
    # 3 n_atoms; the DOS is continuous and piecewise quadratic, so the trapezoid rule on 2001 points
    # errs by ~1e-5 (measured)
    assert np.trapezoid(result.dos, dx=step) == pytest.approx(6.0, rel=1e-4)
    assert result.projected is not None
    np.testing.assert_allclose(result.projected.sum(axis=0), result.dos, atol=1e-12 * result.dos.max())
    # each atom carries 3 states in all
    np.testing.assert_allclose(np.trapezoid(result.projected, dx=step, axis=1), [3.0, 3.0], rtol=1e-4)
    # the tetrahedron DOS on the reduced mesh is the one on the full mesh
    full = crystal.dos([6, 6, 6], omega=result.omega, symmetry=False)
    np.testing.assert_allclose(crystal.dos([6, 6, 6], omega=result.omega).dos, full.dos, atol=1e-9 * full.dos.max())


def test_classical_limit_of_the_heat_capacity() -> None:
    crystal = spring_crystals()[1]
    hot = crystal.thermal_properties([1e6], mesh=6)
    # C_v -> 3 n k_B (Dulong-Petit) up to the excluded Gamma modes and O((hbar omega / kT)^2)
    expected = (6 - 3 / 6 ** 3) * constants.R
    assert hot.heat_capacity_j_k_mol()[0] == pytest.approx(expected, rel=1e-6)


def christoffel(c11: float, c12: float, c44: float, density: float, direction: np.ndarray) -> np.ndarray:
    """Ascending sound velocities of a cubic medium: eigenvalues of Gamma_ik = C_ijkl n_j n_l, over rho."""
    n = direction / np.linalg.norm(direction)
    gamma = (c12 + c44) * np.outer(n, n)
    gamma[np.diag_indices(3)] = c11 * n ** 2 + c44 * (1 - n ** 2)
    return np.sqrt(np.linalg.eigvalsh(gamma) / density)


DIRECTIONS = [np.array(v, dtype=float) for v in ([1, 0, 0], [1, 1, 0], [1, 1, 1], [0.3, -0.5, 0.8])]


@pytest.mark.parametrize("direction", DIRECTIONS, ids=lambda d: str(d.tolist()))
def test_sound_velocities_against_christoffel(direction: np.ndarray) -> None:
    a, m, k, kt = 1.3, 2.0, 0.7, 0.2
    # fcc, central nearest-neighbour springs: C11 = 2k/a, C12 = C44 = k/a, rho = 4m/a^3
    fcc = crystals.fcc(a, m, k)
    truth = christoffel(2 * k / a, k / a, k / a, 4 * m / a ** 3, direction)
    # Richardson on steps h, h/2 leaves O(h^4) ~ 1e-12 and rounding eps / (h a)^2 ~ 1e-11 (measured 2e-10 at worst)
    np.testing.assert_allclose(fcc.sound_velocities(direction).velocities, truth, rtol=1e-9)
    # simple cubic with bond-bending kt: C11 = k/a, C44 = kt/a, C12 = -kt/a (no xy coupling), rho = m/a^3
    sc = crystals.simple_cubic(a, m, k, transverse=kt)
    truth = christoffel(k / a, -kt / a, kt / a, m / a ** 3, direction)
    np.testing.assert_allclose(sc.sound_velocities(direction).velocities, truth, rtol=1e-9)


def test_measured_order_of_convergence_of_the_slopes_is_two() -> None:
    a, m, k = 1.3, 2.0, 0.7
    fcc = crystals.fcc(a, m, k)
    direction = DIRECTIONS[3]
    truth = christoffel(2 * k / a, k / a, k / a, 4 * m / a ** 3, direction)
    steps = 0.4 * 2.0 ** -np.arange(6)  # rad / length
    error = np.abs(crystals.acoustic_slopes(fcc, direction, steps) / truth - 1).max(axis=1)
    order = np.log2(error[:-1] / error[1:])
    np.testing.assert_allclose(order, 2.0, atol=0.01)  # measured 1.998 .. 2.000


def test_thermal_and_dos_inputs() -> None:
    crystal = spring_crystals()[0]
    with pytest.raises(ValueError, match=r"mesh\[1\] is 0; each mesh size must be a positive integer"):
        crystal.dos([4, 0, 4])
    with pytest.raises(ValueError, match=r"mesh\[2\] is 4 along a vacuum axis; it must be 1"):
        crystals.square(1.0, 1.0, 1.0).dos([4, 4, 4])
    with pytest.raises(ValueError, match=r"method='gaussian' needs sigma"):
        crystal.dos(4, method="gaussian")
    with pytest.raises(ValueError, match=r"temperatures\[1\] is -1.0"):
        crystal.thermal_properties([0.0, -1.0], mesh=4)
    with pytest.raises(ValueError, match=r"thermal properties need physical units"):
        crystals.fcc(1.0, 1.0, 1.0, units="dimensionless").thermal_properties([300.0], mesh=4)
    with pytest.raises(ValueError, match=r"leaves the periodic plane \(vacuum axis 2\)"):
        crystals.square(1.0, 1.0, 1.0, transverse=0.1).sound_velocities([0, 0, 1])


def test_result_types_are_frozen() -> None:
    import dataclasses

    crystal = spring_crystals()[0]
    results = [crystal.band_structure(npoints=20), crystal.dos(4), crystal.thermal_properties([300.0], mesh=4),
               crystal.sound_velocities([1, 0, 0])]
    for result in results:
        field = dataclasses.fields(result)[0].name
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(result, field, None)
        arrays = [getattr(result, f.name) for f in dataclasses.fields(result)
                  if isinstance(getattr(result, f.name), np.ndarray)]
        assert arrays and all(not a.flags.writeable for a in arrays)


def test_a_crystal_in_metres_finds_its_symmetry_and_path_as_in_angstrom() -> None:
    """spglib's and SeeK-path's tolerances are lengths (1e-5): the same fcc crystal in SI (a =
    5.26e-10 m) and in dimensionless units (a = 1) reduces its mesh to the same irreducible
    points and takes the same path; its thermal properties come out (they failed with
    'cannot unpack NoneType' before the cell was scaled for them)."""
    from vibra.crystals.bands import special_points
    from vibra.crystals.mesh import mesh_points

    si = crystals.fcc(5.26e-10, 6.63e-26, 1.2, units="SI")
    unit = crystals.fcc(1.0, 1.0, 1.0, units="dimensionless")
    a, b = mesh_points(si, (8, 8, 8)), mesh_points(unit, (8, 8, 8))
    assert a.irreducible.shape[0] == b.irreducible.shape[0] < 8**3 // 10
    np.testing.assert_array_equal(a.weights, b.weights)
    assert special_points(si)[1] == special_points(unit)[1]
    assert np.all(np.isfinite(si.thermal_properties([10.0, 300.0], mesh=(6, 6, 6)).heat_capacity))
