"""Tests of vibra.spectra.ideal_gas_thermochemistry. Truth comes from ASE's `IdealGasThermo` on
the same vibrational energies (with ASE's constants set to CODATA 2018, the values vibra uses),
from tabulated standard entropies (CODATA Key Values for Thermodynamics, NIST-JANAF) computed
with experimental frequencies and geometries, and from thermodynamic identities
(C_p = dH/dT, S = -dG/dT, dS/d ln p = -k)."""

from __future__ import annotations

import dataclasses

import ase.thermochemistry
import numpy as np
import pytest
from ase import Atoms
from ase.thermochemistry import IdealGasThermo
from ase.units import create_units
from scipy import constants

import vibra.molecules
from vibra import molecules as mol
from vibra.spectra import (BOLTZMANN_EV_PER_K, IdealGasThermochemistry, ideal_gas_thermochemistry,
                           thermochemistry)

EV_PER_CM1 = constants.h * constants.c / constants.centi / constants.e
J_PER_MOL_PER_EV = constants.e * constants.N_A
TEMPERATURES = np.array([20.0, 298.15, 1000.0, 3000.0])
PRESSURES = (1e3, 1e5, 1e7)


def _ase(system: mol.System, geometry: str, sigma: int, spin: float) -> IdealGasThermo:
    analysis = mol.vibrational_analysis(system)
    energies = analysis.vibration_wavenumbers_cm1() * EV_PER_CM1
    return IdealGasThermo(energies, geometry, potentialenergy=0.0, atoms=mol.system_atoms(system),
                          symmetrynumber=sigma, spin=spin)


@pytest.fixture
def ase_codata_2018(monkeypatch: pytest.MonkeyPatch) -> None:
    """ASE's thermochemistry with CODATA 2018 constants (its default is CODATA 2014)."""
    monkeypatch.setattr(ase.thermochemistry, "units", create_units("2018"))


# ----------------------------------------------------------------- against ASE
@pytest.mark.parametrize("case", ["co2", "h2o", "ch4"])
@pytest.mark.parametrize("spin", [0.0, 1.0])
def test_matches_ase_ideal_gas_thermo(ase_codata_2018: None, case: str, spin: float) -> None:
    system, shape, sigma = {"co2": (mol.co2(), "linear", 2), "h2o": (mol.h2o(), "nonlinear", 2),
                            "ch4": (mol.molecule("CH4"), "nonlinear", 12)}[case]
    reference = _ase(system, shape, sigma, spin)
    analysis = mol.vibrational_analysis(system)
    for pressure in PRESSURES:
        gas = ideal_gas_thermochemistry(analysis, TEMPERATURES, pressure, spin=spin, symmetry_number=sigma,
                                        geometry=system)
        assert gas.shape == shape
        h = [reference.get_enthalpy(t, verbose=False) for t in TEMPERATURES]
        s = [reference.get_entropy(t, pressure, verbose=False) for t in TEMPERATURES]
        g = [reference.get_gibbs_energy(t, pressure, verbose=False) for t in TEMPERATURES]
        np.testing.assert_allclose(gas.enthalpy, h, rtol=1e-6)
        np.testing.assert_allclose(gas.entropy, s, rtol=1e-6)
        np.testing.assert_allclose(gas.gibbs, g, rtol=1e-6)


def test_matches_ase_for_a_monatomic_gas(ase_codata_2018: None) -> None:
    argon = Atoms("Ar")
    gas = ideal_gas_thermochemistry([], TEMPERATURES, 2e5, geometry=argon)
    reference = IdealGasThermo([], "monatomic", atoms=argon, symmetrynumber=1, spin=0)
    assert gas.shape == "monatomic" and gas.symmetry_number == 1
    np.testing.assert_allclose(gas.entropy, [reference.get_entropy(t, 2e5, verbose=False) for t in TEMPERATURES],
                               rtol=1e-6)
    np.testing.assert_allclose(gas.enthalpy, [reference.get_enthalpy(t, verbose=False) for t in TEMPERATURES],
                               rtol=1e-6)


# ----------------------------------------------------------------- against tables
def _co2() -> Atoms:
    return Atoms("OCO", positions=[(-1.1600, 0, 0), (0, 0, 0), (1.1600, 0, 0)])


def _h2o() -> Atoms:
    r, half = 0.9572, np.radians(104.52) / 2
    return Atoms("OHH", positions=[(0, 0, 0), (r * np.sin(half), r * np.cos(half), 0),
                                   (-r * np.sin(half), r * np.cos(half), 0)])


def _nh3() -> Atoms:
    r, angle = 1.012, np.radians(106.7)
    beta = np.arcsin(2 / np.sqrt(3) * np.sin(angle / 2))       # N-H against the C3 axis
    return Atoms("NHHH", positions=[(0, 0, 0)] + [
        (r * np.sin(beta) * np.cos(phi), r * np.sin(beta) * np.sin(phi), -r * np.cos(beta))
        for phi in (0, 2 * np.pi / 3, 4 * np.pi / 3)])


def _ch4() -> Atoms:
    a = 1.087 / np.sqrt(3)
    return Atoms("CHHHH", positions=[(0, 0, 0), (a, a, a), (a, -a, -a), (-a, a, -a), (-a, -a, a)])


# Experimental geometries (NIST CCCBDB, "experimental geometry") and fundamentals in cm^-1
# (T. Shimanouchi, Tables of Molecular Vibrational Frequencies, NSRDS-NBS 39, 1972; NH3's
# inversion doublet 932/968 averaged), degenerate modes once per component; standard
# entropies S°(298.15 K, 1 bar) in J/(mol K): CO2 213.785, H2O 188.835, NH3 192.77 from the
# CODATA Key Values for Thermodynamics (Cox, Wagman, Medvedev 1989); CH4 186.251 and Ar
# 154.846 from NIST-JANAF (Chase 1998).
TABLES = {
    "CO2": (_co2, [1333, 667, 667, 2349], 2, 213.785),
    "H2O": (_h2o, [3657, 1595, 3756], 2, 188.835),
    "NH3": (_nh3, [3337, 950, 3444, 3444, 1627, 1627], 3, 192.77),
    "CH4": (_ch4, [2917, 1534, 1534, 3019, 3019, 3019, 1306, 1306, 1306], 12, 186.251),
    "Ar": (lambda: Atoms("Ar"), [], 1, 154.846),
}


@pytest.mark.parametrize("name", sorted(TABLES))
def test_standard_entropy_matches_tables(name: str) -> None:
    build, wavenumbers, sigma, tabulated = TABLES[name]
    gas = ideal_gas_thermochemistry(wavenumbers, 298.15, constants.bar, symmetry_number=sigma, geometry=build())
    assert abs(gas.entropy_j_per_mol_k()[0] - tabulated) < 1.0


# ----------------------------------------------------------------- identities
def test_heat_capacity_and_entropy_are_derivatives() -> None:
    system = mol.h2o()
    t = np.array([150.0, 400.0, 1500.0])
    step = 1e-3 * t
    gas = ideal_gas_thermochemistry(system, t, 3e4, symmetry_number=2, spin=0.5)
    up = ideal_gas_thermochemistry(system, t + step, 3e4, symmetry_number=2, spin=0.5)
    down = ideal_gas_thermochemistry(system, t - step, 3e4, symmetry_number=2, spin=0.5)
    np.testing.assert_allclose((up.enthalpy - down.enthalpy) / (2 * step), gas.heat_capacity, rtol=1e-6)
    np.testing.assert_allclose(-(up.gibbs - down.gibbs) / (2 * step), gas.entropy, rtol=1e-6)


def test_pressure_enters_only_the_translational_entropy() -> None:
    system = mol.co2()
    low = ideal_gas_thermochemistry(system, TEMPERATURES, 1e4, symmetry_number=2)
    high = ideal_gas_thermochemistry(system, TEMPERATURES, 1e6, symmetry_number=2)
    np.testing.assert_allclose(low.entropy - high.entropy, BOLTZMANN_EV_PER_K * np.log(100.0), rtol=1e-12)
    np.testing.assert_array_equal(low.enthalpy, high.enthalpy)


def test_parts_add_up_and_classical_limits() -> None:
    system = mol.molecule("NH3")
    gas = ideal_gas_thermochemistry(system, [5.0, 298.15], symmetry_number=3, spin=1.0)
    parts = (gas.translational, gas.rotational, gas.vibrational, gas.electronic)
    for field in ("enthalpy", "entropy", "gibbs", "heat_capacity"):
        np.testing.assert_allclose(sum(getattr(p, field) for p in parts), getattr(gas, field), rtol=1e-14)
    k = BOLTZMANN_EV_PER_K
    np.testing.assert_allclose(gas.electronic.entropy, k * np.log(3.0), rtol=1e-14)
    assert gas.heat_capacity[0] == pytest.approx(4.0 * k, rel=1e-12)      # 5/2 k + 3/2 k, vibrations frozen
    linear = ideal_gas_thermochemistry(mol.co2(), 5.0, symmetry_number=2)
    assert linear.heat_capacity[0] == pytest.approx(3.5 * k, rel=1e-9)
    vibrational = thermochemistry(mol.vibrational_analysis(system), [5.0, 298.15])
    np.testing.assert_array_equal(gas.vibrational.entropy, vibrational.entropy)
    assert gas.zero_point_energy == vibrational.zero_point_energy
    assert "S_rot" in gas.table() and gas.table().count("\n") == 3


def test_symmetry_number_divides_the_rotational_partition_function() -> None:
    system = mol.h2o()
    one = ideal_gas_thermochemistry(system, 298.15, symmetry_number=1)
    two = ideal_gas_thermochemistry(system, 298.15, symmetry_number=2)
    np.testing.assert_allclose(one.entropy - two.entropy, BOLTZMANN_EV_PER_K * np.log(2.0), rtol=1e-12)


def test_symmetry_number_from_the_point_group() -> None:
    for system, sigma in ((mol.co2(), 2), (mol.h2o(), 2), (mol.molecule("NH3"), 3), (mol.molecule("CH4"), 12),
                          (mol.molecule("C6H6", torsion=0.1), 12), (mol.molecule("CH3OH", torsion=0.1), 1)):
        assert ideal_gas_thermochemistry(system, 298.15).symmetry_number == sigma


# ----------------------------------------------------------------- results and bad input
def test_result_is_frozen() -> None:
    gas = ideal_gas_thermochemistry(mol.co2(), [300.0], symmetry_number=2)
    assert isinstance(gas, IdealGasThermochemistry)
    with pytest.raises(dataclasses.FrozenInstanceError):
        gas.pressure = 1.0  # type: ignore[misc]
    with pytest.raises(ValueError):
        gas.entropy[0] = 0.0
    with pytest.raises(ValueError):
        gas.rotational.entropy[0] = 0.0


def test_bad_input_is_named() -> None:
    system = mol.co2()
    analysis = mol.vibrational_analysis(system)
    with pytest.raises(ValueError, match="geometry is required"):
        ideal_gas_thermochemistry(analysis.modes, 300.0, symmetry_number=2)
    # the analysis alone carries its molecule (issue 31: it failed with "geometry is required")
    alone = ideal_gas_thermochemistry(analysis, 300.0, symmetry_number=2)
    np.testing.assert_allclose(alone.entropy, ideal_gas_thermochemistry(system, 300.0, symmetry_number=2).entropy,
                               rtol=1e-14)
    for keyword, value, message in (("low_frequency", "qrrho", "low_frequency is 'qrrho'"),
                                    ("scale_factor", 0.0, "scale_factor is 0.0"),
                                    ("cutoff", float("nan"), "cutoff is nan")):
        with pytest.raises(ValueError, match=message):
            ideal_gas_thermochemistry(analysis, 300.0, **{keyword: value})
    for temperature in (0.0, float("nan")):
        with pytest.raises(ValueError, match="temperature"):
            ideal_gas_thermochemistry(analysis, temperature, low_frequency="grimme")
    with pytest.raises(ValueError, match="gives 3 vibrations; a linear molecule of 3 atoms has 4"):
        ideal_gas_thermochemistry([1333, 667, 2349], 300.0, symmetry_number=2, geometry=_co2())
    with pytest.raises(ValueError, match="9 degrees of freedom but geometry has 1 atom"):
        ideal_gas_thermochemistry(analysis, 300.0, symmetry_number=2, geometry=Atoms("H"))
    with pytest.raises(ValueError, match="spin is 0.3"):
        ideal_gas_thermochemistry(system, 300.0, symmetry_number=2, spin=0.3)
    with pytest.raises(ValueError, match="symmetry_number is 0"):
        ideal_gas_thermochemistry(system, 300.0, symmetry_number=0)
    with pytest.raises(TypeError, match="symmetry_number must be an int"):
        ideal_gas_thermochemistry(system, 300.0, symmetry_number=2.0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="pressure is -1.0"):
        ideal_gas_thermochemistry(system, 300.0, -1.0, symmetry_number=2)
    with pytest.raises(ValueError, match="temperature"):
        ideal_gas_thermochemistry(system, [300.0, 0.0], symmetry_number=2)
    with pytest.raises(TypeError, match="geometry must be a vibra System or an ase.Atoms"):
        ideal_gas_thermochemistry(analysis, 300.0, symmetry_number=2, geometry="CO2")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="geometry must be a molecule"):
        ideal_gas_thermochemistry(analysis, 300.0, symmetry_number=2, geometry=mol.co2(dims=1))


def test_symmetry_number_none_asks_point_group_of_the_geometry(monkeypatch: pytest.MonkeyPatch) -> None:
    """The wiring only: a stand-in point_group records what it is given (the real one is tested above)."""
    seen = []

    class _Group:
        symmetry_number = 2

    def point_group(geometry: object, tolerance: float = 0.01) -> _Group:
        seen.append(geometry)
        return _Group()

    monkeypatch.setattr(vibra.molecules, "point_group", point_group, raising=False)
    system = mol.co2()
    gas = ideal_gas_thermochemistry(system, 298.15)
    assert gas.symmetry_number == 2 and seen == [system]
    explicit = ideal_gas_thermochemistry(system, 298.15, symmetry_number=2)
    np.testing.assert_array_equal(gas.entropy, explicit.entropy)
    assert ideal_gas_thermochemistry([], 298.15, geometry=Atoms("Ar")).symmetry_number == 1 and len(seen) == 1
