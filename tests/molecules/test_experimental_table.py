"""The cited table of observed fundamentals and IR intensities (vibra.molecules.experimental), the
fundamental scale factors (vibra.spectra.scale_factors), the comparison of computed against
observed values (vibra.spectra.experiment) and its chart (vibra.charts.experiment).

Truth: the cited sources themselves (Shimanouchi's fundamentals; the NIST CCCBDB page of H2O for
its intensities; Jennings and Robiette's nu4 band strength of CH4 in cm^-2 atm^-1, converted here
with scipy's constants; Irikura et al.'s published fundamental factor for HF/6-31G(d) with its
standard uncertainty: values transcribed here independently of the module), the character
tables vibra already has (every species is one of the molecule's point group), and the Alecu et
al. ratio lambda_F / lambda_ZPE = 0.974.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from tests.helpers.images import check_png
from tests.helpers.ir_lines import ir_lines
from vibra.molecules import EXPERIMENTAL, experimental_fundamentals
from vibra.molecules.experimental import CCCBDB_H2O_INTENSITIES, JENNINGS_ROBIETTE_1982_CH4_NU4
from vibra.spectra import SCALE_FACTORS, ExperimentComparison, compare_with_experiment, fundamental_scale_factor

#: The CCCBDB page "Experimental data for H2O" (Release 18), vibrational levels: km/mol.
CCCBDB_H2O_KM_PER_MOL = {"nu1": 2.9, "nu2": 62.5, "nu3": 41.7}
#: Jennings and Robiette, J. Mol. Spectrosc. 94, 369 (1982), abstract: the nu4 band strength of
#: 12CH4, S = 127 +- 4 cm^-2 atm^-1 at 295.7 K.
CH4_NU4_CM2_ATM, CH4_NU4_KELVIN = 127.0, 295.7
#: Irikura, Johnson and Kacker (2005), abstract: the fundamental factor of HF/6-31G(d) and its
#: standard uncertainty.
HF_631GD_FUNDAMENTAL, HF_631GD_UNCERTAINTY = 0.8982, 0.0230


def test_every_value_has_a_source() -> None:
    for formula, entry in EXPERIMENTAL.items():
        assert entry.name == formula
        assert "Shimanouchi" in entry.source and "NSRDS-NBS 39" in entry.source
        names = [f.name for f in entry.fundamentals]
        assert names == [f"nu{i + 1}" for i in range(len(names))], formula
        for fundamental in entry.fundamentals:
            assert np.isfinite(fundamental.wavenumber_cm1) and fundamental.wavenumber_cm1 > 0
            if fundamental.intensity_km_per_mol is not None:
                assert fundamental.intensity_km_per_mol > 0
                assert entry.intensity_source in (CCCBDB_H2O_INTENSITIES, JENNINGS_ROBIETTE_1982_CH4_NU4), formula
        assert entry.has_intensities == (entry.intensity_source is not None), formula


def test_water_intensities_are_the_cccbdb_values() -> None:
    entry = EXPERIMENTAL["H2O"]
    assert {f.name: f.intensity_km_per_mol for f in entry.fundamentals} == CCCBDB_H2O_KM_PER_MOL
    assert "7732185" in str(entry.intensity_source)  # the page: H2O's CAS number


def test_methane_nu4_intensity_is_jennings_robiettes_band_strength() -> None:
    """S (cm^-2 atm^-1 at T) x the molar volume at 1 atm and T (cm^3/mol) is cm/mol; / 1e5 is
    km/mol. Stored to 0.1 km/mol, the precision the source's +-4 (+-1.0 km/mol) allows."""
    from scipy.constants import R, atm

    entry = EXPERIMENTAL["CH4"]
    km_per_mol = CH4_NU4_CM2_ATM * (R * CH4_NU4_KELVIN / atm * 1e6) / 1e5
    assert {f.name: f.intensity_km_per_mol for f in entry.fundamentals} == {
        "nu1": None, "nu2": None, "nu3": None, "nu4": round(km_per_mol, 1)}
    assert entry.intensity_source == JENNINGS_ROBIETTE_1982_CH4_NU4
    assert "Jennings" in entry.intensity_source and "127" in entry.intensity_source
    assert EXPERIMENTAL["CO2"].intensity_source is None and not EXPERIMENTAL["CO2"].has_intensities


@pytest.mark.parametrize("name", ["CO2", "H2O", "CH4"])
def test_species_are_the_point_groups(name: str) -> None:
    """Every listed species is a vibration species of the molecule's point group, and the count of
    fundamentals (degenerate sets once) is what the group's vibrational representation has."""
    from vibra import molecules as mol

    system = {"CO2": lambda: mol.co2(dims=3), "H2O": mol.h2o, "CH4": lambda: mol.molecule("CH4")}[name]()
    analysis = mol.vibrational_analysis(system)
    computed = analysis.species
    entry = experimental_fundamentals(system.symbols, system.masses)
    assert entry is not None and entry.name == name
    assert {f.species for f in entry.fundamentals} <= set(computed)
    sets = len({(s, round(float(w))) for s, w in zip(computed, analysis.wavenumbers_cm1()[analysis.vibrations])})
    assert len(entry.fundamentals) == sets


def test_fundamental_factors_are_the_ratio_of_the_zpe_factors() -> None:
    for level, factor in SCALE_FACTORS.items():
        assert fundamental_scale_factor(level) == round(0.974 * factor, 3)
    assert fundamental_scale_factor("RHF/6-31G*") == fundamental_scale_factor("HF/6-31G(d)") == 0.885
    assert fundamental_scale_factor("b3lyp/6-31g*") == 0.952
    assert fundamental_scale_factor("GFN2-xTB") is None
    with pytest.raises(TypeError, match="level must be a str"):
        fundamental_scale_factor(0.9)  # type: ignore[arg-type]


def test_fundamental_factor_rule_lands_within_the_published_uncertainty() -> None:
    """0.974 x the ZPE factor of HF/6-31G(d) against the fundamental factor fitted directly to
    observed fundamentals (Irikura, Johnson and Kacker 2005: 0.8982 +- 0.0230, a standard
    uncertainty after the ISO Guide to the Expression of Uncertainty in Measurement). Tolerance:
    that one standard uncertainty, the size the authors give the factor itself ("only two
    significant digits"); the rule is 0.013 off."""
    assert abs(fundamental_scale_factor("HF/6-31G(d)") - HF_631GD_FUNDAMENTAL) <= HF_631GD_UNCERTAINTY




def test_comparison_scales_pairs_and_sums_degenerate_sets() -> None:
    entry = EXPERIMENTAL["CO2"]
    ir = ir_lines([700.0, 700.0, 1400.0, 2400.0], [20.0, 20.0, 0.0, 500.0], "B3LYP/6-31G(d)")
    comparison = compare_with_experiment(ir, ["Pi_u", "Pi_u", "Sigma_g+", "Sigma_u+"], entry)
    assert comparison.names == ("nu1", "nu2", "nu3")
    assert comparison.scale_factor == 0.952
    assert np.allclose(comparison.computed_cm1, 0.952 * np.array([1400.0, 700.0, 2400.0]))
    assert np.allclose(comparison.computed_km_per_mol, [0.0, 40.0, 500.0])  # the bend's two components summed
    assert np.all(np.isnan(comparison.observed_km_per_mol))  # CO2: no sourced intensities
    expected = 100 * (0.952 * 2400.0 - 2349.0) / 2349.0
    assert comparison.deviation_percent()[2] == pytest.approx(expected)
    assert "nu3" in comparison.table() and "Shimanouchi" in comparison.table()
    unscaled = compare_with_experiment(ir_lines([1600.0, 3650.0, 3750.0], [60, 3, 40], "GFN2-xTB"), ["A1", "A1", "B2"],
                                       EXPERIMENTAL["H2O"])
    assert unscaled.scale_factor == 1.0 and "unscaled" in unscaled.scale_source
    assert np.allclose(unscaled.intensity_ratio(), [3 / 2.9, 60 / 62.5, 40 / 41.7])


def test_comparison_is_frozen() -> None:
    comparison = compare_with_experiment(ir_lines([1600.0, 3650.0, 3750.0], [60, 3, 40], ""), ["A1", "A1", "B2"],
                                         EXPERIMENTAL["H2O"])
    with pytest.raises(dataclasses.FrozenInstanceError):
        comparison.level = "x"  # type: ignore[misc]
    with pytest.raises(ValueError):
        comparison.computed_cm1[0] = 0.0


def test_comparison_bad_input_is_named() -> None:
    ir = ir_lines([1600.0, 3650.0, 3750.0], [60, 3, 40], "")
    with pytest.raises(ValueError, match=r"species has 2 labels; expected one per line of ir \(3\)"):
        compare_with_experiment(ir, ["A1", "A1"], EXPERIMENTAL["H2O"])
    with pytest.raises(TypeError, match="entry must be a vibra.molecules.ExperimentalFundamentals"):
        compare_with_experiment(ir, ["A1", "A1", "B2"], {"H2O": 1})
    with pytest.raises(TypeError, match="ir must be an IRSpectrum"):
        compare_with_experiment([1.0], ["A1"], EXPERIMENTAL["H2O"])
    with pytest.raises(ValueError, match="no observed fundamental of H2O matches"):
        compare_with_experiment(ir, ["E", "E", "T2"], EXPERIMENTAL["H2O"])
    with pytest.raises(ValueError, match="scale_factor is -1"):
        compare_with_experiment(ir, ["A1", "A1", "B2"], EXPERIMENTAL["H2O"], scale_factor=-1)


def test_chart_renders(tmp_path: Path) -> None:
    from vibra.charts import save_figure
    from vibra.charts.experiment import plot_experiment_comparison

    comparison = compare_with_experiment(ir_lines([1700.0, 3800.0, 3900.0], [70, 8, 60], "B3LYP/6-31G(d)"),
                                         ["A1", "A1", "B2"], EXPERIMENTAL["H2O"])
    figure = plot_experiment_comparison(comparison, title="water")
    assert "computed against observed" in figure._suptitle.get_text()
    path = save_figure(figure, tmp_path / "experiment.png")
    check_png(path, least=(400, 600))
    assert isinstance(comparison, ExperimentComparison)
    with pytest.raises(TypeError, match="comparison must be a vibra.spectra.ExperimentComparison"):
        plot_experiment_comparison(object())
