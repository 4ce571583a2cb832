"""Spectra from electronic structure with PySCF (issue 46, items 1 and 2): `vibra.molecules.engines`
and `vibra.spectra.electronic`, at RHF/STO-3G on water and CO2 (small and fast).

Skipped without PySCF (the optional extra ``vibra[pyscf]``). Truth comes from outside the code
under test: PySCF's own analytic Hessian and its `pyscf.hessian.thermo.harmonic_analysis`; ASE's
`Infrared` on the same engine; PySCF's TDHF excitations (the sum over states of the full
random-phase approximation equals the static CPHF polarisability exactly); the character tables
(`vibra.molecules.character_tables`, checked against the published tables elsewhere); the
translation sum rules; closed forms (the depolarisation ratio 3/4 of a non-totally-symmetric
line; the cross section in SI units).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

pyscf = pytest.importorskip("pyscf")

from ase import Atoms  # noqa: E402
from ase import units as ase_units  # noqa: E402
from ase.optimize import BFGS  # noqa: E402
from ase.vibrations import Infrared  # noqa: E402
from scipy import constants  # noqa: E402

from vibra import molecules as mol  # noqa: E402
from vibra import spectra  # noqa: E402
from vibra.molecules.engines import (EngineCalculator, ElectronicStructure, PySCFEngine,  # noqa: E402
                                     electronic_structure)

ROOT = Path(__file__).resolve().parents[2]
LEVEL = "RHF/STO-3G"


def relaxed(atoms: Atoms, engine: PySCFEngine) -> Atoms:
    """`atoms` at the engine's equilibrium (ASE's BFGS to 1e-4 eV/Angstrom)."""
    work = atoms.copy()
    work.calc = EngineCalculator(engine)
    BFGS(work, logfile=None).run(fmax=1e-4)
    out = work.copy()
    out.calc = None
    return out


class Molecule:
    """One molecule's relaxed geometry, electronic structure and vibrational analysis (built once)."""

    def __init__(self, atoms: Atoms, cache: Path) -> None:
        self.engine = PySCFEngine("hf", "sto-3g")
        self.atoms = relaxed(atoms, self.engine)
        self.cache = cache
        self.electronic = electronic_structure(self.atoms, self.engine, cache=cache, symmetry=False)
        self.analysis = mol.vibrational_analysis(self.electronic.system())
        self.ir = spectra.electronic_ir_spectrum(self.electronic, self.analysis)
        self.raman = spectra.electronic_raman_spectrum(self.electronic, self.analysis)


@pytest.fixture(scope="module")
def water(tmp_path_factory: pytest.TempPathFactory) -> Molecule:
    atoms = Atoms("OHH", positions=[(0.0, 0.0, 0.1173), (0.0, 0.7572, -0.4692), (0.0, -0.7572, -0.4692)])
    return Molecule(atoms, tmp_path_factory.mktemp("water-cache"))


@pytest.fixture(scope="module")
def co2(tmp_path_factory: pytest.TempPathFactory) -> Molecule:
    atoms = Atoms("OCO", positions=[(0.0, 0.0, -1.16), (0.0, 0.0, 0.0), (0.0, 0.0, 1.16)])
    return Molecule(atoms, tmp_path_factory.mktemp("co2-cache"))


@pytest.fixture(params=["water", "co2"])
def molecule(request: pytest.FixtureRequest) -> Molecule:
    return request.getfixturevalue(request.param)


# ====================================================================== Hessians and frequencies
def test_analytic_hessian_agrees_with_finite_differences_within_their_error_estimate(molecule: Molecule) -> None:
    # PySCF's analytic Hessian against vibra's central differences of PySCF's analytic forces
    # (h = 0.01 Angstrom, 2-point): every entry within vibra's stated error (Richardson
    # truncation + SCF noise / h). Measured: largest |analytic - fd| / error 0.975 (water) and
    # 0.996 (CO2): the entries dominated by truncation, where Richardson's estimate is the
    # error's leading term itself, so the ratio approaches 1 from below.
    es = molecule.electronic
    assert es.hessian_method == "analytic" and es.level == LEVEL
    assert es.hessian_disagreement() <= 1.0
    fd = es.finite_difference
    assert fd.error_method == "richardson" and fd.noise_source == "given" and fd.n_force_calls == 37
    # the frequencies of the two Hessians within the fd Hessian's own first-order bound
    analytic = molecule.analysis
    numeric = mol.vibrational_analysis(fd.system())
    bound = fd.omega_errors(numeric.modes)[numeric.vibrations]
    gap = np.abs(numeric.modes.omega[numeric.vibrations] - analytic.modes.omega[analytic.vibrations])
    assert np.all(gap <= bound)


def test_frequencies_equal_pyscf_harmonic_analysis(molecule: Molecule) -> None:
    # PySCF's own normal-mode analysis of its analytic Hessian (its mass weighting, projection
    # and unit constants) with vibra's masses: the same frequencies. Measured: 4.4e-6 cm^-1 at
    # most (the two libraries' CODATA constants); 1e-3 cm^-1 allowed.
    from pyscf.hessian import thermo

    atoms = molecule.atoms
    mf = molecule.engine.scf(atoms.get_atomic_numbers(), atoms.get_positions())
    result = thermo.harmonic_analysis(mf.mol, mf.Hessian().kernel(), mass=atoms.get_masses())
    theirs = np.sort(np.asarray(result["freq_wavenumber"]).real)
    ours = molecule.analysis.vibration_wavenumbers_cm1()
    linear = molecule.analysis.point_group.is_linear
    assert len(ours) == len(theirs) == 3 * len(atoms) - (5 if linear else 6)
    np.testing.assert_allclose(ours, theirs, atol=1e-3)


def test_published_rhf_sto3g_water(water: Molecule) -> None:
    # Y. Yamaguchi, M. Frisch, J. Gaw, H. F. Schaefer and J. S. Binkley, J. Chem. Phys. 84,
    # 2262 (1986), table 6, first column, as GAMESS(US)'s sample input exam10 reproduces it
    # with analytic derivatives at the RHF/STO-3G equilibrium: frequencies 2170.04, 4140.00,
    # 4391.07 cm^-1; IR intensities 0.17128, 1.04807, 0.70926 D^2/(amu Angstrom^2); mean
    # polarisability 0.40079 Angstrom^3. Ours (geometry relaxed here to 1e-4 eV/Angstrom, the
    # dipole derivatives by finite differences): 2169.85, 4139.64, 4390.67 (0.4 cm^-1 below,
    # the geometry's last digits); intensities within 4.2e-4 relative; alpha within 1e-5.
    # Allowed: 1 cm^-1, 2e-3 and 1e-4.
    np.testing.assert_allclose(water.analysis.vibration_wavenumbers_cm1(), [2170.04, 4140.00, 4391.07], atol=1.0)
    np.testing.assert_allclose(water.ir.intensities / ase_units.Debye**2, [0.17128, 1.04807, 0.70926], rtol=2e-3)
    derivatives = water.electronic.finite_difference.derivatives
    assert derivatives is not None and derivatives.reference_polarizability is not None
    assert np.trace(derivatives.reference_polarizability) / 3.0 == pytest.approx(0.40079, rel=1e-4)


# ====================================================================== selection rules
def test_intensities_vanish_exactly_where_the_character_table_says_inactive(molecule: Molecule) -> None:
    # The species of each vibration from vibra's point group; IR activity from the character
    # table (x, y, z), Raman from its quadratic forms. An inactive line must lie within its own
    # error bound (from the derivatives' finite-difference estimate) and below 1e-9 of the
    # strongest line; an active one far above its bound (measured: 1e-23 of the strongest line
    # for the forbidden ones, whose central differences cancel by symmetry; the allowed ones
    # exceed their bounds 1500 times or more).
    analysis, ir, raman = molecule.analysis, molecule.ir, molecule.raman
    table = analysis.point_group.table
    species = analysis.species
    for spectrum, values, errors, active in (
            (ir, ir.intensities, ir.intensity_errors, [table.is_ir_active(s) for s in species]),
            (raman, raman.activities, raman.activity_errors, [table.is_raman_active(s) for s in species])):
        assert errors is not None and spectrum.level == LEVEL
        np.testing.assert_array_equal(spectrum.mode_indices, analysis.vibrations)
        strongest = values.max()
        for value, error, allowed in zip(values, errors, active):
            if allowed:
                assert value > 100.0 * error and value > 1e-3 * strongest
            else:
                assert value <= error and value <= 1e-9 * strongest
        assert spectrum.active().tolist() == active


def test_co2_mutual_exclusion(co2: Molecule) -> None:
    # centrosymmetric: the symmetric stretch (Sigma_g+) is Raman only, the bend (Pi_u) and the
    # antisymmetric stretch (Sigma_u+) IR only
    assert co2.analysis.point_group.name == "Dinfh"
    assert co2.analysis.species == ("Pi_u", "Pi_u", "Sigma_g+", "Sigma_u+")
    assert co2.ir.active().tolist() == [True, True, False, True]
    assert co2.raman.active().tolist() == [False, False, True, False]
    assert (co2.ir.active() != co2.raman.active()).all()


def test_derivatives_obey_the_translation_sum_rules(molecule: Molecule) -> None:
    # moving the whole neutral molecule changes neither its dipole nor its polarisability:
    # sum_i dmu/dx_i = q = 0 and sum_i dalpha/dx_i = 0, within the summed error estimates
    derivatives = molecule.electronic.finite_difference.derivatives
    assert derivatives is not None and derivatives.error_method == "richardson"
    n = len(molecule.atoms)
    for values, errors in ((derivatives.dipole, derivatives.dipole_error),
                           (derivatives.polarizability, derivatives.polarizability_error)):
        assert values is not None and errors is not None
        total = np.abs(values.reshape(n, 3, -1).sum(axis=0))
        assert np.all(total <= errors.reshape(n, 3, -1).sum(axis=0))


# ====================================================================== IR against ASE
def test_ir_intensities_match_ase_infrared(water: Molecule, tmp_path: Path) -> None:
    # ASE's Infrared drives the same engine (through EngineCalculator) over the same +-0.01
    # Angstrom displacements, with its own Hessian, modes and unit factor (Porezag's 42.255
    # km/mol per (D/A)^2/amu, 2.4e-5 below CODATA). With vibra's finite-difference Hessian
    # (the same forces; read back from the cache) the two differ by that factor and by ASE's
    # unprojected rotations: measured 5.3e-5 relative, 2e-5 cm^-1; allowed 2e-4 and 1e-3
    # cm^-1. With the analytic Hessian the modes move by the fd error: measured 2.3e-4
    # relative, 0.7 cm^-1; allowed 1e-3 and 1 cm^-1.
    atoms = water.atoms.copy()
    atoms.calc = EngineCalculator(water.engine, ("dipole",))
    infrared = Infrared(atoms, name=str(tmp_path / "ir"), delta=0.01, nfree=2)
    infrared.run()
    ase_cm1 = infrared.get_frequencies().real[-3:]
    ase_km_per_mol = infrared.intensities[-3:] * 42.255
    numeric = electronic_structure(water.atoms, water.engine, cache=water.cache, hessian="finite difference")
    same_hessian = spectra.electronic_ir_spectrum(numeric)
    np.testing.assert_allclose(same_hessian.wavenumbers, ase_cm1, atol=1e-3)
    np.testing.assert_allclose(same_hessian.intensities_km_per_mol(), ase_km_per_mol, rtol=2e-4)
    np.testing.assert_allclose(water.ir.wavenumbers, ase_cm1, atol=1.0)
    np.testing.assert_allclose(water.ir.intensities_km_per_mol(), ase_km_per_mol, rtol=1e-3)


# ====================================================================== polarisability
def test_polarizability_analytic_and_finite_field_match_tdhf_sum_over_states(water: Molecule) -> None:
    # The static polarisability three ways at the water equilibrium: vibra's CPHF response
    # (analytic), vibra's finite field (+-0.001 a.u., central differences of the dipole), and
    # the sum over all of PySCF's TDHF (full RPA) excitations, alpha_ab = 2 sum_n mu_a^n mu_b^n
    # / omega_n, which equals the CPHF static response exactly. Measured: CPHF vs TDHF 5e-14,
    # finite field vs TDHF 7e-7 (relative to the largest component; the field's O(F^2)
    # truncation is gamma F^2 / 6). Allowed: 1e-9 and 1e-5.
    from pyscf import tdscf

    numbers, positions = water.atoms.get_atomic_numbers(), water.atoms.get_positions()
    mf = water.engine.scf(numbers, positions)
    td = tdscf.TDHF(mf)
    td.nstates = int((mf.mo_occ > 0).sum() * (mf.mo_occ == 0).sum())   # every excitation of the basis
    td.conv_tol = 1e-12
    td.kernel()
    moments = np.asarray(td.transition_dipole())                        # (n_states, 3), e bohr
    reference = 2.0 * np.einsum("na,nb,n->ab", moments, moments, 1.0 / np.asarray(td.e))
    reference *= constants.physical_constants["Bohr radius"][0] ** 3 / constants.angstrom**3
    analytic = PySCFEngine("hf", "sto-3g", polarizability="analytic").compute(numbers, positions, ["polarizability"])
    field = PySCFEngine("hf", "sto-3g", polarizability="finite field").compute(numbers, positions, ["polarizability"])
    scale = np.abs(reference).max()
    assert analytic.polarizability is not None and field.polarizability is not None
    np.testing.assert_allclose(analytic.polarizability, reference, atol=1e-9 * scale)
    np.testing.assert_allclose(field.polarizability, reference, atol=1e-5 * scale)
    # what the finite difference differentiated at the reference geometry is the same tensor
    derivatives = water.electronic.finite_difference.derivatives
    assert derivatives is not None
    np.testing.assert_allclose(derivatives.reference_polarizability, analytic.polarizability, atol=1e-12)
    assert water.electronic.polarizability_method == "analytic response (CPHF)"


# ====================================================================== Raman: ratios and cross sections
def test_depolarization_ratio_of_the_antisymmetric_stretch_is_three_quarters(water: Molecule) -> None:
    # a B2 line has no isotropic part: rho = 3 g^2 / 4 g^2 = 3/4 (to the fd noise); the A1
    # lines are polarised, rho < 3/4
    rho = water.raman.depolarization_ratios()
    b2 = [k for k, s in enumerate(water.analysis.species) if s == "B2"]
    a1 = [k for k, s in enumerate(water.analysis.species) if s == "A1"]
    np.testing.assert_allclose(rho[b2], 0.75, atol=1e-8)
    assert np.all(rho[a1] < 0.75)


def test_cross_sections_in_si_units(co2: Molecule) -> None:
    # The same cross section written in SI: d sigma/d Omega = omega_s^4 / (16 pi^2 eps0^2 c^4)
    # (4 pi eps0)^2 S / 45 hbar / (2 omega_k) / (1 - exp(-hbar omega_k / kT)), alpha' as SI
    # polarisability derivatives; an independent path through the units. Then the laws: the
    # scattered frequency to the fourth power, and the Bose factor (-> 1 at T = 0).
    raman = co2.raman
    laser_nm, temperature = 532.0, 298.15
    sigma = raman.cross_sections_cm2_per_sr(laser_nm, temperature)
    nu = raman.wavenumbers * 100.0                                  # m^-1
    omega_s = 2 * np.pi * constants.c * (1e9 / laser_nm - nu)
    omega_k = 2 * np.pi * constants.c * nu
    activity = raman.activities * 1e-40 / constants.atomic_mass    # m^4 / kg
    eps0 = constants.epsilon_0
    bose = 1.0 / (1.0 - np.exp(-constants.hbar * omega_k / (constants.k * temperature)))
    si = (omega_s**4 / (16 * np.pi**2 * eps0**2 * constants.c**4) * (4 * np.pi * eps0) ** 2 * activity / 45.0
          * constants.hbar / (2 * omega_k) * bose)                   # m^2 / sr
    np.testing.assert_allclose(sigma, si * 1e4, rtol=1e-12)
    cold = raman.cross_sections_cm2_per_sr(laser_nm, 0.0)
    np.testing.assert_allclose(sigma / cold, bose, rtol=1e-12)
    red = raman.cross_sections_cm2_per_sr(785.0, 0.0)
    np.testing.assert_allclose(red / cold, ((1e7 / 785.0 - raman.wavenumbers) / (1e7 / 532.0 - raman.wavenumbers))
                               ** 4, rtol=1e-12)
    with pytest.raises(ValueError, match=r"laser_nm is 5000.0: 2000 cm\^-1, not above the highest line"):
        raman.cross_sections_cm2_per_sr(5000.0)


# ====================================================================== level of theory on charts
def test_the_level_of_theory_reaches_the_charts(water: Molecule, tmp_path: Path) -> None:
    from vibra.charts import save_figure
    from vibra.charts.spectra import plot_broadened_spectrum, plot_stick_spectrum

    sticks = water.ir.sticks()
    broad = sticks.broadened(np.linspace(1500.0, 4800.0, 400), 20.0)
    assert sticks.level == broad.level == LEVEL
    assert water.raman.sticks().level == LEVEL and water.raman.path == "polarizability derivatives"
    figure = plot_broadened_spectrum(broad, sticks=sticks)
    assert figure.axes[0].get_title() == f"IR spectrum, {LEVEL}"
    assert plot_stick_spectrum(water.raman.sticks()).axes[0].get_title() == f"Raman stick spectrum, {LEVEL}"
    assert save_figure(figure, tmp_path / "ir.png").stat().st_size > 0
    assert f"IR (dipole derivatives, {LEVEL})" in water.ir.table()
    # the level survives a round trip through a result file
    again = spectra.IRSpectrum.load(water.ir.save(tmp_path / "ir.npz"))
    assert again.level == LEVEL
    np.testing.assert_array_equal(again.intensity_errors, water.ir.intensity_errors)


# ====================================================================== cache: resumable
def test_a_rerun_reads_every_geometry_from_the_cache(water: Molecule) -> None:
    # the fixture's run wrote one file per geometry (forces, dipole, polarisability); the same
    # run again computes nothing and gives the same numbers bit for bit
    again = electronic_structure(water.atoms, water.engine, cache=water.cache, hessian="finite difference",
                                 symmetry=False)
    fd, first = again.finite_difference, water.electronic.finite_difference
    assert fd.n_force_calls == 0 and fd.n_cached == 37 and again.hessian_method == "finite difference"
    np.testing.assert_array_equal(fd.hessian, first.hessian)
    assert fd.derivatives is not None and first.derivatives is not None
    np.testing.assert_array_equal(fd.derivatives.dipole, first.derivatives.dipole)
    np.testing.assert_array_equal(fd.derivatives.polarizability, first.derivatives.polarizability)
    assert len(list(water.cache.glob("*.npy"))) == 37


# ====================================================================== the engine's inputs
@pytest.mark.filterwarnings("ignore:Basis may be available in basis-set-exchange")
def test_engine_settings_are_checked() -> None:
    with pytest.raises(ValueError, match=r"polarizability is 'exact'"):
        PySCFEngine(polarizability="exact")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"spin is -1"):
        PySCFEngine(spin=-1)
    with pytest.raises(ValueError, match=r"polarizability='analytic' needs a restricted"):
        PySCFEngine(spin=2, polarizability="analytic")
    with pytest.raises(TypeError, match=r"basis must be a non-empty str"):
        PySCFEngine(basis="")
    with pytest.raises(TypeError, match=r"charge must be an int"):
        PySCFEngine(charge=0.5)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"field"):
        PySCFEngine(field=0.0)
    with pytest.raises(ValueError, match=r"PySCF cannot build the molecule with basis 'no-such-basis'"):
        PySCFEngine(basis="no-such-basis").compute(np.array([1, 1]), np.array([[0, 0, 0], [0, 0, 0.74]]))
    assert PySCFEngine("b3lyp", "cc-pvdz").level == "B3LYP/cc-pVDZ"
    assert PySCFEngine("hf", "6-31g*", spin=2).level == "UHF/6-31G*"
    assert PySCFEngine(spin=2).polarizability_method.startswith("finite field")


def test_electronic_structure_checks_its_inputs(water: Molecule) -> None:
    with pytest.raises(TypeError, match=r"engine must be a vibra.molecules.engines.Engine"):
        electronic_structure(water.atoms, 3.0)
    with pytest.raises(ValueError, match=r"hessian is 'numerical'"):
        electronic_structure(water.atoms, water.engine, hessian="numerical")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"properties\[0\] is 'charges'"):
        electronic_structure(water.atoms, water.engine, properties=["charges"])
    with pytest.raises(TypeError, match=r"electronic must be a vibra.molecules.engines.ElectronicStructure"):
        spectra.electronic_ir_spectrum(water.analysis)  # type: ignore[arg-type]
    assert isinstance(water.electronic, ElectronicStructure)


# ====================================================================== the docs
def test_docs_pyscf_example_runs_as_written(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # docs/spectra.md, "From electronic structure (PySCF)": its ```py blocks (they need the extra,
    # so the page's other test leaves them out) run as written
    text = (ROOT / "docs" / "spectra.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```py\n(.*?)```", text, re.S)
    assert blocks
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    for block in blocks:
        exec(compile(block, "docs/spectra.md (PySCF)", "exec"), namespace)
    assert namespace["ir"].level == LEVEL
    assert (tmp_path / "water_ir_rhf.png").stat().st_size > 0
