"""Tests of vibra.spectra (and its charts, vibra.charts.spectra).

Truth comes from outside the module: closed forms for the axial and 3-D CO2 models (seed
003 eq. 157 and the bend of a linear triatomic), the CO2 selection rules, ASE's
`Infrared`, `HarmonicThermo` and `IdealGasThermo`, sympy derivatives, the Teller-Redlich
product rule, the line-shape integrals, and finite differences of models written here.
The test systems are built here with `System.from_springs` / `System.from_terms`.
"""

from __future__ import annotations

import dataclasses
import re
import tempfile
from pathlib import Path

import numpy as np
import pytest
import sympy
from ase import Atoms
from ase import units as ase_units
from ase.calculators.calculator import Calculator, all_changes
from ase.data import atomic_masses_common, atomic_numbers
from ase.thermochemistry import HarmonicThermo, IdealGasThermo
from ase.vibrations import Infrared
from helpers.images import check_png
from scipy import constants

import vibra
from vibra import molecules as mol
from vibra import spectra
from vibra.charts._style import save_figure
from vibra.charts.spectra import (
    plot_broadened_spectrum,
    plot_stick_spectrum,
    plot_thermo,
)

M_O = float(atomic_masses_common[atomic_numbers["O"]])
M_C = float(atomic_masses_common[atomic_numbers["C"]])
M_H = float(atomic_masses_common[atomic_numbers["H"]])
L_CO = 1.16            # Angstrom (seed 003: L = 0.116 nm)
K_STRETCH = 100.0      # eV/Angstrom^2
K_BEND = 5.0           # eV/rad^2
DELTA = 0.3            # e: CO2 charges (-DELTA, 2 DELTA, -DELTA)
CO2_CHARGES = np.array([-DELTA, 2 * DELTA, -DELTA])


def omega_to_cm1(omega_squared_ase: float) -> float:
    """sqrt(k/m) with k in eV/A^2 and m in amu, converted to cm^-1 with scipy.constants."""
    omega_si = np.sqrt(omega_squared_ase * constants.e / constants.angstrom**2 / constants.atomic_mass)
    return float(omega_si / (2 * np.pi * constants.c / constants.centi))


def co2_3d(m_o1: float = M_O, m_c: float = M_C, m_o2: float = M_O) -> vibra.System:
    """Linear O-C-O along x: two C-O stretches and a linear bend in y and in z.

    Wilson-B rows: stretch (i, j) is -e on i, +e on j; the bend coordinate in y is
    (u_O1y - u_Cy)/L + (u_O2y - u_Cy)/L (zero for translations and rigid rotations).
    """
    positions = np.array([[-L_CO, 0, 0], [0, 0, 0], [L_CO, 0, 0]])
    b = np.zeros((4, 9))
    b[0, 0], b[0, 3] = -1.0, 1.0
    b[1, 3], b[1, 6] = -1.0, 1.0
    b[2, [1, 4, 7]] = [1 / L_CO, -2 / L_CO, 1 / L_CO]
    b[3, [2, 5, 8]] = [1 / L_CO, -2 / L_CO, 1 / L_CO]
    return vibra.System.from_terms(positions, [m_o1, m_c, m_o2], b,
                                   [K_STRETCH, K_STRETCH, K_BEND, K_BEND], units="ASE", name="co2")


def co2_axial(m_o: float = M_O, m_c: float = M_C) -> vibra.System:
    """The seed's axial CO2 (eq. 152-155): 3 sites on a line, two springs."""
    return vibra.System.from_springs([0.0, L_CO, 2 * L_CO], [m_o, m_c, m_o], [[0, 1], [1, 2]],
                                     K_STRETCH, units="ASE", name="co2-axial")


H2O_POSITIONS = np.array([[0.0, 0.0, 0.0], [0.757, 0.586, 0.0], [-0.757, 0.586, 0.0]])
H2O_CHARGES = np.array([-0.8, 0.4, 0.4])
H2O_SPRINGS = np.array([[0, 1], [0, 2], [1, 2]])
H2O_STIFFNESS = np.array([50.0, 50.0, 5.0])


def h2o(masses: tuple[float, float, float] = (M_O, M_H, M_H), positions: np.ndarray = H2O_POSITIONS
        ) -> vibra.System:
    """Bent H2O: two O-H springs and an H-H spring (Urey-Bradley), rotation invariant."""
    return vibra.System.from_springs(positions, list(masses), H2O_SPRINGS, H2O_STIFFNESS,
                                     units="ASE", name="h2o")


# closed forms of co2_3d (seed 003 eq. 157 for the stretches; bend of a linear XY2)
SYM = omega_to_cm1(K_STRETCH / M_O)
ASYM = omega_to_cm1(K_STRETCH * (1 / M_O + 2 / M_C))
BEND = omega_to_cm1(K_BEND / L_CO**2 * (2 / M_O + 4 / M_C))


class HarmonicPointCharges(Calculator):
    """ASE calculator: E = 1/2 u^T K u about `reference`, dipole = sum q_i r_i (+ a cubic term).

    The optional cubic term beta * sum_i x_i^3 along x makes the dipole non-linear, so that
    finite differences have an O(step^2) error with a known value (beta * step^2 per row).
    """

    implemented_properties = ["energy", "forces", "dipole"]

    def __init__(self, hessian: np.ndarray, reference: np.ndarray, charges: np.ndarray,
                 beta: float = 0.0) -> None:
        super().__init__()
        self.hessian, self.reference, self.charges, self.beta = hessian, reference, charges, beta

    def calculate(self, atoms=None, properties=("energy",), system_changes=all_changes):
        super().calculate(atoms, properties, system_changes)
        positions = self.atoms.get_positions()
        u = (positions - self.reference).ravel()
        force = -self.hessian @ u
        dipole = self.charges @ positions
        dipole[0] += self.beta * np.sum(positions[:, 0] ** 3)
        self.results = {"energy": 0.5 * float(u @ self.hessian @ u),
                        "forces": force.reshape(-1, 3), "dipole": dipole}


def h2o_atoms(beta: float = 0.0) -> Atoms:
    system = h2o()
    atoms = Atoms("OH2", positions=H2O_POSITIONS, masses=[M_O, M_H, M_H])
    atoms.calc = HarmonicPointCharges(system.hessian().toarray(), H2O_POSITIONS, H2O_CHARGES, beta)
    return atoms


def by_wavenumber(result, value: float) -> np.ndarray:
    """Mask of the lines within 1e-6 relative of `value` (closed-form identification)."""
    return np.isclose(result.wavenumbers, value, rtol=1e-6, atol=0)


# ====================================================================== IR
def test_co2_frequencies_match_closed_forms_before_spectra():
    # The fixture itself: dense/accurate eigen-solutions agree with the closed forms to
    # ~1e-12 relative; 1e-9 leaves room for any solver path.
    ir = spectra.ir_spectrum(co2_3d(), charges=CO2_CHARGES)
    np.testing.assert_allclose(ir.wavenumbers, [BEND, BEND, SYM, ASYM], rtol=1e-9)


def test_co2_ir_selection_rules_and_closed_form_intensities():
    ir = spectra.ir_spectrum(co2_3d(), charges=CO2_CHARGES)
    # Symmetric stretch: the two O move oppositely with equal charges -> dmu = 0 exactly.
    # Bend (each component) and asymmetric stretch: with point charges and a momentum-free
    # mode, |dmu/dQ|^2 = sum_i q_i^2 / m_i = DELTA^2 (2/m_O + 4/m_C) (derived by hand from the
    # M-normalised shapes of eq. 158 and of the bend; the sym stretch carries none of it).
    expected = DELTA**2 * (2 / M_O + 4 / M_C)
    sym, asym, bend = by_wavenumber(ir, SYM), by_wavenumber(ir, ASYM), by_wavenumber(ir, BEND)
    assert (sym.sum(), asym.sum(), bend.sum()) == (1, 1, 2)
    assert not ir.active()[sym].any()
    assert ir.active()[asym].all() and ir.active()[bend].all()
    # rounding in the shapes (~1e-16) leaves the forbidden line at ~1e-32 of the others
    assert ir.intensities[sym][0] < 1e-20 * expected
    np.testing.assert_allclose(ir.intensities[asym], expected, rtol=1e-12)
    np.testing.assert_allclose(ir.intensities[bend], expected, rtol=1e-12)
    # the bend's dipole change is perpendicular to the axis, the asym stretch's along it
    assert abs(ir.dipole_derivatives[asym][0, 0]) == pytest.approx(np.sqrt(expected), rel=1e-12)
    np.testing.assert_allclose(ir.dipole_derivatives[bend][:, 0], 0.0, atol=1e-14)
    assert "IR (point charges)" in ir.table() and ir.table().count(" no") == 1


def test_co2_axial_model_ir():
    # The seed's 1-D model (dim = 1): only the asymmetric stretch of eq. 157-158 is IR active.
    ir = spectra.ir_spectrum(co2_axial(), charges=CO2_CHARGES)
    np.testing.assert_allclose(ir.wavenumbers, [SYM, ASYM], rtol=1e-9)
    np.testing.assert_array_equal(ir.active(), [False, True])
    np.testing.assert_allclose(ir.intensities[1], DELTA**2 * (2 / M_O + 4 / M_C), rtol=1e-12)
    np.testing.assert_allclose(ir.dipole_derivatives[:, 1:], 0.0, atol=0)


def test_km_per_mol_factor_matches_ase_porezag_factor():
    # ASE converts (D/A)^2/amu to km/mol with 42.255 (Porezag & Pederson 1996), quoted to five
    # digits and 2.4e-5 below the CODATA value; 5e-5 relative covers that rounding.
    assert spectra.KM_PER_MOL_PER_E2_AMU * ase_units.Debye**2 == pytest.approx(42.255, rel=5e-5)


def test_ir_matches_ase_infrared(tmp_path):
    # ASE builds its own Hessian and dipole derivatives by finite differences of the same
    # harmonic, point-charge calculator: both are linear in the displacements, so central
    # differences are exact up to rounding (~1e-12 relative); ASE's unit constants (CODATA
    # 2014) differ from scipy's by ~1e-8. Tolerances: 1e-6 on wavenumbers and intensities.
    atoms = h2o_atoms()
    infrared = Infrared(atoms, name=str(tmp_path / "ir"), delta=0.01)
    infrared.run()
    ase_cm1 = infrared.get_frequencies().real[-3:]
    ase_intensity = infrared.intensities[-3:]                      # (D/A)^2 / amu
    ir = spectra.ir_spectrum(h2o(), charges=H2O_CHARGES)
    np.testing.assert_allclose(ir.wavenumbers, ase_cm1, rtol=1e-6)
    np.testing.assert_allclose(ir.intensities / ase_units.Debye**2, ase_intensity, rtol=1e-6)
    assert ir.active().all()  # H2O (C2v): all three modes are IR active


def test_calculator_dipole_derivatives_match_point_charges():
    atoms = h2o_atoms()
    derivatives = spectra.dipole_derivatives(atoms, step=0.01)
    # mu is linear in r: central differences are exact up to rounding (|mu| eps / step ~ 1e-13)
    expected = np.kron(H2O_CHARGES[:, None], np.eye(3))           # row 3i+b: q_i e_b
    np.testing.assert_allclose(derivatives, expected, atol=1e-11)
    from_calculator = spectra.ir_spectrum(h2o(), dipole_derivatives=derivatives)
    from_charges = spectra.ir_spectrum(h2o(), charges=H2O_CHARGES)
    assert from_calculator.model == "dipole derivatives"
    np.testing.assert_allclose(from_calculator.intensities, from_charges.intensities, rtol=1e-9)
    # the (n_sites, 3, 3) layout is the same data
    again = spectra.ir_spectrum(h2o(), dipole_derivatives=derivatives.reshape(3, 3, 3))
    np.testing.assert_array_equal(again.intensities, from_calculator.intensities)
    np.testing.assert_array_equal(atoms.get_positions(), H2O_POSITIONS)  # atoms left untouched


def test_dipole_derivative_step_error_is_second_order():
    # mu_x has beta * sum x_i^3: d/dx_i = 3 beta x_i^2, and the central difference adds exactly
    # beta * step^2 (the third-derivative term 6 beta * step^2 / 6).
    beta = 0.5
    atoms = h2o_atoms(beta)
    for step in (0.02, 0.01):
        derivatives = spectra.dipole_derivatives(atoms, step=step)
        exact = np.kron(H2O_CHARGES[:, None], np.eye(3))
        exact[0::3, 0] += 3 * beta * H2O_POSITIONS[:, 0] ** 2
        np.testing.assert_allclose(derivatives[0::3, 0] - exact[0::3, 0], beta * step**2, rtol=1e-6)


def test_electronegativity_charges():
    # q_O = -0.2 (chi_O - chi_C) per bond with Pauling chi_C = 2.55, chi_O = 3.44 (CRC)
    charges = spectra.electronegativity_charges(["O", "C", "O"], [[0, 1], [1, 2]])
    np.testing.assert_allclose(charges, [-0.178, 0.356, -0.178], atol=1e-12)
    water = spectra.electronegativity_charges(["O", "H", "H"], [[0, 1], [0, 2]], transfer=0.5)
    np.testing.assert_allclose(water, [-1.24, 0.62, 0.62], atol=1e-12)
    # the table's charges give the same CO2 selection rules
    ir = spectra.ir_spectrum(co2_3d(), charges=charges)
    assert ir.active().tolist() == [True, True, False, True]


class ValencePointCharges(mol.ValenceForceField):
    """vibra's valence force field (nonlinear coordinates) plus a point-charge dipole."""

    implemented_properties = ["energy", "forces", "dipole"]

    def __init__(self, model: mol.ValenceModel, charges: np.ndarray) -> None:
        super().__init__(model)
        self.charges = np.asarray(charges, dtype=float)

    def calculate(self, atoms=None, properties=("energy",), system_changes=all_changes):
        super().calculate(atoms, properties, system_changes)
        self.results["dipole"] = self.charges @ self.atoms.get_positions()


def test_fd_hessian_rotations_left_out_via_vibrational_analysis(tmp_path):
    # A finite-difference Hessian of a nonlinear force field (h = 0.01 A) puts H2O's rotations
    # at 26 and 29 cm^-1: beyond the default zero_rtol, so bare Modes let one through as a
    # strong spurious IR line. The Eckart analysis matches them and the spectrum keeps 3N-6.
    atoms = mol.h2o_atoms()
    model = mol.valence_model(atoms, bonds=np.array([[0, 1], [0, 2]]), stretch=mol.H2O_STRETCH,
                              bend=mol.H2O_BEND)
    calc = ValencePointCharges(model, H2O_CHARGES)
    system = mol.finite_difference_hessian(atoms, calc, step=0.01).system()
    with pytest.warns(RuntimeWarning):         # the fd rotations are partly imaginary
        bare = spectra.ir_spectrum(system, charges=H2O_CHARGES)
    assert (bare.wavenumbers < 100.0).any() and bare.intensities_km_per_mol().max() > 100.0
    analysis = mol.vibrational_analysis(system)
    ir = spectra.ir_spectrum(system, analysis, charges=H2O_CHARGES)
    raman = spectra.raman_spectrum(system, analysis, bonds=[[0, 1], [0, 2]])
    np.testing.assert_array_equal(ir.mode_indices, analysis.vibrations)
    np.testing.assert_array_equal(raman.mode_indices, analysis.vibrations)
    # ASE's Infrared on the same calculator, step and stencil: the same fd Hessian, solved
    # without projection. Wavenumbers differ by ASE's CODATA 2014 constants (~5e-9): 1e-7.
    # ASE's vectors carry a rotational admixture of at most (omega_rot / omega_vib)^2 =
    # (29 / 1595)^2 = 3.3e-4 in amplitude, so intensities agree to 2 x 3.3e-4 < 1e-3.
    work = atoms.copy()
    work.calc = calc
    infrared = Infrared(work, name=str(tmp_path / "ir"), delta=0.01, nfree=2)
    infrared.run()
    np.testing.assert_allclose(ir.wavenumbers, infrared.get_frequencies().real[-3:], rtol=1e-7)
    np.testing.assert_allclose(ir.intensities / ase_units.Debye**2, infrared.intensities[-3:], rtol=1e-3)
    # the thermochemistry counts the same 3 vibrations: ASE HarmonicThermo on ASE's 3 highest
    # energies, at the same kT (entropy depends on x = E/kT; 5e-9 in E -> 1e-7 relative)
    thermo = spectra.thermochemistry(analysis, [298.15])
    assert thermo.n_imaginary == 0 and len(thermo.wavenumbers) == 3
    reference = HarmonicThermo(vib_energies=infrared.get_energies().real[-3:])
    t_ase = ase_temperature(np.array([298.15]))[0]
    assert thermo.entropy[0] / K_VIBRA == pytest.approx(
        reference.get_entropy(t_ase, verbose=False) / ase_units.kB, rel=1e-6)


# ====================================================================== Raman
def bond_polarizability(positions: np.ndarray, bonds: np.ndarray, a_par, a_perp, d_par, d_perp,
                        r0: np.ndarray) -> np.ndarray:
    """The model's definition, written directly: sum_b a_par(r) e e^T + a_perp(r) (I - e e^T)."""
    total = np.zeros((3, 3))
    for b, (i, j) in enumerate(bonds):
        vector = positions[j] - positions[i]
        r = np.linalg.norm(vector)
        e = vector / r
        par = a_par[b] + d_par[b] * (r - r0[b])
        perp = a_perp[b] + d_perp[b] * (r - r0[b])
        total += par * np.outer(e, e) + perp * (np.eye(3) - np.outer(e, e))
    return total


def test_co2_mutual_exclusion():
    system = co2_3d()
    modes = system.modes()
    ir = spectra.ir_spectrum(system, modes, charges=CO2_CHARGES)
    raman = spectra.raman_spectrum(system, modes, bonds=[[0, 1], [1, 2]],
                                   polarizability_parallel=2.0, polarizability_perpendicular=0.7,
                                   derivative_parallel=3.0, derivative_perpendicular=0.4)
    np.testing.assert_array_equal(raman.mode_indices, ir.mode_indices)
    # centrosymmetric: no mode is both IR and Raman active, and every mode is one of them
    assert not (ir.active() & raman.active()).any()
    assert (ir.active() | raman.active()).all()
    sym = by_wavenumber(raman, SYM)
    assert raman.active()[sym].all() and not ir.active()[sym].any()
    # forbidden Raman lines vanish to rounding (~1e-31 of the allowed one)
    assert raman.activities[~sym].max() < 1e-20 * raman.activities[sym][0]
    assert "Raman" in raman.table()


def test_co2_symmetric_stretch_activity_closed_form():
    # Sym stretch shape: O at +-1/sqrt(2 m_O) along x, C still: each bond lengthens by
    # dr = 1/sqrt(2 m_O) per unit Q and does not turn, so d alpha/dQ = 2 dr diag(d_par, d_perp,
    # d_perp): a' = 2 dr (d_par + 2 d_perp)/3, g' = 2 dr |d_par - d_perp|.
    d_par, d_perp = 3.0, 0.4
    raman = spectra.raman_spectrum(co2_3d(), bonds=[[0, 1], [1, 2]], derivative_parallel=d_par,
                                   derivative_perpendicular=d_perp)
    dr = 1 / np.sqrt(2 * M_O)
    a, g = 2 * dr * (d_par + 2 * d_perp) / 3, 2 * dr * abs(d_par - d_perp)
    sym = by_wavenumber(raman, SYM)
    np.testing.assert_allclose(abs(raman.isotropic[sym]), a, rtol=1e-12)
    np.testing.assert_allclose(raman.anisotropy[sym], g, rtol=1e-12)
    np.testing.assert_allclose(raman.activities[sym], 45 * a**2 + 7 * g**2, rtol=1e-12)


def test_raman_matches_finite_differences_of_the_bond_model():
    # H2O, all four parameters per bond different, so stretch and rotation terms both count.
    system = h2o()
    modes = system.modes()
    a_par, a_perp = np.array([1.5, 1.5, 0.3]), np.array([0.6, 0.6, 0.1])
    d_par, d_perp = np.array([2.5, 2.5, 0.2]), np.array([0.3, 0.3, 0.05])
    raman = spectra.raman_spectrum(system, modes, bonds=H2O_SPRINGS, polarizability_parallel=a_par,
                                   polarizability_perpendicular=a_perp, derivative_parallel=d_par,
                                   derivative_perpendicular=d_perp)
    r0 = np.linalg.norm(H2O_POSITIONS[H2O_SPRINGS[:, 1]] - H2O_POSITIONS[H2O_SPRINGS[:, 0]], axis=1)
    step = 1e-4   # central differences: error ~ step^2 * alpha''' ~ 1e-8; rounding ~ 1e-12
    for row, k in enumerate(raman.mode_indices):
        shape = modes.shapes[:, k].reshape(3, 3)
        plus = bond_polarizability(H2O_POSITIONS + step * shape, H2O_SPRINGS, a_par, a_perp,
                                   d_par, d_perp, r0)
        minus = bond_polarizability(H2O_POSITIONS - step * shape, H2O_SPRINGS, a_par, a_perp,
                                    d_par, d_perp, r0)
        numeric = (plus - minus) / (2 * step)
        np.testing.assert_allclose(raman.polarizability_derivatives[row], numeric, atol=1e-6)
    assert raman.active().all()  # C2v H2O: every mode is Raman active too


def test_raman_activities_do_not_depend_on_orientation(rng):
    # 45 a'^2 + 7 g'^2 are rotational invariants: rotating the molecule (positions and hence
    # the spring Hessian) leaves them unchanged up to the eigen-solver's rounding (1e-9).
    rotation, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    turned = H2O_POSITIONS @ rotation.T + np.array([0.3, -1.0, 2.0])
    first = spectra.raman_spectrum(h2o(), bonds=H2O_SPRINGS)
    second = spectra.raman_spectrum(h2o(positions=turned), bonds=H2O_SPRINGS)
    np.testing.assert_allclose(second.activities, first.activities, rtol=1e-9)
    np.testing.assert_allclose(second.wavenumbers, first.wavenumbers, rtol=1e-10)


# ====================================================================== broadening
@pytest.mark.parametrize("shape", ["lorentzian", "gaussian"])
def test_broadened_lines_have_unit_area_and_closed_form_peaks(shape):
    positions, strengths, width = np.array([700.0, 1300.0, 2350.0]), np.array([2.0, 0.5, 1.0]), 12.0
    grid = np.linspace(0.0, 3000.0, 60001)   # h = 0.05 cm^-1 << width
    spectrum = spectra.broadened_spectrum(positions, strengths, grid, width, shape)
    area = np.trapezoid(spectrum.values, grid)
    if shape == "lorentzian":
        half = width / 2
        inside = (np.arctan((grid[-1] - positions) / half) - np.arctan((grid[0] - positions) / half)) / np.pi
        peak = 2 / (np.pi * width)
    else:
        inside = np.ones(3)      # Gaussian tails beyond 50 sigma: below 1e-300
        peak = np.sqrt(4 * np.log(2) / np.pi) / width
    # trapezoid error ~ h^2/12 * integral|g''| ~ (0.05/6)^2 -> 1e-6 relative; 1e-5 allowed
    assert area == pytest.approx(float(strengths @ inside), rel=1e-5)
    single = spectra.broadened_spectrum([1000.0], [3.0], [1000.0, 1000.0 + width / 2], width, shape)
    np.testing.assert_allclose(single.values, [3.0 * peak, 1.5 * peak], rtol=1e-12)  # FWHM


@pytest.mark.parametrize("shape", ["lorentzian", "gaussian"])
def test_broadening_matches_scipy_profiles_in_small_blocks(shape, rng, monkeypatch):
    # scipy.stats' Cauchy (scale = FWHM/2) and normal (sigma = FWHM / (2 sqrt(2 ln 2))) pdfs
    # are the reference; a tiny block size forces the chunked path with ragged last chunk.
    from scipy import stats

    monkeypatch.setattr(spectra.broadening, "_BLOCK", 7)
    positions, strengths = rng.uniform(500, 3500, 5), rng.uniform(0, 2, 5)
    grid = np.linspace(0, 4000, 103)
    width = 25.0
    offset = grid[:, None] - positions[None, :]
    if shape == "lorentzian":
        profile = stats.cauchy.pdf(offset, scale=width / 2)
    else:
        profile = stats.norm.pdf(offset, scale=width / (2 * np.sqrt(2 * np.log(2))))
    spectrum = spectra.broadened_spectrum(positions, strengths, grid, width, shape)
    # same closed forms evaluated in a different order: rounding only
    np.testing.assert_allclose(spectrum.values, profile @ strengths, rtol=1e-12, atol=1e-300)


def test_sticks_merge_degenerate_lines_and_broaden():
    ir = spectra.ir_spectrum(co2_3d(), charges=CO2_CHARGES)
    sticks = ir.sticks()
    # the two bend components merge; sym stretch kept with (numerically) zero intensity
    np.testing.assert_allclose(sticks.wavenumbers, [BEND, SYM, ASYM], rtol=1e-9)
    per_line = DELTA**2 * (2 / M_O + 4 / M_C) * spectra.KM_PER_MOL_PER_E2_AMU
    np.testing.assert_allclose(sticks.intensities[[0, 2]], [2 * per_line, per_line], rtol=1e-12)
    assert sticks.unit == "km/mol" and sticks.kind == "IR"
    raw = ir.sticks(unit="e^2/amu", merge_cm1=0.0)
    assert len(raw.wavenumbers) >= 3 and raw.unit == "e^2/amu"
    broad = sticks.broadened(np.linspace(500, 2600, 50), 20.0, "gaussian")
    assert broad.kind == "IR" and broad.unit == "km/mol" and broad.values.shape == (50,)


# ====================================================================== thermochemistry
TEMPERATURES = np.array([5.0, 50.0, 298.15, 1000.0, 5000.0])
# ASE evaluates ln(1 - e^-x) as log(1 - exp(-x)), which loses the digits of e^-x once it
# nears machine epsilon (x >~ 15: 50 K and below for CO2's bend); vibra uses log1p there.
# The ASE comparisons therefore run where x < 10; the cold end is checked against mpmath.
ASE_TEMPERATURES = np.array([100.0, 298.15, 1000.0, 5000.0])
K_VIBRA = constants.k / constants.e       # eV/K, CODATA 2018 (what vibra uses)


def ase_temperature(t: np.ndarray) -> np.ndarray:
    """ASE's kB is CODATA 2014 (3.4e-7 apart): compare at the same kT, not the same T."""
    return t * K_VIBRA / ase_units.kB


def test_thermochemistry_matches_ase_harmonic_thermo():
    modes = co2_3d().modes()
    thermo = spectra.thermochemistry(modes, ASE_TEMPERATURES)
    np.testing.assert_allclose(thermo.wavenumbers, [BEND, BEND, SYM, ASYM], rtol=1e-9)
    # the quanta are h c nu~ (scipy constants) and equal the core's hbar omega
    np.testing.assert_allclose(thermo.vibrational_energies,
                               thermo.wavenumbers * constants.h * constants.c / constants.centi / constants.e,
                               rtol=1e-14)
    reference = HarmonicThermo(vib_energies=thermo.vibrational_energies)
    for i, t in enumerate(ase_temperature(ASE_TEMPERATURES)):
        # same formulas on the same energies: agreement to rounding; 1e-10 relative
        assert thermo.internal_energy[i] == pytest.approx(reference.get_internal_energy(t, verbose=False), rel=1e-10)
        assert thermo.entropy[i] / K_VIBRA == pytest.approx(
            reference.get_entropy(t, verbose=False) / ase_units.kB, rel=1e-10, abs=1e-300)
        helmholtz = reference.get_helmholtz_energy(t, verbose=False)
        assert thermo.helmholtz_energy[i] == pytest.approx(helmholtz, rel=1e-10)
        # bottom-of-well convention: F = -kT ln q_BOT
        kt = ase_units.kB * t
        assert thermo.log_partition_function_bottom[i] == pytest.approx(-helmholtz / kt, rel=1e-10)
    assert thermo.zero_point_energy == pytest.approx(reference.get_ZPE_correction(), rel=1e-14)
    assert thermo.n_imaginary == 0


def test_thermochemistry_skips_the_same_modes_as_ase_ideal_gas():
    # IdealGasThermo keeps the 3N-5 highest of all 3N energies of linear CO2 (rigid-body
    # modes included): the vibrational part must match ours, which skips them by threshold.
    modes = co2_3d().modes()
    all_energies = np.abs(modes.energies_mev()) / 1000.0
    thermo = spectra.thermochemistry(modes, ASE_TEMPERATURES)
    reference = IdealGasThermo(all_energies, geometry="linear", natoms=3)
    assert len(reference.vib_energies) == len(thermo.wavenumbers) == 4
    assert thermo.zero_point_energy == pytest.approx(reference.get_ZPE_correction(), rel=1e-12)
    for i, t in enumerate(ase_temperature(ASE_TEMPERATURES)):
        # U - ZPE: our U includes the ZPE (0.32 eV), so the difference carries an absolute
        # rounding error of ~1e-16 eV * a few
        thermal = thermo.internal_energy[i] - thermo.zero_point_energy
        assert thermal == pytest.approx(reference.get_vib_energy_contribution(t), rel=1e-10, abs=1e-15)
        entropy = reference.get_vib_entropy_contribution(t) / ase_units.kB
        assert thermo.entropy[i] / K_VIBRA == pytest.approx(entropy, rel=1e-10, abs=1e-300)
        # ZPE-referenced convention: ln q_ZPE = S/k - (U - ZPE)/kT = -sum ln(1 - e^-x). Both
        # terms are ~ x e^-x and their difference e^-x: cancellation costs up to a factor
        # x ~ 10 here, and U - ZPE a factor ZPE / (U - ZPE) ~ 1e3 at 100 K: 1e-8 relative.
        log_q = entropy - reference.get_vib_energy_contribution(t) / (ase_units.kB * t)
        assert thermo.log_partition_function[i] == pytest.approx(log_q, rel=1e-8, abs=1e-300)
        assert thermo.partition_function[i] == pytest.approx(np.exp(log_q), rel=1e-8)


def test_heat_capacity_is_the_temperature_derivative_of_u():
    # sympy differentiates U(T) = sum E/(exp(E/kT) - 1) symbolically; evaluated in mpmath
    # at 30 digits, it is exact for our purpose. Tolerance 1e-11 relative (float64 rounding
    # of x^2 e^-x / (1 - e^-x)^2 and of the sum).
    wavenumbers = np.array([150.0, 667.0, 667.0, 1333.0, 2349.0])
    thermo = spectra.thermochemistry(wavenumbers, TEMPERATURES)
    t, k = sympy.symbols("T k", positive=True)
    energies = [sympy.Float(e, 30) for e in thermo.vibrational_energies]
    internal = sum(e / (sympy.exp(e / (k * t)) - 1) for e in energies)
    heat_capacity = sympy.diff(internal, t)
    for i, temperature in enumerate(TEMPERATURES):
        value = heat_capacity.subs({t: sympy.Float(temperature, 30), k: sympy.Float(K_VIBRA, 30)})
        assert thermo.heat_capacity[i] == pytest.approx(float(value.evalf(30)), rel=1e-11, abs=1e-300)
    # limits: C_v -> n k as T -> infinity (x -> 0: C_v/k = n - sum x^2/12 + O(x^4))
    hot = spectra.thermochemistry(wavenumbers, [1e7])
    x = thermo.vibrational_energies / (K_VIBRA * 1e7)
    assert hot.heat_capacity[0] / K_VIBRA == pytest.approx(5 - np.sum(x**2) / 12, rel=1e-12)
    # 5 K: every mode frozen out; the 150 cm^-1 one gives x^2 e^-x ~ 4e-16 of k
    assert thermo.heat_capacity[0] < 1e-15 * 5 * K_VIBRA


def test_cold_entropy_and_partition_function_keep_their_digits():
    # (abs=0 throughout: pytest.approx's default abs=1e-12 would hide these tiny values)
    # mpmath at 40 digits gives S/k = sum x/(e^x - 1) - ln(1 - e^-x) and ln q_ZPE exactly;
    # at 5 and 20 K (x up to ~700) float64 with expm1/log1p keeps ~1e-13 relative.
    import mpmath

    mpmath.mp.dps = 40
    wavenumbers = np.array([150.0, 667.0, 1333.0, 2349.0])
    cold = np.array([5.0, 20.0])
    thermo = spectra.thermochemistry(wavenumbers, cold)
    for i, t in enumerate(cold):
        xs = [mpmath.mpf(float(e)) / (mpmath.mpf(K_VIBRA) * mpmath.mpf(float(t)))
              for e in thermo.vibrational_energies]
        entropy = sum(x / mpmath.expm1(x) - mpmath.log(-mpmath.expm1(-x)) for x in xs)
        log_q = -sum(mpmath.log(-mpmath.expm1(-x)) for x in xs)
        assert thermo.entropy[i] / K_VIBRA == pytest.approx(float(entropy), rel=1e-12, abs=0)
        assert thermo.log_partition_function[i] == pytest.approx(float(log_q), rel=1e-12, abs=0)
        kt = K_VIBRA * t
        assert thermo.log_partition_function_bottom[i] == pytest.approx(
            float(log_q) - thermo.zero_point_energy / kt, rel=1e-14, abs=0)


def test_thermochemistry_leaves_out_zero_and_imaginary_modes():
    with pytest.warns(RuntimeWarning, match="1 imaginary mode"):
        thermo = spectra.thermochemistry([0.0, 1e-6, -150.0, 500.0, 1000.0], [300.0])
    assert thermo.n_imaginary == 1
    np.testing.assert_allclose(thermo.wavenumbers, [500.0, 1000.0])
    plain = spectra.thermochemistry([1000.0, 500.0], 300.0)
    np.testing.assert_allclose(plain.entropy, thermo.entropy, rtol=1e-15)
    text = thermo.table()
    assert "1 imaginary mode(s) left out" in text and "300.00" in text


def test_thermochemistry_from_modes_warns_on_unstable_modes():
    # A spring system with a negative-stiffness extra Hessian: one imaginary mode.
    hessian = np.diag([4.0, -1.0, 9.0])
    with pytest.warns(RuntimeWarning):
        modes = vibra.normal_modes(hessian, [1.0, 1.0, 1.0], units="ASE")
    with pytest.warns(RuntimeWarning, match="thermochemistry: 1 imaginary"):
        thermo = spectra.thermochemistry(modes, [300.0])
    assert thermo.n_imaginary == 1 and len(thermo.wavenumbers) == 2


def test_thermochemistry_per_mole_units():
    thermo = spectra.thermochemistry([1000.0], [300.0, 600.0])
    np.testing.assert_allclose(thermo.heat_capacity_j_per_mol_k(), thermo.heat_capacity / K_VIBRA * constants.R,
                               rtol=1e-14)
    np.testing.assert_allclose(thermo.entropy_j_per_mol_k(), thermo.entropy / K_VIBRA * constants.R, rtol=1e-14)


# ====================================================================== isotopes
def test_isotope_masses_table_agrees_with_ase_for_common_isotopes():
    # ASE's atomic_masses_common are the most abundant isotopes' masses (same AME data)
    for label, symbol in [("1H", "H"), ("12C", "C"), ("14N", "N"), ("16O", "O"), ("32S", "S"),
                          ("35Cl", "Cl")]:
        assert spectra.ISOTOPE_MASSES[label] == pytest.approx(
            atomic_masses_common[atomic_numbers[symbol]], abs=1e-8)
    for label, number in [("D", 2), ("13C", 13), ("15N", 15), ("17O", 17), ("18O", 18), ("34S", 34),
                          ("37Cl", 37)]:
        # mass number + mass excess, |excess| < 0.05 amu for these light nuclides (34S: -0.032)
        assert abs(spectra.ISOTOPE_MASSES[label] - number) < 0.05


@pytest.mark.parametrize("substitution, m_o, m_c", [
    ({1: "13C"}, M_O, spectra.ISOTOPE_MASSES["13C"]),
    ({0: "18O", 2: "18O"}, spectra.ISOTOPE_MASSES["18O"], M_C),
    ({0: 17.0, 1: 14.0, 2: 17.0}, 17.0, 14.0),
])
def test_axial_co2_isotope_shifts_follow_eq_157(substitution, m_o, m_c):
    shifts = spectra.isotope_shifts(co2_axial(), substitution)
    np.testing.assert_allclose(shifts.wavenumbers, [SYM, ASYM], rtol=1e-9)
    expected = [omega_to_cm1(K_STRETCH / m_o), omega_to_cm1(K_STRETCH * (1 / m_o + 2 / m_c))]
    np.testing.assert_allclose(shifts.shifted_wavenumbers, expected, rtol=1e-9)
    np.testing.assert_allclose(shifts.shifts, np.array(expected) - [SYM, ASYM], rtol=1e-6, atol=1e-9)
    assert list(shifts.sites) == sorted(substitution)
    text = shifts.table()
    assert "isotope shifts" in text and f"{expected[1]:.2f}" in text


def test_isotope_shifts_obey_teller_redlich_product_rule():
    # Teller-Redlich for a non-linear molecule (all modes):
    # prod (w'/w) = prod_i (m_i/m'_i)^(3/2) * (M'/M)^(3/2) * prod_a (I'_a/I_a)^(1/2),
    # with principal moments from ASE. Exact for a rotation-invariant harmonic K; 1e-9
    # relative covers the eigen-solver rounding.
    masses, new = np.array([M_O, M_H, M_H]), np.array([M_O, spectra.ISOTOPE_MASSES["D"], M_H])
    shifts = spectra.isotope_shifts(h2o(), {1: "D"})
    moments = Atoms("OH2", positions=H2O_POSITIONS, masses=masses).get_moments_of_inertia()
    moments_new = Atoms("OH2", positions=H2O_POSITIONS, masses=new).get_moments_of_inertia()
    rule = (np.prod(masses / new) ** 1.5 * (new.sum() / masses.sum()) ** 1.5
            * np.prod(moments_new / moments) ** 0.5)
    assert np.prod(shifts.ratios) == pytest.approx(rule, rel=1e-9)
    assert (shifts.shifts < 0).all()   # a heavier atom lowers every frequency (or keeps it)


def test_isotope_13c_leaves_co2_symmetric_stretch_unchanged_in_3d():
    # Linear molecule: rule with exponent 1 on the (unchanged) moment of inertia; the C atom
    # does not move in the symmetric stretch, so that line does not shift.
    shifts = spectra.isotope_shifts(co2_3d(), {1: "13C"})
    sym = by_wavenumber(shifts, SYM)
    np.testing.assert_allclose(shifts.shifted_wavenumbers[sym], SYM, rtol=1e-9)
    m_new = spectra.ISOTOPE_MASSES["13C"]
    rule = (M_C / m_new) ** 1.5 * ((2 * M_O + m_new) / (2 * M_O + M_C)) ** 1.5
    assert np.prod(shifts.ratios) == pytest.approx(rule, rel=1e-9)


def test_isotope_table_is_the_molecules_table_and_read_only():
    assert spectra.ISOTOPE_MASSES is mol.ISOTOPE_MASSES
    assert spectra.ISOTOPE_MASSES["D"] == mol.isotope_mass("2H")
    with pytest.raises(TypeError):
        spectra.ISOTOPE_MASSES["13C"] = 13.0  # type: ignore[index]


def test_isotope_shift_mode_count_mismatch_raises():
    # Axial CO2: SYM / ASYM = 0.522 before, 0.537 after 13C (ASYM drops, SYM does not move).
    # zero_rtol = 0.53 counts SYM as a zero mode before and as a vibration after.
    ratio_before = SYM / ASYM
    ratio_after = SYM / omega_to_cm1(K_STRETCH * (1 / M_O + 2 / spectra.ISOTOPE_MASSES["13C"]))
    assert ratio_before < 0.53 < ratio_after
    with pytest.raises(RuntimeError, match="the substituted system has 2 vibrational modes, the original 1"):
        spectra.isotope_shifts(co2_axial(), {1: "13C"}, zero_rtol=0.53)


# ====================================================================== validation
def test_ir_validation_messages():
    system = co2_3d()
    with pytest.raises(TypeError, match="system must be a vibra.System"):
        spectra.ir_spectrum("co2", charges=CO2_CHARGES)
    with pytest.raises(TypeError, match="generalised coordinates"):
        spectra.ir_spectrum(vibra.System.generalized(np.eye(2), np.eye(2), units="ASE"), charges=[0, 0])
    with pytest.raises(ValueError, match="system.units is 'SI'"):
        spectra.ir_spectrum(vibra.System.from_springs([0.0, 1.0], 1.0, [[0, 1]], 1.0), charges=[1, -1])
    with pytest.raises(TypeError, match="modes must be a vibra.Modes or a molecules.VibrationalAnalysis, got ndarray"):
        spectra.ir_spectrum(system, np.zeros(3), charges=CO2_CHARGES)
    with pytest.raises(ValueError, match="modes has 3 degrees of freedom but the system has 9"):
        spectra.ir_spectrum(system, mol.vibrational_analysis(co2_axial()), charges=CO2_CHARGES)
    with pytest.raises(ValueError, match="modes has no shapes"):
        spectra.ir_spectrum(system, system.modes(vectors=False), charges=CO2_CHARGES)
    with pytest.raises(ValueError, match="modes has 3 degrees of freedom but the system has 9"):
        spectra.ir_spectrum(system, co2_axial().modes(), charges=CO2_CHARGES)
    with pytest.raises(ValueError, match="exactly one of charges and dipole_derivatives"):
        spectra.ir_spectrum(system)
    with pytest.raises(ValueError, match="exactly one of charges and dipole_derivatives"):
        spectra.ir_spectrum(system, charges=CO2_CHARGES, dipole_derivatives=np.zeros((9, 3)))
    with pytest.raises(ValueError, match=r"charges must have 3 entries \(one per site\), got 2"):
        spectra.ir_spectrum(system, charges=[1.0, -1.0])
    with pytest.raises(ValueError, match=r"charges\[1\] is (np\.float64\()?nan"):
        spectra.ir_spectrum(system, charges=[1.0, np.nan, -1.0])
    with pytest.raises(ValueError, match=r"dipole_derivatives must have shape \(9, 3\) or \(3, 3, 3\), got \(6, 3\)"):
        spectra.ir_spectrum(system, dipole_derivatives=np.zeros((6, 3)))
    with pytest.raises(ValueError, match="zero_rtol is -1.0; it must be >= 0"):
        spectra.ir_spectrum(system, charges=CO2_CHARGES, zero_rtol=-1.0)
    with pytest.raises(TypeError, match="zero_rtol must be a real number, got str"):
        spectra.ir_spectrum(system, charges=CO2_CHARGES, zero_rtol="big")
    ir = spectra.ir_spectrum(system, charges=CO2_CHARGES)
    with pytest.raises(ValueError, match="unit is 'D'; expected one of 'km/mol', 'e\\^2/amu'"):
        ir.sticks(unit="D")
    with pytest.raises(ValueError, match="rtol is -0.5"):
        ir.active(-0.5)
    with pytest.raises(ValueError, match="merge_cm1 is nan"):
        ir.sticks(merge_cm1=float("nan"))


def test_ir_warns_about_imaginary_modes():
    system = vibra.System.from_hessian([[0.0, 0, 0], [1.0, 0, 0]], [1.0, 1.0],
                                       np.diag([4.0, -1.0, 1.0, 4.0, 2.0, 3.0]), units="ASE")
    with pytest.warns(RuntimeWarning):
        modes = system.modes()
    with pytest.warns(RuntimeWarning, match="ir_spectrum: 1 imaginary mode"):
        ir = spectra.ir_spectrum(system, modes, charges=[0.5, -0.5])
    assert len(ir.wavenumbers) == 5 and (ir.wavenumbers > 0).all()


def test_dipole_derivatives_validation():
    with pytest.raises(TypeError, match="atoms must be an ase.Atoms, got list"):
        spectra.dipole_derivatives([1, 2])
    with pytest.raises(TypeError, match="atoms has no calculator"):
        spectra.dipole_derivatives(Atoms("H2", positions=[[0, 0, 0], [0.7, 0, 0]]))
    with pytest.raises(ValueError, match="step is 0.0; it must be positive and finite"):
        spectra.dipole_derivatives(h2o_atoms(), step=0.0)


def test_electronegativity_validation():
    with pytest.raises(ValueError, match=r"symbols\[1\] is 'Xx'; known elements"):
        spectra.electronegativity_charges(["O", "Xx"], [[0, 1]])
    with pytest.raises(ValueError, match=r"bonds\[0,1\] is 5; site indices run from 0 to 1"):
        spectra.electronegativity_charges(["O", "H"], [[0, 5]])
    with pytest.raises(ValueError, match="transfer is -1"):
        spectra.electronegativity_charges(["O", "H"], [[0, 1]], transfer=-1)


def test_raman_validation_messages():
    system = co2_3d()
    with pytest.raises(ValueError, match="bonds is empty"):
        spectra.raman_spectrum(system, bonds=np.zeros((0, 2), dtype=int))
    with pytest.raises(TypeError, match="bonds must hold integer site indices, got dtype float64"):
        spectra.raman_spectrum(system, bonds=[[0.0, 1.0]])
    with pytest.raises(ValueError, match=r"bonds must have shape \(n_bonds, 2\), got \(3,\)"):
        spectra.raman_spectrum(system, bonds=[0, 1, 2])
    with pytest.raises(ValueError, match=r"bonds\[1\] joins site 2 to itself"):
        spectra.raman_spectrum(system, bonds=[[0, 1], [2, 2]])
    with pytest.raises(ValueError, match=r"derivative_parallel must have 2 entries \(one per bond\), got 3"):
        spectra.raman_spectrum(system, bonds=[[0, 1], [1, 2]], derivative_parallel=[1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match=r"polarizability_perpendicular\[0\] is (np\.float64\()?inf"):
        spectra.raman_spectrum(system, bonds=[[0, 1], [1, 2]], polarizability_perpendicular=[np.inf, 1.0])
    clash = vibra.System.from_springs([[0.0, 0, 0], [1.0, 0, 0], [0.0, 0, 0]], 1.0, [[0, 1]], 1.0,
                                      units="ASE")
    with pytest.raises(ValueError, match=r"bonds\[0\] joins sites 0 and 2 at the same position"):
        spectra.raman_spectrum(clash, bonds=[[0, 2]])


def test_broadening_validation_messages():
    with pytest.raises(ValueError, match=r"intensities must have 2 entries \(one per wavenumber\), got 1"):
        spectra.broadened_spectrum([1.0, 2.0], [1.0], [1.0], 1.0)
    with pytest.raises(ValueError, match=r"intensities\[1\] is (np\.float64\()?-1\.0\)?; every intensity must be >= 0"):
        spectra.broadened_spectrum([1.0, 2.0], [1.0, -1.0], [1.0], 1.0)
    with pytest.raises(ValueError, match="grid must be 1-D"):
        spectra.broadened_spectrum([1.0], [1.0], [[1.0]], 1.0)
    with pytest.raises(ValueError, match="grid must hold at least one wavenumber"):
        spectra.broadened_spectrum([1.0], [1.0], [], 1.0)
    with pytest.raises(ValueError, match="width is -2.0; it must be positive"):
        spectra.broadened_spectrum([1.0], [1.0], [1.0], -2.0)
    with pytest.raises(ValueError, match="shape is 'voigt'; expected one of 'lorentzian', 'gaussian'"):
        spectra.broadened_spectrum([1.0], [1.0], [1.0], 2.0, "voigt")
    with pytest.raises(ValueError, match=r"wavenumbers\[0\] is (np\.float64\()?nan"):
        spectra.broadened_spectrum([np.nan], [1.0], [1.0], 2.0)


def test_thermochemistry_validation_messages():
    with pytest.raises(ValueError, match=r"temperatures\[1\] is (np\.float64\()?0\.0\)?; every temperature must be positive"):
        spectra.thermochemistry([1000.0], [300.0, 0.0])
    with pytest.raises(ValueError, match="modes must be 1-D"):
        spectra.thermochemistry([[1000.0]], [300.0])
    with pytest.raises(TypeError, match="modes must be an array of real numbers"):
        spectra.thermochemistry(["a", object()], [300.0])
    dimensionless = vibra.normal_modes(np.diag([1.0, 4.0]), [1.0, 1.0])
    with pytest.raises(ValueError, match="modes are dimensionless"):
        spectra.thermochemistry(dimensionless, [300.0])


def test_isotope_validation_messages():
    system = co2_axial()
    with pytest.raises(TypeError, match="system must be a vibra.System"):
        spectra.isotope_shifts(None, {0: "18O"})
    with pytest.raises(TypeError, match="system must be a system of sites; this one is in generalised"):
        spectra.isotope_shifts(vibra.System.generalized(np.eye(2), np.eye(2), units="ASE"), {0: 2.0})
    with pytest.raises(TypeError, match="substitutions must be a mapping"):
        spectra.isotope_shifts(system, [(0, "18O")])
    with pytest.raises(ValueError, match="substitutions is empty"):
        spectra.isotope_shifts(system, {})
    with pytest.raises(ValueError, match=r"substitutions\[3\]: site index out of range 0\.\.2"):  # worded as substitute_isotopes
        spectra.isotope_shifts(system, {3: "18O"})
    with pytest.raises(TypeError, match="substitutions key '0' must be an int"):
        spectra.isotope_shifts(system, {"0": "18O"})
    with pytest.raises(ValueError, match=r"substitutions\[0\] is '19O'; known isotopes"):
        spectra.isotope_shifts(system, {0: "19O"})
    with pytest.raises(ValueError, match=r"substitutions\[0\] is -1.0; a mass must be positive"):
        spectra.isotope_shifts(system, {0: -1.0})
    with pytest.raises(TypeError, match=r"substitutions\[0\] must be a mass or an isotope name, got list"):
        spectra.isotope_shifts(system, {0: [18.0]})
    si = vibra.System.from_springs([0.0, 1.0], [1.0, 1.0], [[0, 1]], 1.0, units="SI")
    with pytest.raises(ValueError, match=r"substitutions\[0\] is the isotope name '18O', which needs masses in amu"):
        spectra.isotope_shifts(si, {0: "18O"})
    dimensionless = vibra.System.from_springs([0.0, 1.0], [1.0, 1.0], [[0, 1]], 1.0, units="dimensionless")
    with pytest.raises(ValueError, match="system is dimensionless"):
        spectra.isotope_shifts(dimensionless, {0: 2.0})
    with pytest.raises(ValueError, match="accuracy is 'best'"):
        spectra.isotope_shifts(system, {0: 2.0}, accuracy="best")


# ====================================================================== immutability
def _results():
    system = co2_3d()
    modes = system.modes()
    ir = spectra.ir_spectrum(system, modes, charges=CO2_CHARGES)
    return [
        (ir, "intensities"),
        (spectra.raman_spectrum(system, modes, bonds=[[0, 1], [1, 2]]), "activities"),
        (ir.sticks(), "wavenumbers"),
        (spectra.broadened_spectrum([1.0], [1.0], [1.0, 2.0], 1.0), "values"),
        (spectra.thermochemistry(modes, [300.0]), "entropy"),
        (spectra.isotope_shifts(co2_axial(), {1: "13C"}), "shifted_wavenumbers"),
    ]


def test_results_are_immutable():
    for result, array_name in _results():
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(result, array_name, None)
        array = getattr(result, array_name)
        with pytest.raises(ValueError, match="read-only"):
            array[0] = 1.0


# ====================================================================== charts


def test_charts_draw_labelled_pngs(tmp_path):
    system = co2_3d()
    modes = system.modes()
    sticks = spectra.ir_spectrum(system, modes, charges=CO2_CHARGES).sticks()
    figure = plot_stick_spectrum(sticks)
    axis = figure.axes[0]
    assert axis.xaxis_inverted()                           # IR: decreasing to the right
    assert "cm$^{-1}$" in axis.get_xlabel() and "decreasing" in axis.get_xlabel()
    assert "km/mol" in axis.get_ylabel()
    path = save_figure(figure, tmp_path / "sticks.png")
    check_png(path, (600, 960))                            # 8 x 5 in at 120 dpi

    broad = sticks.broadened(np.linspace(400, 2800, 400), 30.0)
    figure = plot_broadened_spectrum(broad, sticks=sticks)
    assert figure.axes[0].xaxis_inverted() and "per cm" in figure.axes[0].get_ylabel()
    check_png(save_figure(figure, tmp_path / "broad.png"), (600, 960))

    raman = spectra.raman_spectrum(system, modes, bonds=[[0, 1], [1, 2]]).sticks()
    figure = plot_stick_spectrum(raman)
    assert not figure.axes[0].xaxis_inverted() and "Raman shift" in figure.axes[0].get_xlabel()
    assert "Raman activity" in figure.axes[0].get_ylabel()
    check_png(save_figure(figure, tmp_path / "raman.png"), (600, 960))

    thermo = spectra.thermochemistry(modes, np.linspace(10.0, 2000.0, 50))
    figure = plot_thermo(thermo)
    assert "J mol" in figure.axes[0].get_ylabel() and "(K)" in figure.axes[1].get_xlabel()
    check_png(save_figure(figure, tmp_path / "thermo.png"), (540, 1200))


def test_chart_argument_types():
    with pytest.raises(TypeError, match="sticks must be a StickSpectrum, got list"):
        plot_stick_spectrum([1, 2])
    with pytest.raises(TypeError, match="spectrum must be a BroadenedSpectrum"):
        plot_broadened_spectrum(None)
    spectrum = spectra.broadened_spectrum([1.0], [1.0], [0.0, 1.0, 2.0], 1.0)
    with pytest.raises(TypeError, match="sticks must be a StickSpectrum or None"):
        plot_broadened_spectrum(spectrum, sticks=3)
    with pytest.raises(TypeError, match="thermo must be a Thermochemistry"):
        plot_thermo(spectrum)


# ====================================================================== docs
def test_docs_spectra_example_runs_as_written(tmp_path, monkeypatch):
    # docs/spectra.md must work exactly as written: run its code block in a scratch folder
    text = (Path(__file__).resolve().parents[2] / "docs" / "spectra.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert blocks
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    namespace: dict = {}
    for block in blocks:
        exec(compile(block, "docs/spectra.md", "exec"), namespace)
    # what the text promises: CO2 selection rules and the merged bend
    assert namespace["ir"].active().tolist() == [True, True, False, True]
    assert namespace["raman"].active().tolist() == [False, False, True, False]
    assert len(namespace["sticks"].wavenumbers) == 3
    for name, size in [("co2_ir.png", (960, 600)), ("co2_raman.png", (960, 600)), ("co2_thermo.png", (1200, 540))]:
        check_png(tmp_path / name, size[::-1])  # sizes above: (width, height)


@pytest.mark.parametrize("spectrum, kwargs, match", [
    ("ir", {"charges": [1e308, -1e308, 0.0]}, r"the intensity of the line at .* cm\^-1 is inf: charges too large"),
    ("raman", {"bonds": [[0, 1], [1, 2]], "derivative_parallel": 1e300},
     r"the activity of the line at .* cm\^-1 is inf: the bond polarisabilities or the geometry too large"),
])
def test_an_overflowing_spectrum_is_refused_where_it_appears(spectrum: str, kwargs: dict, match: str) -> None:
    """No silent inf in a spectrum (issue 44): the line and the inputs are named."""
    from vibra import molecules
    from vibra.spectra import ir_spectrum, raman_spectrum

    co2 = molecules.co2()
    with pytest.raises(ValueError, match=match):
        (ir_spectrum if spectrum == "ir" else raman_spectrum)(co2, co2.modes(), **kwargs)
