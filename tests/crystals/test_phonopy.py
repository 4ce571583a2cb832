"""vibra.crystals against phonopy on the same force constants, both ways (issue 30, items 1-2).

Truth: phonopy's own D(q) and eigensolver (``Phonopy.run_qpoints``). phonopy's physical
constants are older than scipy's (its amu and eV differ by ~1e-7), so frequencies are compared
as sqrt(eigenvalue) in phonopy's unit system (our omega in ASE units times phonopy's
DefaultToTHz): what remains is the arithmetic of the two D(q), to rounding.
"""

from __future__ import annotations

import numpy as np
import pytest
from phonopy.physical_units import get_physical_units

from vibra import crystals
from vibra.crystals import Crystal

RNG = np.random.default_rng(3030)
TO_THZ = get_physical_units().DefaultToTHz
# Both sides form D(q) from the same blocks and solve it with LAPACK: the difference is a few
# eps ||D|| absolute, so 1e-10 relative holds for every |f| above 1e-3 f_max (away from Gamma).
RTOL = 1e-10


def spring_crystals() -> list[Crystal]:
    return [
        crystals.fcc(4.0, 39.95, 1.2, units="ASE"),
        crystals.diamond(5.43, 28.09, 10.0, shells=3, transverse=[1.0, 0.5, 0.2], units="ASE"),
        crystals.rock_salt(5.64, [22.99, 35.45], 2.0, shells=2, transverse=0.3, units="ASE"),
        crystals.honeycomb(2.46, 12.01, 25.0, shells=2, transverse=[3.0, 1.0], units="ASE"),
    ]


def away_from_gamma(reference: np.ndarray) -> np.ndarray:
    return np.abs(reference) > 1e-3 * np.abs(reference).max()


@pytest.mark.parametrize("crystal", spring_crystals(), ids=lambda c: c.name)
def test_bands_on_500_qpoints_match_phonopy(crystal: Crystal) -> None:
    bands = crystal.band_structure(npoints=500)
    phonon = crystal.to_phonopy()
    phonon.run_qpoints(bands.qpoints)
    reference = phonon.qpoints.frequencies
    ours = np.sort(bands.omega, axis=1) * TO_THZ
    mask = away_from_gamma(reference)
    np.testing.assert_allclose(ours[mask], reference[mask], rtol=RTOL)


def test_eigenvectors_match_phonopy_up_to_a_phase() -> None:
    crystal = spring_crystals()[1]
    q = RNG.random((30, 3))
    phonon = crystal.to_phonopy()
    phonon.run_qpoints(q, with_eigenvectors=True)
    theirs = phonon.qpoints.eigenvectors
    ours = crystal.phonons(q, vectors=True).vectors
    assert ours is not None
    overlap = np.abs(np.einsum("qib,qib->qb", ours.conj(), theirs))
    freq = phonon.qpoints.frequencies
    single = np.ones_like(freq, dtype=bool)  # nondegenerate branches only: their eigenvector is unique
    gap = np.diff(freq, axis=1) > 1e-6
    single[:, 1:] &= gap
    single[:, :-1] &= gap
    np.testing.assert_allclose(overlap[single], 1.0, atol=1e-9)


def emt_phonopy(conventional: bool):  # type: ignore[no-untyped-def]
    """phonopy's own workflow on fcc Cu with ASE's EMT forces: displacements, forces, force constants."""
    from ase import Atoms
    from ase.build import bulk
    from ase.calculators.emt import EMT
    from phonopy import Phonopy
    from phonopy.structure.atoms import PhonopyAtoms

    atoms = bulk("Cu", "fcc", a=3.61, cubic=conventional)
    unit = PhonopyAtoms(symbols=atoms.get_chemical_symbols(), cell=atoms.cell.array,
                        scaled_positions=atoms.get_scaled_positions())
    phonon = Phonopy(unit, supercell_matrix=np.eye(3, dtype=int) * 2, primitive_matrix="F" if conventional else None)
    phonon.generate_displacements(distance=0.01)
    forces = []
    for cell in phonon.supercells_with_displacements:
        image = Atoms(cell.symbols, cell=cell.cell, scaled_positions=cell.scaled_positions, pbc=True)
        image.calc = EMT()
        forces.append(image.get_forces())
    phonon.forces = np.array(forces)
    phonon.produce_force_constants()
    return phonon


@pytest.mark.parametrize("conventional", [False, True], ids=["primitive", "conventional-F"])
def test_from_phonopy_reads_supercell_force_constants_with_equidistant_images(conventional: bool) -> None:
    # A 2x2x2 supercell of fcc holds pairs with several equidistant shortest images: phonopy splits
    # their block over them (multiplicity); from_phonopy must do the same.
    phonon = emt_phonopy(conventional)
    crystal = crystals.from_phonopy(phonon)
    assert crystal.n_atoms == 1 and crystal.units.name == "ASE"
    assert crystal.force_constants is not None
    q = RNG.random((200, 3))
    phonon.run_qpoints(q)
    reference = phonon.qpoints.frequencies
    mask = away_from_gamma(reference)
    np.testing.assert_allclose(crystal.frequencies(q)[mask] * TO_THZ, reference[mask], rtol=RTOL)


def test_round_trip_and_si_units() -> None:
    crystal = spring_crystals()[2]
    back = crystals.from_phonopy(crystal.to_phonopy())
    q = RNG.random((50, 3))
    np.testing.assert_allclose(back.frequencies(q), crystal.frequencies(q), rtol=1e-12, atol=1e-9)
    # an SI crystal is converted to phonopy's units on the way out: its THz agree to phonopy's
    # older constants (amu and eV 1.2e-7 apart from CODATA 2018), hence 1e-6
    si = crystals.fcc(5.26e-10, 6.63e-26, 0.52, units="SI")
    phonon = si.to_phonopy()
    phonon.run_qpoints(q)
    np.testing.assert_allclose(si.phonons(q).frequencies_thz(), phonon.qpoints.frequencies, rtol=1e-6, atol=1e-9)


def test_to_phonopy_refuses_a_supercell_too_small_and_names_the_size_needed() -> None:
    crystal = crystals.fcc(4.0, 39.95, 1.2, shells=2, units="ASE")
    with pytest.raises(ValueError, match=r"supercell \[2, 2, 2\] is too small.*needs at least \[\d, \d, \d\]"):
        crystal.to_phonopy(supercell=[2, 2, 2])
    with pytest.raises(ValueError, match=r"supercell\[2\] is 2 along a vacuum axis"):
        spring_crystals()[3].to_phonopy(supercell=[3, 3, 2])
    with pytest.raises(ValueError, match=r"dimensionless units; phonopy needs physical units"):
        crystals.fcc(1.0, 1.0, 1.0, units="dimensionless").to_phonopy()
