"""The chart of computed against observed fundamentals (vibra.charts.experiment): its text stays
legible whatever the molecule. Four fundamentals (CH4) once put the sources beneath the table on
its last row; CH4's nu1 and nu3, 102 cm^-1 apart, once printed their deviations on top of each
other; a molecule without sourced intensities (CO2) once left the observed half of the chart empty.

Truth: the drawn geometry itself (window extents of the rendered text, table and axes), against
the requirement that nothing a reader must read overlaps.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from vibra.molecules import EXPERIMENTAL
from vibra.spectra import compare_with_experiment
from tests.helpers.ir_lines import ir_lines


def _comparison(formula: str) -> Any:
    """RHF/6-31G*-like lines (harmonic, so x 0.885 lands them near the observed ones)."""
    lines = {"CH4": ([3300, 1700, 1700, 3400, 3400, 3400, 1450, 1450, 1450], [0, 0, 0, 20, 20, 20, 12, 12, 12],
                     ["A1", "E", "E", "T2", "T2", "T2", "T2", "T2", "T2"]),
             "CO2": ([751, 751, 1518, 2590], [69.5, 69.5, 0, 988.9], ["Pi_u", "Pi_u", "Sigma_g+", "Sigma_u+"]),
             "H2O": ([1826, 4056, 4174], [110.1, 18.3, 59.7], ["A1", "A1", "B2"])}[formula]
    wavenumbers, km_per_mol, species = lines
    spectrum = ir_lines(wavenumbers, km_per_mol, "RHF/6-31G*")
    return compare_with_experiment(spectrum, species, EXPERIMENTAL[formula])


def _drawn(formula: str) -> tuple[Any, Any]:
    from vibra.charts.experiment import plot_experiment_comparison

    figure = plot_experiment_comparison(_comparison(formula), title=formula)
    figure.canvas.draw()
    return figure, figure.canvas.get_renderer()


@pytest.mark.parametrize("formula", ["H2O", "CO2", "CH4"])
def test_sources_lie_beneath_the_table_inside_the_figure(formula: str) -> None:
    figure, renderer = _drawn(formula)
    table_axes = figure.axes[1]
    table = table_axes.tables[0]
    sources = [text for text in (*figure.texts, *table_axes.texts)
               if text.get_text().startswith("observed wavenumbers")]
    assert len(sources) == 1
    table_box = table.get_window_extent(renderer)
    source_box = sources[0].get_window_extent(renderer)
    assert source_box.y1 <= table_box.y0, (source_box, table_box)  # below the last row, not on it
    assert len(table.get_celld()) == (len(_comparison(formula)) + 1) * 9  # every row drawn, header included
    for box in (table_box, source_box):
        assert 0 <= box.x0 and box.x1 <= figure.bbox.x1 and 0 <= box.y0 and box.y1 <= figure.bbox.y1


@pytest.mark.parametrize("formula", ["H2O", "CO2", "CH4"])
def test_labels_do_not_overlap_and_stay_in_the_chart(formula: str) -> None:
    figure, renderer = _drawn(formula)
    axes = figure.axes[0]
    labels = [text.get_window_extent(renderer) for text in axes.texts]
    assert len(labels) == 2 * len(_comparison(formula))  # a name above each computed line, a deviation below
    for i, box in enumerate(labels):
        assert axes.bbox.x0 <= box.x0 and box.x1 <= axes.bbox.x1 and axes.bbox.y0 <= box.y0 and box.y1 <= axes.bbox.y1
        for other in labels[i + 1:]:
            assert not box.overlaps(other), (box, other)


def test_chart_without_observed_intensities_keeps_its_space_for_the_computed_lines() -> None:
    # CO2 has no sourced intensities: the observed side holds short position marks only, so most
    # of the height goes to the computed lines (more than twice the observed side's).
    figure, _ = _drawn("CO2")
    low, high = figure.axes[0].get_ylim()
    assert high > 2.0 * -low > 0
