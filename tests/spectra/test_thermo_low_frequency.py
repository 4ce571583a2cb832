"""Thermochemistry as published (issue 31, item 4): quasi-RRHO (Grimme's entropy, Head-Gordon's
enthalpy), Truhlar's raised frequencies, scale factors, error bars from the frequencies' bounds.

Truth: GoodVibes (PyPI ``goodvibes``), its per-mode functions and its whole pipeline on its own
example outputs, given scipy's CODATA constants for the comparison (its defaults are CODATA
2010, ~1e-7 apart, which would hide the 1e-8 target); limits (a stiff mode is harmonic, a soft
one a free rotor); the bounds checked against the quantities recomputed at shifted frequencies.
"""

from __future__ import annotations

import os
import warnings
from typing import Any, Iterator

import numpy as np
import pytest
from scipy import constants

import vibra
from vibra.spectra import ideal_gas_thermochemistry, thermochemistry

J_PER_MOL = constants.e * constants.N_A  # J/mol per eV
FREQUENCIES = np.array([12.0, 45.0, 88.0, 150.0, 420.0, 1100.0, 3050.0])  # cm^-1, three soft


@pytest.fixture()
def goodvibes() -> Iterator[Any]:
    """goodvibes.thermo with scipy's constants for one test, its own restored after."""
    thermo = pytest.importorskip("goodvibes.thermo")
    names = ("GAS_CONSTANT", "PLANCK_CONSTANT", "BOLTZMANN_CONSTANT", "SPEED_OF_LIGHT", "AVOGADRO_CONSTANT")
    saved = {name: getattr(thermo, name) for name in names}
    values = (constants.R, constants.h, constants.k, constants.c / constants.centi, constants.N_A)
    for name, value in zip(names, values):
        setattr(thermo, name, value)
    try:
        yield thermo
    finally:
        for name, value in saved.items():
            setattr(thermo, name, value)


@pytest.mark.parametrize("temperature", [50.0, 298.15, 1000.0])
def test_each_treatment_equals_goodvibes_mode_by_mode(goodvibes: Any, temperature: float) -> None:
    """S and U of the vibrations against GoodVibes' own functions on the same frequencies:
    harmonic (calc_rrho_entropy, calc_vibrational_energy), Grimme + Head-Gordon (calc_damp,
    calc_freerot_entropy with B_av = 1e-44, calc_qRRHO_energy), Truhlar (rrho at the raised
    frequencies). rtol 1e-8, the issue's target (the same formulas: agreement is at rounding)."""
    gv = goodvibes
    damp = np.array(gv.calc_damp(FREQUENCIES, 100.0))
    rrho = np.array(gv.calc_rrho_entropy(temperature, FREQUENCIES))
    expected = {
        None: (rrho.sum(), gv.calc_vibrational_energy(temperature, FREQUENCIES)),
        "grimme": ((damp * rrho + (1 - damp) * np.array(gv.calc_freerot_entropy(temperature, FREQUENCIES))).sum(),
                   (damp * np.array(gv.calc_qRRHO_energy(temperature, FREQUENCIES))
                    + (1 - damp) * 0.5 * constants.R * temperature).sum()),
        "truhlar": (np.sum(gv.calc_rrho_entropy(temperature, np.maximum(FREQUENCIES, 100.0))),
                    gv.calc_vibrational_energy(temperature, FREQUENCIES)),
    }
    for treatment, (entropy, energy) in expected.items():
        ours = thermochemistry(FREQUENCIES, temperature, low_frequency=treatment)
        assert ours.entropy[0] * J_PER_MOL == pytest.approx(entropy, rel=1e-8)
        assert ours.internal_energy[0] * J_PER_MOL == pytest.approx(energy, rel=1e-8)


@pytest.mark.parametrize("example", ["ethane.out", "allene.out"])
def test_the_quasi_rrho_correction_equals_goodvibes_on_its_examples(goodvibes: Any, example: str) -> None:
    """GoodVibes' whole pipeline (calc_bbe, QS="grimme", QH=True, cutoffs 100 cm^-1, B_av 1e-44)
    on its example Gaussian outputs: the quasi-RRHO minus harmonic S and H (the translational
    and rotational parts cancel) against ours on the frequencies it parsed, rtol 1e-8."""
    path = os.path.join(os.path.dirname(goodvibes.__file__), "examples", example)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        bbe = goodvibes.calc_bbe(path, QS="grimme", QH=True, cutoff=100.0, H_FREQ_CUTOFF=100.0, temp=298.15,
                                 inertia="global", conc=1.0 / 24.46, scale_fac=1.0)
    to_j = goodvibes.J_TO_AU  # GoodVibes' Hartree -> J/mol
    frequencies = np.asarray(bbe.frequency_wn, dtype=float)
    harmonic = thermochemistry(frequencies, 298.15)
    quasi = thermochemistry(frequencies, 298.15, low_frequency="grimme")
    assert (quasi.entropy[0] - harmonic.entropy[0]) * J_PER_MOL == pytest.approx(
        (bbe.qh_entropy - bbe.entropy) * to_j, rel=1e-8)
    assert (quasi.internal_energy[0] - harmonic.internal_energy[0]) * J_PER_MOL == pytest.approx(
        (bbe.qh_enthalpy - bbe.enthalpy) * to_j, rel=1e-8)


def test_the_limits_stiff_modes_stay_harmonic_soft_ones_become_free_rotors() -> None:
    """w = 1 / (1 + (nu0 / nu)^4): a 3000 cm^-1 mode keeps its harmonic S but for (100/3000)^4 of a
    free rotor's; as nu -> 0 the harmonic S grows like k ln(1/nu) without bound while the
    quasi-RRHO one tends to the free rotor of moment B_av, k (1/2 + ln sqrt(8 pi^3 B_av kT / h^2))
    (finite), and U to kT / 2 (at 1e-7 cm^-1 the rotor's moment is B_av to 4e-6: 3e-7 in S)."""
    k = constants.k / constants.e
    rotor = k * (0.5 + 0.5 * np.log(8 * np.pi**3 * 1e-44 * constants.k * 298.15 / constants.h**2))
    stiff = thermochemistry([3000.0], 298.15, low_frequency="grimme").entropy[0]
    # (1 - w) ~ (1/30)^4 of the free rotor's entropy is all that moves (absolute: the harmonic S
    # of a 3000 cm^-1 mode at room temperature is itself only ~1e-10 eV/K)
    assert abs(stiff - thermochemistry([3000.0], 298.15).entropy[0]) <= (100 / 3000) ** 4 * rotor
    harmonic = [thermochemistry([nu], 298.15).entropy[0] for nu in (1e-6, 1e-7)]
    assert harmonic[1] - harmonic[0] == pytest.approx(k * np.log(10), rel=1e-6)
    soft = thermochemistry([1e-7], 298.15, low_frequency="grimme")
    assert soft.entropy[0] == pytest.approx(rotor, rel=1e-6)
    assert soft.internal_energy[0] == pytest.approx(0.5 * k * 298.15, rel=1e-6)


def test_a_scale_factor_scales_every_frequency_first() -> None:
    scaled = thermochemistry(FREQUENCIES, [100.0, 300.0], scale_factor=0.961, low_frequency="grimme")
    direct = thermochemistry(0.961 * FREQUENCIES, [100.0, 300.0], low_frequency="grimme")
    np.testing.assert_allclose(scaled.entropy, direct.entropy, rtol=1e-14)
    np.testing.assert_allclose(scaled.wavenumbers, 0.961 * FREQUENCIES, rtol=1e-15)
    assert scaled.scale_factor == 0.961


def test_error_bars_cover_the_quantities_at_frequencies_moved_by_their_bounds() -> None:
    """Modes whose omega_error is 1e-3 relative: U, S and F recomputed with every frequency moved
    by its bound (all up, all down: the worst case for sums of monotonic terms) stay within the
    reported errors (each term monotonic in nu: the bound is that worst case, so it is not
    vacuous either: within 1.5x of the change)."""
    system = vibra.molecules.co2()
    modes = vibra.molecules.vibrational_analysis(system).modes
    loose = vibra.Modes(omega=modes.omega, vectors=modes.vectors, shapes=modes.shapes, mass=modes.mass,
                        omega_error=np.maximum(modes.omega_error, 1e-3 * np.abs(modes.omega)),
                        residual=modes.residual, orthogonality=modes.orthogonality, solver=modes.solver,
                        units=modes.units)
    for treatment in (None, "grimme"):
        result = thermochemistry(loose, [300.0, 1500.0], low_frequency=treatment)
        for sign in (1.0, -1.0):
            moved = thermochemistry(result.wavenumbers * (1 + sign * 1e-3), [300.0, 1500.0], low_frequency=treatment)
            for value, error, changed in ((result.entropy, result.entropy_error, moved.entropy),
                                          (result.internal_energy, result.internal_energy_error, moved.internal_energy),
                                          (result.helmholtz_energy, result.helmholtz_energy_error,
                                           moved.helmholtz_energy)):
                change = np.abs(changed - value)
                assert np.all(change <= error * (1 + 1e-12) + 1e-18)
                assert np.all(error <= 1.5 * change + 1e-18)
    gas = ideal_gas_thermochemistry(system, 300.0, symmetry_number=2)
    assert gas.entropy_error is not None and gas.gibbs_error is not None and np.all(gas.entropy_error >= 0)


def test_a_transition_states_imaginary_mode_is_left_out_with_a_note() -> None:
    with pytest.warns(RuntimeWarning, match="1 imaginary mode"):
        result = thermochemistry([-450.0, 300.0, 1200.0], 298.15, low_frequency="grimme")
    assert result.n_imaginary == 1 and result.wavenumbers.tolist() == [300.0, 1200.0]


def test_scale_factor_table_is_goodvibes_and_levels_are_read_by_name() -> None:
    """Each shipped factor equals the ZPE factor of the same level in GoodVibes' copy of the
    Truhlar group's database (an independent package); a level name gives its factor, an
    unknown one is refused with the closest names and the advice to give the number."""
    from goodvibes import vib_scale_factors as gv

    from vibra.spectra import SCALE_FACTORS

    for level, factor in SCALE_FACTORS.items():
        assert gv.scaling_data_dict[gv.canonicalize_level(level)].zpe_fac == factor, level
    by_name = thermochemistry(FREQUENCIES, [100.0, 300.0], scale_factor="b3lyp/6-31g(d)")
    by_number = thermochemistry(FREQUENCIES, [100.0, 300.0], scale_factor=0.977)
    assert by_name.scale_factor == 0.977
    np.testing.assert_array_equal(by_name.entropy, by_number.entropy)
    with pytest.raises(ValueError, match=r"scale_factor is 'B3LYP/6-31G\(x\)': not a level of theory .*closest: "
                                         r"B3LYP/6-31G\(d\).*give the factor .* as a number"):
        thermochemistry(FREQUENCIES, [300.0], scale_factor="B3LYP/6-31G(x)")
