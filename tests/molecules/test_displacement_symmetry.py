"""Symmetry-reduced finite differences (`vibra.molecules.displacement_symmetry`): the same Hessian,
dipole and polarisability derivatives as every Cartesian displacement, for fewer force calls.

Truth: the full Cartesian plan of the same calculator (ASE's EMT; vibra's valence force field),
itself checked against ASE's `Vibrations` in tests/molecules/test_molecules.py; the counts from the orbits and site
symmetries worked out by hand below.

Tolerance of the comparisons: both runs are O(h^2) central differences that differ only in their
truncation (a rotated direction samples other fourth derivatives) and in the operations' miss
(`Reduction.geometry_error`), each within its own estimate; so |H_reduced - H_full| <= 2 (E_reduced
+ E_full), the 2 for the Richardson estimate's own looseness (a factor of up to 4 on single modes
was measured, docs/molecules.md; on entries the ratio measured here is at most 1.15). Where every
operation maps Cartesian axes onto Cartesian axes (Td, C2v, D2h frames) the rebuilt rows are the
same arithmetic on the same forces: equal to rounding, 1e-9 relative.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from ase.calculators.calculator import Calculator, all_changes
from ase.calculators.emt import EMT

from vibra import molecules as mol
from vibra.molecules.displacement_symmetry import reduction, symmetry_tolerance
from vibra.molecules.named import molecule_atoms

# Richardson on (h, 2h): 2 step multiples, a + and a - geometry each, plus the reference.
PER_DOF = 2 * 2


def centred(name: str):
    atoms = molecule_atoms(name)
    atoms.positions -= atoms.get_center_of_mass()   # the toy dipole below is taken about the origin
    return atoms


class ToyProperties(Calculator):  # type: ignore[misc]
    """EMT forces, with a dipole and a polarisability that turn with the molecule (so symmetric).

    mu = sum_i q_i r_i with q_i = q(Z_i) + 0.1 sum_j exp(-r_ij) (not linear: a truncation error);
    alpha = I + sum_{i<j} exp(-r_ij) u_ij u_ij^T, u_ij the unit bond vector (Angstrom^3).
    """

    implemented_properties = ["energy", "forces", "dipole", "polarizability"]

    def calculate(self, atoms=None, properties=("energy",), system_changes=all_changes) -> None:
        super().calculate(atoms, properties, system_changes)
        work = self.atoms.copy()
        work.calc = EMT()
        r = work.positions
        distance = np.linalg.norm(r[:, None] - r[None, :], axis=2)
        weight = np.exp(-distance)
        np.fill_diagonal(weight, 0.0)
        charges = np.where(work.numbers == 1, 0.2, -0.3) + 0.1 * weight.sum(axis=1)
        alpha = np.eye(3)
        for i in range(len(r)):
            for j in range(i + 1, len(r)):
                u = (r[j] - r[i]) / distance[i, j]
                alpha = alpha + weight[i, j] * np.outer(u, u)
        self.results = {"energy": work.get_potential_energy(), "forces": work.get_forces(),
                        "dipole": charges @ r, "polarizability": alpha}


def both(atoms, calc, **options):
    reduced = mol.finite_difference_hessian(atoms, calc, force_noise=None, **options)
    full = mol.finite_difference_hessian(atoms, calc, force_noise=None, symmetry=False, **options)
    return reduced, full


def assert_within_estimates(a, b, error_a, error_b, what: str) -> None:
    excess = np.abs(a - b) - 2.0 * (error_a + error_b)
    assert excess.max() <= 0.0, f"{what}: off by more than 2 x the summed estimates at {np.argmax(excess)}"


# displaced dofs by hand: Td CH4: C (site Td) x alone, C3 and C2 make y and z; H (site C3v about a
# body diagonal) x alone, C3 makes y and z. D6h benzene (x through C0): C and H (site C2v, axes
# onto axes) x, y, z; one C and one H. D8h for Dinfh CO2 along x: C (site D8h) and O (site C8v):
# x, and y (the C8 turns y into the yz plane). C2v H2O: O x, y, z; one H x, y, z. C3v NH3 along z:
# N x (C3: the xy plane) and z; one H x, y, z.
EXPECTED_DOFS = {"CH4": 2, "C6H6": 6, "CO2": 4, "H2O": 6, "NH3": 5}


@pytest.mark.parametrize("name", list(EXPECTED_DOFS))
def test_reduced_plan_counts_and_equals_the_full_plan(name: str) -> None:
    atoms = molecule_atoms(name)
    calc = mol.ValenceForceField(mol.valence_model(atoms))
    reduced, full = both(atoms, calc)
    n = len(atoms)
    assert full.n_force_calls == full.n_full_plan == 1 + PER_DOF * 3 * n
    assert reduced.n_force_calls == 1 + PER_DOF * EXPECTED_DOFS[name], reduced.symmetry
    assert reduced.n_full_plan == full.n_full_plan and "point group" in reduced.symmetry
    assert_within_estimates(reduced.hessian, full.hessian, reduced.error, full.error, name)
    vib_r = mol.vibrational_analysis(reduced.system())
    vib_f = mol.vibrational_analysis(full.system())
    keep = ~np.asarray(vib_f.rigid)
    omega_r, omega_f = vib_r.modes.omega[keep], vib_f.modes.omega[keep]
    allowed = np.maximum(1e-6 * np.abs(omega_f),
                         2.0 * (reduced.omega_errors(vib_r.modes)[keep] + full.omega_errors(vib_f.modes)[keep]))
    assert np.all(np.abs(omega_r - omega_f) <= allowed), name


def test_axis_preserving_groups_rebuild_to_rounding() -> None:
    # Td in its standard frame: every operation a signed permutation of x, y, z
    atoms = molecule_atoms("CH4")
    reduced, full = both(atoms, EMT())
    np.testing.assert_allclose(reduced.hessian, full.hessian, rtol=0, atol=1e-9 * np.abs(full.hessian).max())
    assert reduced.n_force_calls == 9 and full.n_force_calls == 61


@pytest.mark.parametrize("name", ["C6H6", "NH3"])
def test_emt_benzene_and_ammonia_within_estimates(name: str) -> None:
    # non-axis-preserving operations (C6, C3): rebuilt rows differ at the truncation level
    atoms = molecule_atoms(name)
    reduced, full = both(atoms, EMT())
    assert reduced.n_force_calls == 1 + PER_DOF * EXPECTED_DOFS[name]
    assert_within_estimates(reduced.hessian, full.hessian, reduced.error, full.error, name)


@pytest.mark.parametrize("name", ["CH4", "C6H6"])
def test_dipole_and_polarizability_derivatives_and_intensities(name: str) -> None:
    atoms = centred(name)
    reduced, full = both(atoms, ToyProperties(), properties=("dipole", "polarizability"))
    r, f = reduced.derivatives, full.derivatives
    assert r is not None and f is not None and r.dipole is not None and f.dipole is not None
    assert r.dipole_error is not None and f.dipole_error is not None
    assert r.polarizability is not None and f.polarizability is not None
    assert r.polarizability_error is not None and f.polarizability_error is not None
    assert_within_estimates(r.dipole, f.dipole, r.dipole_error, f.dipole_error, "dipole")
    assert_within_estimates(r.polarizability, f.polarizability, r.polarizability_error,
                            f.polarizability_error, "polarizability")
    # IR intensity ~ |d mu / dQ_k|^2 and the Raman invariant sum |d alpha / dQ_k|^2 on the full run's modes
    # (EMT's CH4 and C6H6 are not at equilibrium: the modes of the full Hessian, by numpy alone)
    scale = 1.0 / np.sqrt(np.repeat(full.masses, 3))
    q = np.linalg.eigh(full.hessian * np.outer(scale, scale))[1] * scale[:, None]
    ir = [np.sum((q.T @ d.dipole) ** 2, axis=1) for d in (r, f)]
    raman = [np.sum(np.einsum("ik,iac->kac", q, d.polarizability) ** 2, axis=(1, 2)) for d in (r, f)]
    if name == "CH4":   # axis-preserving Td: equal to rounding
        np.testing.assert_allclose(ir[0], ir[1], rtol=1e-6, atol=1e-9 * ir[1].max())
        np.testing.assert_allclose(raman[0], raman[1], rtol=1e-6, atol=1e-9 * raman[1].max())
    else:               # first-order propagation of the summed estimates, times 2
        bound_ir = 2.0 * 2.0 * np.sqrt(ir[1]) * (np.abs(q.T) @ (r.dipole_error + f.dipole_error)).max(axis=1)
        assert np.all(np.abs(ir[0] - ir[1]) <= bound_ir + 1e-9 * ir[1].max())


def test_c1_molecule_is_unchanged() -> None:
    atoms = molecule_atoms("NH3")        # (any 3 atoms keep a mirror: their plane)
    atoms.positions += np.random.default_rng(4).normal(scale=0.05, size=atoms.positions.shape)
    reduced, full = both(atoms, EMT())
    assert "C1" in reduced.symmetry and reduced.n_force_calls == full.n_force_calls == 49
    np.testing.assert_array_equal(reduced.hessian, full.hessian)


def test_symmetry_broken_beyond_the_step_tolerance_falls_back_with_a_note() -> None:
    atoms = molecule_atoms("CH4")
    atoms.positions[1] += [1e-4, 0.0, 0.0]    # Td within point_group's 0.01, not within h^2 / 6 Angstrom
    assert 1e-4 > symmetry_tolerance(0.01)
    reduced, full = both(atoms, EMT())
    assert "deviates from Td" in reduced.symmetry and "every Cartesian displacement" in reduced.symmetry
    assert reduced.n_force_calls == full.n_force_calls == 61
    np.testing.assert_array_equal(reduced.hessian, full.hessian)
    # a coarser step tolerates more: the same geometry is reduced at h = 0.05 (tolerance 4.2e-4)
    assert reduction(atoms, 0.05, True).reduced


def test_atoms_told_apart_by_their_arrays_are_not_mapped_onto_each_other() -> None:
    atoms = molecule_atoms("CH4")
    atoms.set_initial_magnetic_moments([0, 1, 0, 0, 0])
    assert "initial_magmoms" in reduction(atoms, 0.01, True).note


def test_symmetry_must_be_a_bool() -> None:
    atoms = molecule_atoms("H2O")
    with pytest.raises(TypeError, match="symmetry must be True or False"):
        mol.finite_difference_hessian(atoms, EMT(), symmetry="yes")


def test_reduced_and_full_runs_share_the_cache_without_mixing(tmp_path: Path) -> None:
    atoms = molecule_atoms("CH4")
    calc = EMT()
    options = {"force_noise": None, "calculator_key": "EMT"}   # (an EMT instance's pickle changes as it runs)
    reduced = mol.finite_difference_hessian(atoms, calc, cache=tmp_path / "a", **options)
    full = mol.finite_difference_hessian(atoms, calc, cache=tmp_path / "a", symmetry=False, **options)
    assert (reduced.n_force_calls, full.n_cached, full.n_force_calls) == (9, 9, 52)
    fresh = mol.finite_difference_hessian(atoms, calc, force_noise=None, symmetry=False)
    np.testing.assert_array_equal(full.hessian, fresh.hessian)        # resumed full == fresh full
    again = mol.finite_difference_hessian(atoms, calc, cache=tmp_path / "a", **options)
    assert (again.n_force_calls, again.n_cached) == (0, 9)
    np.testing.assert_array_equal(again.hessian, reduced.hessian)      # reduced from full's files == reduced
    # the other order: a full run first, then a reduced one reads only its own geometries
    mol.finite_difference_hessian(atoms, calc, cache=tmp_path / "b", symmetry=False, **options)
    second = mol.finite_difference_hessian(atoms, calc, cache=tmp_path / "b", **options)
    assert (second.n_force_calls, second.n_cached) == (0, 9)
    np.testing.assert_array_equal(second.hessian, reduced.hessian)


def test_four_point_stencil_and_no_estimate() -> None:
    # 4-point with Richardson: multiples 1, 2, 4 (3 pairs per dof); without the estimate: 1 pair
    atoms = molecule_atoms("NH3")
    reduced, full = both(atoms, EMT(), stencil=4)
    assert (reduced.n_force_calls, full.n_force_calls) == (1 + 6 * EXPECTED_DOFS["NH3"], 1 + 6 * 12)
    assert_within_estimates(reduced.hessian, full.hessian, reduced.error, full.error, "NH3 4-point")
    methane = molecule_atoms("CH4")
    reduced, full = both(methane, EMT(), estimate_error=False)
    assert (reduced.n_force_calls, full.n_force_calls) == (1 + 2 * 2, 1 + 2 * 15)
    np.testing.assert_allclose(reduced.hessian, full.hessian, rtol=0, atol=1e-9 * np.abs(full.hessian).max())


@pytest.mark.parametrize("name", ["H2O", "NH3"])
def test_pyscf_rhf_sto3g_hessian_dipole_and_polarizability(name: str) -> None:
    # an electronic-structure engine (force noise given by the engine, SCF-converged values); the
    # geometries are not PySCF's equilibria (force_tolerance=None): symmetry does not need one
    pytest.importorskip("pyscf")
    from vibra.molecules.engines import PySCFEngine, electronic_structure

    atoms = molecule_atoms(name)
    engine = PySCFEngine("hf", "sto-3g")
    runs = [electronic_structure(atoms, engine, hessian="finite difference", force_tolerance=None, symmetry=flag)
            for flag in (True, False)]
    reduced, full = (run.finite_difference for run in runs)
    assert reduced.n_force_calls == 1 + PER_DOF * EXPECTED_DOFS[name]
    assert full.n_force_calls == 1 + PER_DOF * 3 * len(atoms)
    assert_within_estimates(reduced.hessian, full.hessian, reduced.error, full.error, f"{name} Hessian")
    r, f = reduced.derivatives, full.derivatives
    assert r is not None and f is not None
    for what in ("dipole", "polarizability"):
        assert_within_estimates(getattr(r, what), getattr(f, what), getattr(r, f"{what}_error"),
                                getattr(f, f"{what}_error"), f"{name} {what}")
