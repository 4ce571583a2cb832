"""Tests of vibra.molecules: builders, valence force field, finite differences, Eckart analysis,
isotopes. Truth comes from seed 003 Example 11 (eqs. 157-158), textbook closed forms, ASE
(geometry functions, Vibrations, VibrationsData), phonopy, and invariants (Teller-Redlich)."""

from __future__ import annotations

import dataclasses
import tempfile
import warnings

import numpy as np
import pytest
from ase import Atoms
from ase.build import molecule
from ase.data import atomic_masses, atomic_numbers
from ase.vibrations import Vibrations, VibrationsData
from scipy import constants

from vibra import System
from vibra import molecules as mol
from vibra.units import ASE

from molecule_closed_forms import (CO2_EXPERIMENT, H2O_EXPERIMENT, cm1_from_eigenvalue, co2_closed_form_cm1,
                                    h2o_closed_form_cm1)

M_O = atomic_masses[atomic_numbers["O"]]
M_C = atomic_masses[atomic_numbers["C"]]
KAPPA = mol.CO2_STRETCH
L = mol.CO2_BOND_LENGTH


def _cm1(omega: np.ndarray) -> np.ndarray:
    return ASE.omega_to_cm1(omega)


# ----------------------------------------------------------------- seed 003, Example 11
def test_co2_axial_matches_seed_157_158() -> None:
    system = mol.co2(dims=1)
    assert system.n_dof == 3 and system.dim == 1
    modes = system.modes()
    expected = np.array([0.0, np.sqrt(KAPPA / M_O), np.sqrt(KAPPA * (1 / M_O + 2 / M_C))])  # eq. 157
    # Dense symmetric eigensolvers give omega^2 to ~eps * ||K~|| (||K~|| ~ 4 omega_2^2 here), so
    # the non-zero omegas agree to ~1e-15 relative; 1e-10 leaves room for any solver path. The
    # zero mode's omega is ~sqrt(eps * ||K~||) ~ 1e-8 omega_3 at worst.
    np.testing.assert_allclose(modes.omega[1:], expected[1:], rtol=1e-10)
    assert abs(modes.omega[0]) <= 1e-7 * expected[2]
    alpha = M_O / M_C
    seed_shapes = [np.ones(3) / np.sqrt(3), np.array([-1, 0, 1]) / np.sqrt(2),
                   np.array([1, -2 * alpha, 1]) / np.sqrt(4 * alpha**2 + 2)]  # eq. 158
    for k, seed in enumerate(seed_shapes):
        shape = modes.shapes[:, k] / np.linalg.norm(modes.shapes[:, k])
        # directions agree up to sign; eigenvector error ~ eps * ||K~|| / gap ~ 1e-15
        assert abs(abs(shape @ seed) - 1.0) < 1e-10


def test_co2_3d_four_vibrations_degenerate_bend_five_zero_modes() -> None:
    system = mol.co2()
    assert system.n_dof == 9
    analysis = mol.vibrational_analysis(system)
    assert analysis.linear and analysis.n_rigid == 5 and analysis.n_vibrations == 4
    assert np.count_nonzero(analysis.modes.omega[analysis.rigid] == 0.0) == 5
    bend_1, bend_2, symmetric, asymmetric = analysis.modes.omega[~analysis.rigid]
    # the two bends are symmetry copies (rotation about the axis); only round-off separates them
    assert abs(bend_1 - bend_2) <= 1e-12 * asymmetric
    # textbook linear XY2 bend: omega^2 = k_delta (2/m_O + 4/m_C) / L^2 (Herzberg)
    np.testing.assert_allclose(bend_1, np.sqrt(mol.CO2_BEND * (2 / M_O + 4 / M_C)) / L, rtol=1e-10)
    # stretches are the axial model's (eq. 157)
    np.testing.assert_allclose([symmetric, asymmetric],
                               [np.sqrt(KAPPA / M_O), np.sqrt(KAPPA * (1 / M_O + 2 / M_C))], rtol=1e-10)


def test_co2_reduced_masses_and_force_constants_closed_form() -> None:
    analysis = mol.vibrational_analysis(mol.co2())
    mu = analysis.reduced_mass[~analysis.rigid]
    k = analysis.force_constant[~analysis.rigid]
    alpha = M_O / M_C
    # symmetric stretch: only the O atoms move, mu = m_O, k = mu omega^2 = kappa exactly;
    # asymmetric stretch: l ~ (1, -2 alpha, 1) gives mu = m_O (1 + 2 alpha) / (1 + 2 alpha^2)
    np.testing.assert_allclose(mu[2], M_O, rtol=1e-10)
    np.testing.assert_allclose(k[2], KAPPA, rtol=1e-10)
    np.testing.assert_allclose(mu[3], M_O * (1 + 2 * alpha) / (1 + 2 * alpha**2), rtol=1e-10)
    # 1 eV/A^2 = e / 1e-20 N/m = 0.01602 mdyn/A * 10  (1 mdyn/A = 100 N/m)
    np.testing.assert_allclose(analysis.force_constants_mdyn_per_angstrom()[~analysis.rigid][2],
                               KAPPA * constants.electron_volt / 1e-20 / 100, rtol=1e-12)


def _h2o_cm1(stretch: float, bend: float) -> np.ndarray:
    return h2o_closed_form_cm1(stretch, bend, mol.H2O_BOND_LENGTH, mol.H2O_ANGLE_DEG)


def _least_squares_on_log(model, experiment, start) -> np.ndarray:
    """Constants minimising sum (ln omega_model - ln omega_exp)^2, the fit the docstrings describe."""
    from scipy.optimize import least_squares

    fit = least_squares(lambda logk: np.log(model(*np.exp(logk))) - np.log(experiment), np.log(start),
                        xtol=1e-15, ftol=1e-15, gtol=1e-15)
    return np.exp(fit.x)


def test_co2_default_constants_are_the_documented_fit_to_experiment() -> None:
    # CO2_STRETCH: one kappa fitted by least squares on ln(omega) to nu1 and nu3 in the axial
    # model (eq. 157); CO2_BEND: the linear XY2 bend omega^2 = k (2/m_O + 4/m_C) / L^2 solved for
    # nu2. Refitting here from the experimental values must give the constants to their digits.
    from scipy.optimize import brentq

    stretch_terms = np.array([1 / M_O, 1 / M_O + 2 / M_C])
    kappa, = _least_squares_on_log(lambda k: cm1_from_eigenvalue(k * stretch_terms),
                                   np.array(CO2_EXPERIMENT[1:]), [90.0])
    assert abs(kappa - mol.CO2_STRETCH) <= 0.005            # CO2_STRETCH = 96.24 has 2 decimals
    bend_term = (2 / M_O + 4 / M_C) / L**2
    k_delta = brentq(lambda k: cm1_from_eigenvalue(k * bend_term) - CO2_EXPERIMENT[0], 1.0, 10.0)
    assert abs(k_delta - mol.CO2_BEND) <= 0.0005            # CO2_BEND = 4.806 has 3 decimals
    # vibra's wavenumbers are those closed forms; the documented 667.0, 1279 and 2448 cm^-1
    # ("each 4 % off") follow from them
    waves = mol.vibrational_analysis(mol.co2()).vibration_wavenumbers_cm1()
    closed = co2_closed_form_cm1(mol.CO2_STRETCH, mol.CO2_BEND, L)
    np.testing.assert_allclose(waves, closed, rtol=1e-10)
    assert [round(float(w), 1) for w in closed[:2]] == [667.0, 667.0]
    assert [round(float(w)) for w in closed[2:]] == [1279, 2448]
    np.testing.assert_allclose(closed[2:] / CO2_EXPERIMENT[1:], [0.96, 1.04], atol=0.005)


def test_h2o_three_vibrations_six_zero_modes_and_ase_agrees() -> None:
    system = mol.h2o()
    analysis = mol.vibrational_analysis(system)
    assert not analysis.linear and analysis.n_rigid == 6 and analysis.n_vibrations == 3
    # ASE's VibrationsData diagonalises the same Hessian with its own code and units (CODATA
    # 2014: 4e-9 relative from vibra's CODATA 2018), so 1e-7 relative covers it.
    data = VibrationsData.from_2d(mol.h2o_atoms(), system.hessian().toarray())
    ase_cm1 = np.sort(data.get_frequencies().real)[-3:]
    np.testing.assert_allclose(analysis.vibration_wavenumbers_cm1(), ase_cm1, rtol=1e-7)
    # Wilson's GF closed form for the same force field (eigen round-off ~1e-15 relative)
    np.testing.assert_allclose(analysis.vibration_wavenumbers_cm1(),
                               _h2o_cm1(mol.H2O_STRETCH, mol.H2O_BEND), rtol=1e-10)
    # ZPE: ASE sums 1/2 E over all 9 modes; its 6 rigid ones are sqrt(round-off) ~ 1e-7 eV each
    assert abs(analysis.zero_point_energy_ev() - data.get_zero_point_energy()) < 1e-5


def test_h2o_default_constants_are_the_documented_fit_to_experiment() -> None:
    # H2O_STRETCH and H2O_BEND: least squares on ln(omega) against the three experimental
    # fundamentals in the GF closed form; refitting here gives the constants to their digits
    stretch, bend = _least_squares_on_log(_h2o_cm1, np.array(H2O_EXPERIMENT), [45.0, 4.0])
    assert abs(stretch - mol.H2O_STRETCH) <= 0.005           # 47.89: 2 decimals
    assert abs(bend - mol.H2O_BEND) <= 0.0005                # 4.021: 3 decimals
    # the documented result "1595, 3680 and 3733 cm^-1"
    closed = _h2o_cm1(mol.H2O_STRETCH, mol.H2O_BEND)
    assert [round(float(w)) for w in closed] == [1595, 3680, 3733]


def test_projection_leaves_exact_hessian_and_removes_rigid_stiffness() -> None:
    system = mol.h2o()
    projected = mol.vibrational_analysis(system)
    plain = mol.vibrational_analysis(system, project=False)
    # K has exact rigid-body zero modes, so projection changes the vibrations only by round-off
    np.testing.assert_allclose(projected.modes.omega[~projected.rigid], plain.modes.omega[~plain.rigid], rtol=1e-10)
    assert plain.n_rigid == 6 and np.all(plain.rigid_overlap[plain.rigid] > 1 - 1e-10)
    # add a stiffness along the x translation and the first rotation: an unprojected solve sees
    # it, the Eckart projection removes it exactly (it lives in the rigid-body subspace)
    t = mol.rigid_body_vectors(system.positions, system.masses)
    root = np.sqrt(np.repeat(system.masses, 3))
    spurious = 0.5 * np.outer(root * t[:, 0], root * t[:, 0]) + 0.3 * np.outer(root * t[:, 3], root * t[:, 3])
    stiff = System.from_hessian(system.positions, system.masses, system.hessian().toarray() + spurious, units="ASE")
    np.testing.assert_allclose(mol.vibrational_analysis(stiff).modes.omega, projected.modes.omega, rtol=1e-9, atol=1e-9)
    assert np.count_nonzero(np.abs(mol.vibrational_analysis(stiff, project=False).modes.omega) > 0.1) == 5


def test_imaginary_mode_kept_and_flagged() -> None:
    system = mol.h2o()
    analysis = mol.vibrational_analysis(system)
    bend = analysis.vibrations[0]
    d = analysis.modes.vectors[:, bend]
    lam = analysis.modes.omega[bend] ** 2
    root = np.sqrt(np.repeat(system.masses, 3))
    # K~' = K~ - 2 lam d d^T flips that eigenvalue to -lam and leaves the others (spectral theorem)
    K = system.hessian().toarray() - 2 * lam * np.outer(root * d, root * d)
    unstable = System.from_hessian(system.positions, system.masses, K, units="ASE", name="saddle")
    with pytest.warns(RuntimeWarning, match="imaginary"):
        result = mol.vibrational_analysis(unstable)
    assert result.n_vibrations == 3 and result.imaginary.sum() == 1
    index = int(np.flatnonzero(result.imaginary)[0])
    np.testing.assert_allclose(result.modes.omega[index], -np.sqrt(lam), rtol=1e-10)
    assert result.force_constant[index] < 0
    assert "i" in result.table().splitlines()[2 + index]
    real = analysis.modes.energies_mev()[analysis.vibrations[1:]]
    np.testing.assert_allclose(result.zero_point_energy_ev(), 0.5e-3 * real.sum(), rtol=1e-10)


@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e3])
def test_linear_detection_is_relative(scale: float) -> None:
    atoms = mol.co2_atoms()
    positions = atoms.positions * scale
    masses = atoms.get_masses()
    assert mol.is_linear(positions, masses)
    noisy = positions + 1e-7 * scale * np.array([[0, 1, 0], [0, -1, 1], [0, 0, 1]])
    assert mol.is_linear(noisy, masses)
    bent = positions.copy()
    bent[1, 1] = 0.02 * scale  # about 1 degree
    assert not mol.is_linear(bent, masses)
    assert mol.rigid_body_vectors(bent, masses).shape == (9, 6)
    assert mol.rigid_body_vectors(positions, masses).shape == (9, 5)


# ----------------------------------------------------------------- valence coordinates
@pytest.mark.parametrize("name", ["CH3CH2OH", "CH3CHO"])
def test_internal_coordinates_and_b_matrix_against_ase_geometry(rng: np.random.Generator, name: str) -> None:
    """B rows of stretches, bends, torsions and (CH3CHO's carbonyl carbon) out-of-plane impropers."""
    atoms = molecule(name)
    model = mol.valence_model(atoms, torsion=0.1)
    assert len(model.torsions) > 0 and len(model.angles) > 0
    assert len(model.out_of_plane) == (3 if name == "CH3CHO" else 0)
    x = atoms.positions + 0.05 * rng.standard_normal(atoms.positions.shape)
    moved = atoms.copy()
    moved.positions = x

    def values(positions: np.ndarray) -> np.ndarray:
        probe = atoms.copy()
        probe.positions = positions
        return np.concatenate([
            [probe.get_distance(i, j) for i, j in model.bonds],
            np.radians([probe.get_angle(*t) for t in model.angles]),
            np.radians([probe.get_dihedral(*q) for q in model.torsions]),
            np.radians([probe.get_dihedral(*q) for q in model.out_of_plane]).reshape(-1),
        ])

    b = model.wilson_b(x).toarray()
    numeric = np.empty_like(b)
    h = 1e-6
    for c in range(x.size):
        step = np.zeros(x.size)
        step[c] = h
        diff = values(x + step.reshape(x.shape)) - values(x - step.reshape(x.shape))
        numeric[:, c] = (diff + np.pi) % (2 * np.pi) - np.pi  # dihedrals wrap at +-pi
        numeric[:, c] /= 2 * h
    # central differences of ASE's coordinate values: truncation ~h^2 ~1e-12, round-off
    # ~eps/h ~1e-10 (degrees converted to rad); 1e-7 absolute covers both with margin
    np.testing.assert_allclose(b, numeric, atol=1e-7)


@pytest.mark.parametrize("name, n_angles, n_torsions, n_out_of_plane", [
    ("C2H6", 12, 9, 0),          # 3 x 3 dihedrals about C-C
    ("NH3", 3, 0, 0),            # pyramidal: no out-of-plane term
    ("C6H6", 18, 24, 18),        # 4 dihedrals about each ring bond; 3 impropers at each carbon
    ("C3H6_D3h", 15, 24, 0),     # the ring's C-C-C angles left out: 5 angles at each carbon
    ("C3H4_D2d", 6, 4, 6),       # H-C...C-H about the straight C=C=C (a linear bend); CH2 carbons planar
    ("2-butyne", 12, 9, 0),      # H-C...C-H about the straight C-C#C-C
    ("ClF3", 3, 0, 2),           # T-shaped: the axis through the two axial F is left out
])
def test_internal_terms_counted_by_hand(name: str, n_angles: int, n_torsions: int, n_out_of_plane: int) -> None:
    """Truth: the terms counted from each molecule's structure (module docstring of internal_terms)."""
    from vibra.molecules.internal_terms import internal_terms

    atoms = molecule(name)
    bonds = np.array(mol.bonds_from_distances(atoms.positions, atoms.get_chemical_symbols()))
    terms = internal_terms(atoms.positions, bonds, linear_tolerance_deg=1.0)
    assert len(terms.angles) == n_angles
    assert (len(terms.torsions), len(terms.out_of_plane)) == (n_torsions, n_out_of_plane)
    assert len(terms.torsion_axis) == n_torsions and not terms.torsions.flags.writeable


def test_linear_bend_rows_and_calculator_forces(rng: np.random.Generator) -> None:
    atoms = Atoms("OCOH", positions=[(-1.16, 0, 0), (0, 0, 0), (1.16, 0, 0), (2.1, 0.6, 0.1)])
    model = mol.valence_model(atoms, bonds=np.array([[0, 1], [1, 2], [2, 3]]), stretch=30.0, bend=3.0, torsion=None)
    assert len(model.linear_angles) == 1 and len(model.angles) == 1
    calc = mol.ValenceForceField(model)
    x = atoms.positions + 0.03 * rng.standard_normal(atoms.positions.shape)
    energy, forces = model.energy_and_forces(x)
    numeric = np.zeros_like(x)
    h = 1e-5
    for a in range(4):
        for c in range(3):
            plus, minus = x.copy(), x.copy()
            plus[a, c] += h
            minus[a, c] -= h
            numeric[a, c] = -(model.energy_and_forces(plus)[0] - model.energy_and_forces(minus)[0]) / (2 * h)
    # F = -dE/dx by central differences: truncation ~h^2 E''' ~1e-9, round-off ~eps E/h ~1e-11
    np.testing.assert_allclose(forces, numeric, atol=1e-7)
    probe = atoms.copy()
    probe.positions = x
    probe.calc = calc
    assert probe.get_potential_energy() == pytest.approx(energy, rel=1e-14)
    # linear-bend energy k (1 + cos angle) (rotation invariant), the docstring's definition
    theta = np.radians(probe.get_angle(0, 1, 2))
    bond_angle = np.radians(probe.get_angle(1, 2, 3))
    d = [probe.get_distance(0, 1) - 1.16, probe.get_distance(1, 2) - 1.16,
         probe.get_distance(2, 3) - np.linalg.norm(atoms.positions[3] - atoms.positions[2])]
    expected = (0.5 * 30.0 * np.sum(np.square(d)) + 3.0 * (1 + np.cos(theta))
                + 0.5 * 3.0 * (bond_angle - np.radians(atoms.get_angle(1, 2, 3))) ** 2)
    assert energy == pytest.approx(expected, rel=1e-10)


def test_central_springs_on_linear_molecule_warn_once_naming_the_keyword() -> None:
    """The builder warns, once, saying which keyword adds the missing bends; the analysis of that
    system does not warn again (issue 48: the warning was printed twice and named no keyword).
    A Hessian given as a matrix is warned of by the analysis, which alone sees its zero modes."""
    atoms = mol.co2_atoms()
    model = mol.valence_model(atoms, bend=None)
    with pytest.warns(mol.SoftModeWarning, match="7 zero-frequency modes .* only 5") as caught:
        system = mol.from_atoms(atoms, model)
    assert len(caught) == 1 and 'no bends: pass bend="typed"' in str(caught[0].message)
    with warnings.catch_warnings():
        warnings.simplefilter("error", mol.SoftModeWarning)
        mol.vibrational_analysis(system)
    with pytest.warns(mol.SoftModeWarning, match="2 motion.* no restoring force") as caught:
        mol.vibrational_analysis(mol.from_hessian(atoms, system.hessian().toarray()))
    assert len(caught) == 1


# ----------------------------------------------------------------- finite differences
@pytest.mark.parametrize("stencil", [2, 4])
def test_finite_difference_equals_ase_vibrations_hessian(stencil: int, tmp_path) -> None:
    atoms = mol.h2o_atoms()
    model = mol.valence_model(atoms, stretch=mol.H2O_STRETCH, bend=mol.H2O_BEND)
    calc = mol.ValenceForceField(model)
    ours = mol.finite_difference_hessian(atoms, calc, step=0.01, stencil=stencil, symmetry=False)
    work = atoms.copy()
    work.calc = calc
    vib = Vibrations(work, name=str(tmp_path / "vib"), delta=0.01, nfree=stencil)
    vib.run()
    theirs = vib.get_vibrations().get_hessian_2d()
    # same stencil, same deterministic forces: only the order of floating-point operations
    # differs, ~eps * |F| / h ~ 1e-13 eV/A^2 against entries of ~50
    np.testing.assert_allclose(ours.hessian, theirs, rtol=0, atol=1e-9)
    assert ours.n_force_calls == 1 + 3 * len(atoms) * (2 * stencil if stencil == 2 else 6)
    assert ours.error_method == "richardson"


@pytest.mark.parametrize(("stencil", "step"), [(2, 1e-3), (2, 1e-2), (4, 3e-3), (4, 1e-2)])
def test_finite_difference_error_estimate_tracks_true_error(stencil: int, step: float) -> None:
    atoms = molecule("CH3CH2OH")
    model = mol.valence_model(atoms, torsion=0.1)
    exact = mol.from_atoms(atoms, model).hessian().toarray()
    result = mol.finite_difference_hessian(atoms, mol.ValenceForceField(model), step=step, stencil=stencil)
    actual = np.abs(result.hessian - exact).max()
    # Richardson's estimate is exact to leading order; the next order is smaller by (h / 1 A)^2
    # <= 1e-4 here, so the largest actual and estimated errors agree within 10 %
    assert 0.9 <= actual / result.error.max() <= 1.1
    assert actual > 100 * result.roundoff  # these steps are truncation dominated


def test_finite_difference_without_estimate_and_from_calculator() -> None:
    atoms = mol.co2_atoms()
    model = mol.valence_model(atoms, stretch=KAPPA, bend=mol.CO2_BEND)
    calc = mol.ValenceForceField(model)
    result = mol.finite_difference_hessian(atoms, calc, estimate_error=False, symmetry=False)
    assert result.error_method == "asymmetry" and result.n_force_calls == 1 + 18
    system = mol.from_calculator(atoms, calc, stencil=4, step=0.005)
    exact = mol.from_atoms(atoms, model)
    # 4-point error ~ h^4 E^(6) ~ 1e-8 relative at h = 0.005 A
    np.testing.assert_allclose(
        mol.vibrational_analysis(system).vibration_wavenumbers_cm1(),
        mol.vibrational_analysis(exact).vibration_wavenumbers_cm1(), rtol=1e-6)


class _NaNCalculator(mol.ValenceForceField):
    def calculate(self, atoms=None, properties=("energy",), system_changes=None):  # type: ignore[override]
        super().calculate(atoms, properties, system_changes or [])
        if abs(self.atoms.positions[1, 1]) > 0:  # NaN once atom 1 moves along y
            self.results["forces"] = np.full((len(self.atoms), 3), np.nan)


def test_nan_forces_raise_and_leave_nothing(tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    atoms = mol.co2_atoms()
    calc = _NaNCalculator(mol.valence_model(atoms))
    with pytest.raises(RuntimeError, match=r"non-finite forces at atom 1 displaced by \+1h along y"):
        mol.finite_difference_hessian(atoms, calc)
    assert list(tmp_path.iterdir()) == []


# ----------------------------------------------------------------- other Hessian sources
def test_from_vibrations_data_and_from_hessian(tmp_path) -> None:
    atoms = mol.h2o_atoms()
    system = mol.h2o()
    K = system.hessian().toarray()
    data = VibrationsData.from_2d(atoms, K)
    rebuilt = mol.from_vibrations_data(data)
    # same K, same masses: eigenvalues agree to round-off; ASE's units differ by 4e-9
    np.testing.assert_allclose(mol.vibrational_analysis(rebuilt).vibration_wavenumbers_cm1(),
                               np.sort(data.get_frequencies().real)[-3:], rtol=1e-7)
    from_user = mol.from_hessian(atoms, K)
    np.testing.assert_allclose(from_user.hessian().toarray(), K, rtol=1e-15, atol=0)
    # a partial VibrationsData (hydrogen atoms only) freezes the oxygen
    partial = VibrationsData.from_2d(atoms, K[3:, 3:], indices=[1, 2])
    frozen = mol.from_vibrations_data(partial)
    assert frozen.n_dof == 6 and frozen.frozen[:3].all()
    # zero modes come out as sqrt(round-off) ~ sqrt(eps) * 3600 cm^-1 ~ 1e-4 cm^-1 in either code
    np.testing.assert_allclose(np.sort(np.abs(_cm1(frozen.modes().omega))),
                               np.sort(np.abs(partial.get_frequencies())), rtol=1e-7, atol=1e-3)


def test_from_phonopy_matches_phonopy_gamma_frequencies() -> None:
    from phonopy import Phonopy
    from phonopy.structure.atoms import PhonopyAtoms

    atoms = mol.h2o_atoms()
    model = mol.valence_model(atoms, stretch=mol.H2O_STRETCH, bend=mol.H2O_BEND)
    calc = mol.ValenceForceField(model)
    unit = PhonopyAtoms(symbols=atoms.get_chemical_symbols(), masses=atoms.get_masses(),
                        positions=atoms.positions + 10.0, cell=np.eye(3) * 20.0)
    phonon = Phonopy(unit, supercell_matrix=np.eye(3, dtype=int), primitive_matrix="P", is_symmetry=False)
    phonon.generate_displacements(distance=0.01, is_plusminus=True)
    forces = []
    for cell in phonon.supercells_with_displacements:
        probe = atoms.copy()
        probe.positions = np.asarray(cell.positions) - 10.0
        probe.calc = calc
        forces.append(probe.get_forces())
    phonon.forces = np.array(forces)
    phonon.produce_force_constants(show_drift=False)
    thz = phonon.run_qpoints([[0, 0, 0]]).frequencies[0]
    system = mol.from_phonopy(phonon, name="H2O")
    with warnings.catch_warnings():
        # the fd rigid-body modes may come out slightly imaginary (reported as negative)
        warnings.simplefilter("ignore", RuntimeWarning)
        ours = mol.vibrational_analysis(system, project=False).modes.frequencies_thz()
    # same force constants; phonopy's THz factor differs from CODATA 2018 by 1.2e-7 relative,
    # and its rigid-body modes are ~1 THz * 1e-7 after the unit change: 2e-7 relative + 1e-6 THz
    np.testing.assert_allclose(np.sort(ours), np.sort(thz), rtol=2e-7, atol=1e-6)


# ----------------------------------------------------------------- isotopes
@pytest.mark.parametrize(("substitutions", "masses"), [
    ({1: "13C"}, (15.99900, 13.00335483507, 15.99900)),
    ({0: "18O", 2: "18O"}, (17.99915961286, 12.011, 17.99915961286)),
    ({0: "18O"}, (17.99915961286, 12.011, 15.999)),
    ({2: 17.0}, (15.999, 12.011, 17.0)),
])
def test_isotope_shifts_axial_closed_form(substitutions, masses) -> None:
    base = mol.co2(dims=1)
    system = mol.substitute_isotopes(base, substitutions)
    assert system.coupling is base.coupling or np.array_equal(system.coupling.toarray(), base.coupling.toarray())
    m1, mc, m3 = masses
    # 3-mass free chain: omega^2 (omega^4 - kappa (1/m1 + 2/mc + 1/m3) omega^2
    #                     + kappa^2 (m1 + mc + m3) / (m1 mc m3)) = 0; eq. 157 when m1 = m3
    s = KAPPA * (1 / m1 + 2 / mc + 1 / m3)
    p = KAPPA**2 * (m1 + mc + m3) / (m1 * mc * m3)
    roots = np.sqrt([(s - np.sqrt(s * s - 4 * p)) / 2, (s + np.sqrt(s * s - 4 * p)) / 2])
    np.testing.assert_allclose(system.modes().omega[1:], roots, rtol=1e-10)


def test_d2o_teller_redlich_product_rule() -> None:
    h2o = mol.h2o()
    d2o = mol.substitute_isotopes(h2o, {1: "D", 2: "2H"}, symbols=["O", "H", "H"])
    w_h = mol.vibrational_analysis(h2o).vibration_wavenumbers_cm1()
    w_d = mol.vibrational_analysis(d2o).vibration_wavenumbers_cm1()
    m_h, m_d = np.asarray(h2o.masses), np.asarray(d2o.masses)

    def moments(masses: np.ndarray) -> np.ndarray:
        x = h2o.positions - (masses[:, None] * h2o.positions).sum(0) / masses.sum()
        inertia = np.sum(masses * np.sum(x * x, 1)) * np.eye(3) - np.einsum("i,ia,ib->ab", masses, x, x)
        return np.linalg.eigvalsh(inertia)

    # Teller-Redlich: prod(w'/w) = prod_a (m_a/m'_a)^(3/2) (M'/M)^(3/2) prod_r (I'_r/I_r)^(1/2)
    expected = (np.prod(m_h / m_d) ** 1.5 * (m_d.sum() / m_h.sum()) ** 1.5
                * np.prod(moments(m_d) / moments(m_h)) ** 0.5)
    # exact for a harmonic K with exact rigid-body zero modes; round-off ~1e-14
    np.testing.assert_allclose(np.prod(w_d / w_h), expected, rtol=1e-10)


def test_isotope_mass_table_agrees_with_periodictable() -> None:
    # periodictable carries the AME2020 evaluation (Wang et al., Chinese Phys. C 45, 030003,
    # 2021); vibra's table holds NIST's values (AME2012/AME2016). Revisions between evaluations
    # are below 1.2e-9 relative for these nuclides (3H: 3.4e-9 amu); rel=1e-8 catches any wrong
    # digit among the first eight significant ones, and a 1e-8 mass error moves a wavenumber
    # by 5e-9 relative, far below anything vibra reports.
    import re

    import periodictable

    aliases = {"D": "2H", "T": "3H"}
    for label, mass in mol.ISOTOPE_MASSES.items():
        number, symbol = re.fullmatch(r"(\d+)([A-Z][a-z]?)", aliases.get(label, label)).groups()
        reference = periodictable.elements.symbol(symbol)[int(number)].mass
        assert mass == pytest.approx(reference, rel=1e-8), label
        assert mol.isotope_mass(label) == mass
    assert mol.isotope_mass("D") == pytest.approx(periodictable.D.mass, rel=1e-8)
    assert mol.isotope_mass("T") == pytest.approx(periodictable.T.mass, rel=1e-8)
    # the public table holds the aliases too, and cannot be edited by a caller
    assert mol.ISOTOPE_MASSES["D"] == mol.ISOTOPE_MASSES["2H"] and mol.ISOTOPE_MASSES["T"] == mol.isotope_mass("3H")
    with pytest.raises(TypeError):
        mol.ISOTOPE_MASSES["13C"] = 13.0  # type: ignore[index]


# ----------------------------------------------------------------- elements and bonds
def test_symbols_from_masses_against_ase_and_isotope_masses() -> None:
    from ase.data import chemical_symbols

    import periodictable

    # every standard atomic mass of ase.data maps back to its own element
    assert mol.symbols_from_masses(atomic_masses[1:]) == tuple(chemical_symbols[1:])
    # IUPAC conventional atomic weights (CIAAW 2021) and isotopic masses (periodictable, AME2020)
    assert mol.symbols_from_masses([1.008, 12.011, 14.007, 15.999, 32.06, 35.45]) == ("H", "C", "N", "O", "S", "Cl")
    isotopes = [periodictable.D.mass, periodictable.C[13].mass, periodictable.Cl[37].mass]
    assert mol.symbols_from_masses(isotopes) == ("H", "C", "Cl")
    # nearest standard mass, as documented: 18O (17.999) lies nearer F (18.998) than O (15.999)
    assert mol.symbols_from_masses([periodictable.O[18].mass]) == ("F",)
    assert mol.symbols_from_masses(mol.co2_atoms().get_masses()) == ("O", "C", "O")


def test_bonds_from_distances_co2_h2o_by_hand() -> None:
    # covalent radii (Cordero et al. 2008, ase.data): H 0.31, C 0.76, O 0.66 Angstrom
    # CO2: C=O 1.16 < 1.25 (0.76 + 0.66) = 1.775; O...O 2.32 > 1.25 (0.66 + 0.66) = 1.65
    co2 = mol.co2_atoms()
    assert mol.bonds_from_distances(co2.positions, ["O", "C", "O"]) == ((0, 1), (1, 2))
    # H2O: O-H 0.9572 < 1.25 (0.66 + 0.31) = 1.2125; H...H 2 r sin(52.26 deg) = 1.514 > 0.775
    h2o = mol.h2o_atoms()
    assert mol.bonds_from_distances(h2o.positions, ["O", "H", "H"]) == ((0, 1), (0, 2))
    # the O-H limit scale (0.66 + 0.31) crosses r = 0.9572 at scale = 0.98680
    assert mol.bonds_from_distances(h2o.positions, ["O", "H", "H"], scale=0.986) == ()
    assert mol.bonds_from_distances(h2o.positions, ["O", "H", "H"], scale=0.988) == ((0, 1), (0, 2))
    # H...H joins at scale > 1.5139 / 0.62 = 2.442
    assert mol.bonds_from_distances(h2o.positions, ["O", "H", "H"], scale=2.45) == ((0, 1), (0, 2), (1, 2))
    # the axial CO2 (1-D positions) and a lone atom
    assert mol.bonds_from_distances([[0.0], [1.16], [2.32]], ["O", "C", "O"]) == ((0, 1), (1, 2))
    assert mol.bonds_from_distances([[0.0, 0.0, 0.0]], ["He"]) == ()


def test_bonds_from_distances_match_ase_neighbor_list() -> None:
    # ASE's own neighbour list with natural_cutoffs(mult=1.25): i, j are neighbours when
    # d < 1.25 r_i + 1.25 r_j, the same rule computed by independent code
    from ase.neighborlist import natural_cutoffs, neighbor_list

    for name in ["CH3CH2OH", "C6H6", "CH3COOH", "C60"]:
        atoms = molecule(name)
        first, second = neighbor_list("ij", atoms, natural_cutoffs(atoms, mult=1.25))
        expected = tuple(sorted((int(i), int(j)) for i, j in zip(first, second) if i < j))
        assert mol.bonds_from_distances(atoms.positions, atoms.get_chemical_symbols()) == expected, name


# ----------------------------------------------------------------- bad input
def _co2_model() -> mol.ValenceModel:
    return mol.valence_model(mol.co2_atoms())


def _bad_inputs():
    co2 = mol.co2_atoms()
    calc = mol.ValenceForceField(_co2_model())
    ghost = Atoms(numbers=[8, 0, 8], positions=[(-1.16, 0, 0), (0, 0, 0), (1.16, 0, 0)])
    overlap = Atoms("OCO", positions=[(-1.16, 0, 0), (0, 0, 0), (0.05, 0, 0)])
    stretched = mol.co2_atoms(bond_length=1.20)
    h2o = mol.h2o()
    return [
        (lambda: mol.from_atoms(ghost), ValueError, r"atoms\.numbers\[1\] is 0 \('X'\)"),
        (lambda: mol.from_atoms(overlap), ValueError, r"atoms 1 and 2 overlap \(distance 0\.05"),
        (lambda: mol.from_atoms(stretched, _co2_model()), ValueError, r"residual force .* on atom 0"),
        (lambda: mol.from_atoms("CO2"), TypeError, r"atoms must be an ase\.Atoms, got str"),
        (lambda: mol.from_atoms(Atoms()), ValueError, r"atoms holds no atoms"),
        (lambda: mol.from_atoms(co2, 3), TypeError, r"model must be a ValenceModel, got int"),
        (lambda: mol.from_atoms(co2, _co2_model(), stretch=1.0), TypeError, r"either model or valence_model"),
        (lambda: mol.from_atoms(mol.h2o_atoms()[:2], _co2_model()), ValueError, r"model is for 3 atoms but atoms has 2"),
        (lambda: mol.from_atoms(Atoms("He2", positions=[(0, 0, 0), (0, 0, 5)])), ValueError, r"model has no terms"),
        (lambda: mol.from_atoms(co2, masses=[1.0, 2.0]), ValueError, r"masses must have 3 entries"),
        (lambda: mol.from_atoms(co2, masses=[1.0, -2.0, 1.0]), ValueError, r"masses\[1\] is .*-2\.0.*positive"),
        (lambda: mol.valence_model(co2, stretch=[1.0]), ValueError, r"stretch must be a number or have 2 entries"),
        (lambda: mol.valence_model(co2, stretch=-1.0), ValueError, r"stretch\[0\] is .*-1\.0.*positive"),
        (lambda: mol.valence_model(co2, bonds=[[0, 1.5]]), TypeError, r"bonds must hold integer atom indices"),
        (lambda: mol.valence_model(co2, bonds=[0, 1]), ValueError, r"bonds must have shape \(n, 2\), got \(2,\)"),
        (lambda: mol.valence_model(co2, bonds=[[0, 3]]), ValueError, r"bonds\[0,1\] is 3; atom indices run from 0 to 2"),
        (lambda: mol.valence_model(co2, bonds=[[1, 1]]), ValueError, r"bonds\[0\] is \[1, 1\]; its atoms must be distinct"),
        (lambda: mol.valence_model(co2, bond_scale=0.0), ValueError, r"bond_scale is 0\.0"),
        (lambda: mol.valence_model(co2, linear_tolerance_deg=90), ValueError, r"linear_tolerance_deg is 90"),
        (lambda: mol.valence_model(co2, bend=[]), ValueError, r"linear_bend is required"),
        (lambda: mol.valence_model(co2, torsion="typd"), ValueError, r"torsion is 'typd'; expected \"typed\""),
        (lambda: mol.valence_model(co2, stretch=None), ValueError, r"stretch is None; every bond needs"),
        (lambda: mol.molecule("C2H6", torsion=0), ValueError, r"torsion is 0; .*\(pass torsion=None to leave"),
        (lambda: mol.valence_model(molecule("H2CO"), out_of_plane=-1.0), ValueError, r"out_of_plane\[0\] is .*-1\.0"),
        (lambda: _co2_model().wilson_b(np.zeros((2, 3))), ValueError, r"positions must have shape \(3, 3\)"),
        (lambda: mol.ValenceForceField("model"), TypeError, r"model must be a ValenceModel, got str"),
        (lambda: _energy_on(mol.h2o_atoms()[:2], calc), ValueError, r"atoms has 2 atoms; this force field is for 3"),
        (lambda: mol.finite_difference_hessian(co2), TypeError, r"calculator is None and atoms has no calculator"),
        (lambda: mol.finite_difference_hessian(co2, object()), TypeError, r"calculator must be an ASE calculator"),
        (lambda: mol.finite_difference_hessian(co2, calc, step=0.0), ValueError, r"step is 0\.0"),
        (lambda: mol.finite_difference_hessian(co2, calc, stencil=3), ValueError, r"stencil is 3; expected 2 or 4"),
        (lambda: mol.finite_difference_hessian(co2, calc, force_noise=-1.0), ValueError, r"force_noise is -1\.0"),
        (lambda: mol.finite_difference_hessian(stretched, calc, force_tolerance=1e-3), ValueError,
         r"not an equilibrium of the calculator: residual force .* on atom 0"),
        (lambda: mol.finite_difference_hessian(co2, _ShapeCalculator(_co2_model())), RuntimeError,
         r"forces of shape \(2, 3\) at the reference geometry"),
        (lambda: mol.from_vibrations_data(np.zeros(3)), TypeError, r"data must be an ase\.vibrations\.VibrationsData"),
        (lambda: mol.from_phonopy(None), TypeError, r"phonon must be a phonopy\.Phonopy, got NoneType"),
        (lambda: mol.from_phonopy(_phonopy_without_fc()), ValueError, r"phonon has no force constants"),
        (lambda: mol.from_phonopy(_phonopy_compact_fc()), ValueError,
         r"phonon\.force_constants must be full, shape \(8, 8, 3, 3\), got \(1, 8, 3, 3\)"),
        (lambda: mol.vibrational_analysis(h2o.hessian()), TypeError, r"system must be a vibra System"),
        (lambda: mol.vibrational_analysis(System.generalized(np.eye(2), np.eye(2))), TypeError, r"generalised coordinates"),
        (lambda: mol.vibrational_analysis(h2o.freeze(sites=[0])), ValueError, r"3 frozen degrees of freedom"),
        (lambda: mol.vibrational_analysis(h2o, accuracy="best"), ValueError, r"accuracy is 'best'; expected one of"),
        (lambda: mol.vibrational_analysis(h2o, linear_rtol=-1e-6), ValueError,
         r"linear_rtol is -1e-06; it must be >= 0 \(relative\)"),
        (lambda: mol.vibrational_analysis(h2o, zero_rtol="small"), TypeError, r"zero_rtol must be a real number, got str"),
        (lambda: mol.from_atoms(co2, force_tolerance=-1.0), ValueError,
         r"force_tolerance is -1\.0; it must be >= 0 \(eV/Angstrom\)"),
        (lambda: mol.finite_difference_hessian(co2, _NaNCalculator(_co2_model()), force_tolerance=float("nan")),
         ValueError, r"force_tolerance is nan; it must be finite"),  # checked before any force call
        (lambda: mol.symbols_from_masses([[1.0, 2.0]]), ValueError, r"masses must be 1-D, got shape \(1, 2\)"),
        (lambda: mol.symbols_from_masses([12.0, -1.0]), ValueError, r"masses\[1\] is -1\.0"),
        (lambda: mol.symbols_from_masses([12.0, float("nan")]), ValueError, r"masses\[1\] is nan"),
        (lambda: mol.bonds_from_distances(np.zeros(3), ["O", "C", "O"]), ValueError, r"positions must be 2-D, got shape \(3,\)"),
        (lambda: mol.bonds_from_distances(np.zeros((3, 4)), ["O", "C", "O"]), ValueError,
         r"positions must have shape \(n_atoms, 3\) \(or 1 or 2 columns\), got \(3, 4\)"),
        (lambda: mol.bonds_from_distances(np.zeros((3, 3)), ["O", "C"]), ValueError,
         r"symbols must name 3 atoms \(one per position\), got 2"),
        (lambda: mol.bonds_from_distances(np.zeros((2, 3)), ["O", "Xx"]), ValueError, r"symbols\[1\] is 'Xx'"),
        (lambda: mol.bonds_from_distances(np.zeros((2, 3)), ["X", "O"]), ValueError, r"symbols\[0\] is 'X'"),
        (lambda: mol.bonds_from_distances(np.zeros((2, 3)), ["O", 8]), TypeError, r"symbols\[1\] must be a chemical symbol"),
        (lambda: mol.bonds_from_distances(np.eye(2, 3), ["O", "H"], scale=0.0), ValueError, r"scale is 0\.0"),
        (lambda: mol.isotope_mass(13), TypeError, r"label must be a str"),
        (lambda: mol.isotope_mass("C13x"), ValueError, r"label is 'C13x'; expected an isotope like"),
        (lambda: mol.isotope_mass("99Xx"), ValueError, r"label is '99Xx'; expected an isotope like"),
        (lambda: mol.isotope_mass("13Fe"), ValueError, r"label is '13Fe': isotope not in vibra's table"),
        (lambda: mol.substitute_isotopes(h2o.hessian(), {}), TypeError, r"system must be a vibra System"),
        (lambda: mol.substitute_isotopes(System.from_springs([0.0, 1.0], 1.0, [[0, 1]], 1.0), {0: 2.0}),
         TypeError, r"system must be in ASE units"),
        (lambda: mol.substitute_isotopes(h2o, [(0, 2.0)]), TypeError, r"substitutions must be a mapping"),
        (lambda: mol.substitute_isotopes(h2o, {0: "18O"}, symbols=["O"]), ValueError, r"symbols must name 3 atoms, got 1"),
        (lambda: mol.substitute_isotopes(h2o, {"0": 2.0}), TypeError, r"substitutions key '0' must be an int"),
        (lambda: mol.substitute_isotopes(h2o, {3: 2.0}), ValueError, r"substitutions\[3\]: atom index out of range 0\.\.2"),
        (lambda: mol.substitute_isotopes(h2o, {1: "18O"}, symbols=["O", "H", "H"]), ValueError,
         r"substitutions\[1\] is '18O' but atom 1 is 'H'"),
        (lambda: mol.substitute_isotopes(h2o, {1: -1.0}), ValueError, r"substitutions\[1\] is -1\.0; a mass must be positive"),
        (lambda: mol.substitute_isotopes(h2o, {1: [2.0]}), TypeError, r"substitutions\[1\] must be a mass or an isotope name"),
        (lambda: mol.co2(dims=2), ValueError, r"dims is 2; expected 1 \(axial model\) or 3"),
        (lambda: mol.co2(bond_length=-1.0), ValueError, r"bond_length is -1\.0"),
        (lambda: mol.FiniteDifferenceHessian.omega_errors(
            mol.finite_difference_hessian(co2, calc, estimate_error=False), mol.co2().modes(vectors=False)),
         ValueError, r"modes has no vectors"),
        (lambda: mol.finite_difference_hessian(co2, calc, estimate_error=False).omega_errors(mol.co2(dims=1).modes()),
         ValueError, r"modes has 3 dofs; the Hessian has 9"),
    ]


def _energy_on(atoms: Atoms, calc) -> float:
    atoms.calc = calc
    return atoms.get_potential_energy()


class _ShapeCalculator(mol.ValenceForceField):
    def calculate(self, atoms=None, properties=("energy",), system_changes=None):  # type: ignore[override]
        super().calculate(atoms, properties, system_changes or [])
        self.results["forces"] = self.results["forces"][:2]


def _phonopy_without_fc():
    from phonopy import Phonopy
    from phonopy.structure.atoms import PhonopyAtoms

    return Phonopy(PhonopyAtoms(symbols=["He"], positions=[[1.0, 1.0, 1.0]], cell=np.eye(3) * 5.0),
                   supercell_matrix=np.eye(3, dtype=int), primitive_matrix="P")


def _phonopy_compact_fc():
    from phonopy import Phonopy
    from phonopy.structure.atoms import PhonopyAtoms

    phonon = Phonopy(PhonopyAtoms(symbols=["He"], positions=[[1.0, 1.0, 1.0]], cell=np.eye(3) * 3.0),
                     supercell_matrix=2 * np.eye(3, dtype=int), primitive_matrix="P")
    phonon.generate_displacements(distance=0.01)
    phonon.forces = np.zeros((len(phonon.supercells_with_displacements), 8, 3))
    phonon.produce_force_constants(calculate_full_force_constants=False, show_drift=False)
    return phonon


@pytest.mark.parametrize("case", range(len(_bad_inputs())))
def test_bad_input_messages(case: int) -> None:
    call, error, pattern = _bad_inputs()[case]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mol.SoftModeWarning)
        with pytest.raises(error, match=pattern):
            call()


# ----------------------------------------------------------------- immutability
def test_results_are_frozen() -> None:
    atoms = mol.co2_atoms()
    model = _co2_model()
    fd = mol.finite_difference_hessian(atoms, mol.ValenceForceField(model), estimate_error=False)
    analysis = mol.vibrational_analysis(mol.co2())
    for obj, field, array in [(model, "bond_k", model.bond_k), (fd, "hessian", fd.hessian),
                              (analysis, "reduced_mass", analysis.reduced_mass)]:
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(obj, field, array)
        with pytest.raises(ValueError, match="read-only"):
            array[0] = 1.0
    with pytest.raises(ValueError, match="read-only"):
        analysis.rigid[0] = False


# ----------------------------------------------------------------- docs
def test_docs_molecules_examples_run_as_written(tmp_path, monkeypatch) -> None:
    # docs/molecules.md must work exactly as written (its code blocks, in order)
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "docs" / "molecules.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(blocks) == 5
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    for block in blocks:
        exec(compile(block, "docs/molecules.md", "exec"), namespace)
    assert namespace["co2"].n_dof == 9 and namespace["axial"].n_dof == 3
    assert namespace["result"].n_rigid == 5
    assert namespace["group"].name == "C2v" and namespace["ch4"].point_group.name == "Td"
    # the export example writes into exports/; the cross-check leaves no cache behind
    assert [p.name for p in tmp_path.iterdir()] == ["exports"]
    assert sorted(p.name for p in (tmp_path / "exports").iterdir()) == [
        "FORCE_CONSTANTS", "d2o.molden", "d2o_bend.traj", "d2o_bend.xyz"]
    assert [round(float(w)) for w in namespace["water"].vibration_wavenumbers_cm1()] == [1163, 2664, 2736]


def test_molecular_systems_keep_their_chemical_symbols() -> None:
    """Every molecule builder records the symbols of its atoms (truth: the ASE Atoms given)."""
    from ase.build import molecule as ase_molecule

    from vibra.molecules import co2, from_atoms, from_hessian, h2o, h2o_atoms, molecule

    assert co2().symbols == ("O", "C", "O") and co2(dims=1).symbols == ("O", "C", "O")
    assert h2o().symbols == ("O", "H", "H")
    assert molecule("CH4").symbols == tuple(ase_molecule("CH4").get_chemical_symbols())
    water = h2o_atoms()
    assert from_atoms(water).symbols == ("O", "H", "H")
    assert from_hessian(water, h2o().hessian().toarray()).symbols == ("O", "H", "H")
