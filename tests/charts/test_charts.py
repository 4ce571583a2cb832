"""Tests of the charts that carry meaning (issues 31 and 32): molecule IR/Raman spectra, fitted
B-factors on one axis, the cross-correlation map with its colour bar.

Truth: closed forms and invariants from outside the chart code (the mutual exclusion rule of
centrosymmetric CO2, the character table's activities, the Lorentzian's peak height I / (pi w/2),
ProDy's conventions are checked in tests/pipeline/test_scene_systems.py).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from vibra.charts import save_figure
from vibra.charts.networks import b_factor_axis, plot_b_factors, plot_cross_correlations
from vibra.charts.spectra import plot_molecule_spectra, species_text
from vibra.pipeline.plan import build_system
from vibra.pipeline.plan.analysis import LINE_WIDTH_CM1, molecule_spectra, molecule_symmetry
from vibra.pipeline.scene import load_scene

ROOT = Path(__file__).resolve().parents[2]


def _spectra(name: str):  # noqa: ANN202
    from vibra.pipeline.plan.analysis import molecule_structure

    scene = load_scene(ROOT / "molecules" / f"{name}.toml")
    system = build_system(scene)
    modes = system.modes()
    structure = molecule_structure(scene, system)
    symmetry = molecule_symmetry(system, modes)
    return molecule_spectra(system, modes, structure.symbols, structure.bonds, symmetry), symmetry


def test_co2_spectra_obey_mutual_exclusion_and_carry_species() -> None:
    spectra, symmetry = _spectra("co2")
    assert spectra.n_rigid == 5 and len(spectra.ir.wavenumbers) == 3  # the bend pair is one line
    assert spectra.ir_species == ("Pi_u", "Sigma_g+", "Sigma_u+")
    strongest = spectra.ir.intensities.max()
    ir_allowed = spectra.ir.intensities > 1e-8 * strongest
    raman_allowed = spectra.raman.intensities > 1e-8 * spectra.raman.intensities.max()
    assert ir_allowed.tolist() == [True, False, True] and raman_allowed.tolist() == [False, True, False]
    assert not np.any(ir_allowed & raman_allowed)  # centrosymmetric: no line is both
    assert symmetry.group == "Dinfh"
    assert [symmetry.ir_active[int(k)] for k in (5, 7, 8)] == [True, False, True]  # the character table agrees
    # the Lorentzian of FWHM w peaks at I / (pi w / 2) on top of a line far from the others
    k = int(np.argmax(spectra.ir.intensities))
    peak = np.interp(spectra.ir.wavenumbers[k], spectra.ir_profile.grid, spectra.ir_profile.values)
    assert peak == pytest.approx(spectra.ir.intensities[k] / (np.pi * LINE_WIDTH_CM1 / 2), rel=2e-2)


def test_methane_spectrum_shows_its_species(tmp_path: Path) -> None:
    spectra, _ = _spectra("ch4")
    assert spectra.ir_species == ("T2", "E", "A1", "T2") and spectra.n_rigid == 6
    ir_allowed = spectra.ir.intensities > 1e-8 * spectra.ir.intensities.max()
    assert ir_allowed.tolist() == [True, False, False, True]  # Td: only T2 is IR active
    figure = plot_molecule_spectra(spectra, title="CH4")
    texts = [t.get_text() for axes in figure.axes for t in axes.texts]
    assert sum("$T_{2}$" in t for t in texts) >= 2 and any("$A_{1}$" in t for t in texts)
    assert any("$E$" in t for t in texts)
    assert figure.axes[0].get_xlim()[0] >= 0.0  # no rigid-mode bar at zero: nothing drawn below 0
    labels = [axes.get_xlabel() for axes in figure.axes]
    assert "wavenumber (cm$^{-1}$)" in labels
    path = save_figure(figure, tmp_path / "ch4.png")
    assert path.stat().st_size > 10_000


def test_a_molecule_without_polar_bonds_says_so_instead_of_drawing() -> None:
    from types import SimpleNamespace

    empty = SimpleNamespace(ir=None, ir_profile=None, ir_species=(), ir_model="no IR model: no polar bond",
                            raman=None, raman_profile=None, raman_species=(), raman_model="no Raman model: no bonds",
                            n_rigid=0)
    figure = plot_molecule_spectra(empty)
    assert [t.get_text() for t in figure.axes[0].texts] == ["no IR model: no polar bond"]


def test_species_text() -> None:
    assert species_text("Sigma_g+") == "$\\Sigma_{g}^{+}$"
    assert species_text("A1g") == "$A_{1g}$" and species_text("E''") == "$E$''" and species_text("") == ""


def test_b_factors_share_one_axis_linear_or_log_as_the_data_need() -> None:
    # issue 48: a fitted curve near 0.1 Å2 beside one residue at 53 Å2 read as a flat line
    labels = [f"A:GLY{i}:CA" for i in range(1, 11)]
    experimental = np.linspace(5.0, 20.0, 10)
    fitted = experimental[::-1].copy()  # within a decade: a linear axis holding every value
    figure = plot_b_factors(labels, experimental, fitted, 0.9, scale=2.0, title="t")
    profile, scatter = figure.axes
    assert len(figure.axes) == 2  # the profile and the scatter: no twin axis
    assert profile.get_ylabel() == "B-factor (Å²)" and profile.get_yscale() == "linear"
    assert profile.get_ylim()[0] == 0.0 and profile.get_ylim()[1] >= 20.0
    assert scatter.get_xlim() == scatter.get_ylim()  # the diagonal is the diagonal
    legend = [t.get_text() for t in profile.get_legend().get_texts()]
    assert any("r = 0.900" in t and "x 2" in t and "ProDy" in t for t in legend)
    tail = np.full(10, 0.1)
    tail[-1] = 53.0  # a tail two decades above the rest: log axes, every point in view
    figure = plot_b_factors(labels, experimental, tail, 0.5, scale=1.8, method="least_squares")
    profile, scatter = figure.axes
    assert profile.get_yscale() == scatter.get_xscale() == scatter.get_yscale() == "log"
    assert profile.get_ylim()[0] < 0.1 and profile.get_ylim()[1] > 53.0 and "log" in profile.get_ylabel()
    assert any("least-squares" in t.get_text() for t in profile.get_legend().get_texts())
    assert b_factor_axis(experimental, fitted) == "linear" and b_factor_axis(experimental, tail) == "log"
    with pytest.raises(ValueError, match="two equal 1-D arrays"):
        plot_b_factors(labels, experimental, fitted[:5], 0.9)
    with pytest.raises(ValueError, match="method is 'median'"):
        plot_b_factors(labels, experimental, fitted, 0.9, method="median")


def test_cross_correlation_map_has_a_diverging_colour_bar() -> None:
    labels = [f"A:ALA{i}:CA" for i in range(1, 6)]
    C = np.eye(5) - 0.5 * (np.ones((5, 5)) - np.eye(5))
    figure = plot_cross_correlations(labels, C, n_modes=20, title="t")
    image = figure.axes[0].images[0]
    assert image.get_cmap().name == "RdBu_r" and image.get_clim() == (-1.0, 1.0)
    bar = figure.axes[1]
    assert "dimensionless" in bar.get_ylabel()
    with pytest.raises(ValueError, match=r"correlations must be \(5, 5\)"):
        plot_cross_correlations(labels, C[:4, :4])
