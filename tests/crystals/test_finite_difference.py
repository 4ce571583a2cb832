"""Force constants from an ASE calculator by finite differences (issue 30, item 1).

Truth: ASE's own `ase.phonons.Phonons` (every atom displaced along x, y, z; no symmetry) and
phonopy fed the same forces, on EMT copper. ASE folds the supercell force constants into D(q)
with one image per lattice vector (no minimum-image multiplicity), phonopy and vibra with the
shortest images split evenly: the two interpolations agree exactly only at the q commensurate
with the supercell, so ASE is compared there (all 64 q of the 4x4x4 mesh).
"""

from __future__ import annotations

import numpy as np
import pytest
from ase import Atoms, units
from ase.build import bulk
from ase.calculators.emt import EMT
from ase.phonons import Phonons

from vibra import crystals
from vibra.crystals import FiniteDifferenceForceConstants

SUPERCELL = (4, 4, 4)
MESH = np.stack(np.meshgrid(*[np.arange(4) / 4] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
# omega in rad per ASE time unit -> hbar omega in eV (ASE's Phonons reports energies)
TO_EV = units._hbar * 1e10 / np.sqrt(units._e * units._amu)


def copper():
    return bulk("Cu", "fcc", a=3.61)


@pytest.fixture(scope="module")
def result() -> FiniteDifferenceForceConstants:
    # symmetry=True: phonopy's symmetric generator and solver, the path these tests pin (EMT on 4x4x4
    # would otherwise take symmetry="auto"'s cheaper path, tested below)
    return crystals.finite_difference_force_constants(copper(), EMT(), supercell=SUPERCELL, delta=0.01, symmetry=True)


def test_symmetry_reduces_fcc_to_one_displacement(result: FiniteDifferenceForceConstants) -> None:
    # fcc: one atom, its site group O_h makes x, y, z and +-h equivalent (phonopy's generator)
    assert result.n_displacements == 1
    assert result.n_force_calls == 1 + 2 * result.n_displacements    # reference, h and 2h
    assert result.noise_source == "analytic"                           # EMT is listed: not probed


def test_bands_match_ase_phonons_within_the_finite_difference_error(result: FiniteDifferenceForceConstants,
                                                                    tmp_path) -> None:
    phonons = Phonons(copper(), EMT(), supercell=SUPERCELL, delta=0.01, name=str(tmp_path / "phonon"))
    phonons.run()
    phonons.read(acoustic=True)
    theirs = np.sort(phonons.band_structure(MESH), axis=1)
    ours = result.crystal.frequencies(MESH) * TO_EV
    # Both are central differences with the same h on the same supercell, so each carries the
    # truncation error our Richardson estimate bounds: allow it once for each side.
    bound = 2.0 * result.omega_errors(MESH) * TO_EV
    assert (np.abs(ours - theirs) <= bound).all()
    assert bound.max() < 0.05 * np.abs(theirs).max()                     # and the bound is informative


def test_error_bound_covers_the_step_refinement(result: FiniteDifferenceForceConstants) -> None:
    # truth: the same calculator at a 4x smaller step (truncation 16x smaller)
    fine = crystals.from_ase(copper(), EMT(), supercell=SUPERCELL, delta=0.0025)
    q = np.array([[0.5, 0.5, 0.5], [0.0, 0.5, 0.5], [0.25, 0.0, 0.25], [0.1, 0.2, 0.3]])
    gap = np.abs(result.crystal.frequencies(q) - fine.frequencies(q))
    assert (gap <= result.omega_errors(q)).all()


def test_matches_phonopy_fed_the_same_forces(result: FiniteDifferenceForceConstants) -> None:
    from phonopy import Phonopy
    from phonopy.structure.atoms import PhonopyAtoms

    atoms = copper()
    phonon = Phonopy(PhonopyAtoms(symbols=atoms.get_chemical_symbols(), cell=atoms.cell.array,
                                  scaled_positions=atoms.get_scaled_positions()),
                     supercell_matrix=np.diag(SUPERCELL), primitive_matrix=None, log_level=0)
    phonon.generate_displacements(distance=0.01)
    forces = []
    for cell in phonon.supercells_with_displacements:
        work = Atoms(cell.symbols, cell.positions, cell=cell.cell, pbc=True, calculator=EMT())
        forces.append(work.get_forces())
    phonon.forces = np.array(forces)
    phonon.produce_force_constants()
    phonon.symmetrize_force_constants()
    path = result.crystal.band_structure(npoints=200)
    phonon.run_qpoints(path.qpoints)
    theirs = phonon.qpoints.frequencies
    ours = result.crystal.phonons(path.qpoints).frequencies_thz()
    away = np.abs(theirs) > 1e-2 * np.abs(theirs).max()
    # phonopy's constants differ from scipy's by ~1e-7 relative; the two sum-rule projections
    # differ by the raw violation (1e-7 eV/A^2 of ~1 eV/A^2 blocks, SumRuleReport)
    np.testing.assert_allclose(ours[away], theirs[away], rtol=1e-6)


def test_sum_rules_hold_and_violations_are_reported(result: FiniteDifferenceForceConstants) -> None:
    fc = result.crystal.force_constants
    assert fc is not None
    scale = np.abs(fc.blocks).max()
    # acoustic sum rule: sum over j, R of Phi(0 0; j R) = 0 (one atom per cell)
    assert np.abs(fc.blocks.sum(axis=0)).max() < 1e-12 * scale
    # index symmetry Phi(i 0; j R) = Phi(j 0; i -R)^T  <=>  D(q) Hermitian at every q
    d = crystals.dynamical_matrices(result.crystal, np.random.default_rng(30).random((20, 3)))
    assert np.abs(d - d.conj().transpose(0, 2, 1)).max() < 1e-14 * np.abs(d).max()
    assert result.sum_rules.acoustic < 1e-9 and result.sum_rules.index < 1e-5
    omega = result.crystal.frequencies([[0.0, 0.0, 0.0]])
    assert np.abs(omega).max() < 1e-6 * result.crystal.frequencies([[0.5, 0.5, 0.5]]).max()


def test_cache_resumes_and_client_runs_the_same(tmp_path) -> None:
    first = crystals.finite_difference_force_constants(copper(), EMT(), supercell=(3, 3, 3), cache=tmp_path,
                                                       symmetry=True)
    again = crystals.finite_difference_force_constants(copper(), EMT(), supercell=(3, 3, 3), cache=tmp_path,
                                                       symmetry=True)
    assert first.n_force_calls == 3 and again.n_force_calls == 0 and again.n_cached == 3
    q = [[0.3, 0.1, 0.2]]
    assert np.array_equal(first.crystal.frequencies(q), again.crystal.frequencies(q))


def test_structure_only_and_bad_input() -> None:
    assert crystals.from_ase(copper()).force_constants is None
    with pytest.raises(ValueError, match="supercell is None"):
        crystals.from_ase(copper(), EMT())
    with pytest.raises(ValueError, match="supercell must be 3 positive integers"):
        crystals.from_ase(copper(), EMT(), supercell=(2, 0, 2))
    with pytest.raises(ValueError, match="delta"):
        crystals.from_ase(copper(), EMT(), supercell=(2, 2, 2), delta=-0.01)
    with pytest.raises(TypeError, match="calculator"):
        crystals.finite_difference_force_constants(copper(), None, supercell=(2, 2, 2))
    with pytest.raises(ValueError, match="client"):
        crystals.from_ase(copper(), EMT(), supercell=(2, 2, 2), client="nowhere")


def test_result_is_frozen(result: FiniteDifferenceForceConstants) -> None:
    from dataclasses import FrozenInstanceError

    with pytest.raises(FrozenInstanceError):
        result.step = 0.1  # type: ignore[misc]
    with pytest.raises(ValueError):
        result.error_blocks[0, 0, 0, 0] = 1.0


def test_dask_client_gives_the_serial_result_bit_for_bit() -> None:
    # one Dask task per displaced supercell; the forces are gathered, then assembled in a fixed order
    serial = crystals.finite_difference_force_constants(copper(), EMT, supercell=(2, 2, 2))
    local = crystals.finite_difference_force_constants(copper(), EMT, supercell=(2, 2, 2), client="local",
                                                       n_workers=1)
    q = [[0.5, 0.0, 0.5], [0.5, 0.5, 0.5]]
    assert np.array_equal(serial.crystal.frequencies(q), local.crystal.frequencies(q))
    assert np.array_equal(serial.error_blocks, local.error_blocks)


def test_auto_symmetry_skips_the_search_for_a_closed_form_calculator_and_keeps_the_degeneracies(
        result: FiniteDifferenceForceConstants) -> None:
    # EMT on 4x4x4: the search (48 operations x 64 cells x 64 atoms) costs more than five more force calls
    auto = crystals.finite_difference_force_constants(copper(), EMT(), supercell=SUPERCELL, delta=0.01)
    assert auto.n_displacements == 6                                   # +-x, +-y, +-z without the search
    q = np.array([[0.5, 0.0, 0.5], [0.5, 0.5, 0.5], [0.3, 0.1, 0.2]])
    ours, symmetric = auto.crystal.frequencies(q), result.crystal.frequencies(q)
    # the space-group average keeps the degeneracies the symmetric solver gives: X and L's transverse pairs
    assert abs(ours[0, 0] - ours[0, 1]) < 1e-12 * ours[0, 1] and abs(ours[1, 0] - ours[1, 1]) < 1e-12 * ours[1, 1]
    # both are central-difference force constants on the same supercell: within the error bound of either
    assert (np.abs(ours - symmetric) <= 2.0 * result.omega_errors(q)).all()
    # any other calculator keeps the search: its force calls are the cost
    from ase.calculators.calculator import Calculator, all_changes

    class Opaque(Calculator):
        implemented_properties = ["energy", "forces"]

        def calculate(self, atoms=None, properties=("forces",), system_changes=all_changes):
            super().calculate(atoms, properties, system_changes)
            inner = EMT()
            self.results = {"energy": inner.get_potential_energy(self.atoms), "forces": inner.get_forces(self.atoms)}

    opaque = crystals.finite_difference_force_constants(copper(), Opaque(), supercell=(2, 2, 2), estimate_error=False,
                                                        force_noise=None)
    assert opaque.n_displacements == 1
    with pytest.raises(ValueError, match="symmetry is 'yes'; expected 'auto', True or False"):
        crystals.finite_difference_force_constants(copper(), EMT(), supercell=SUPERCELL, symmetry="yes")
