"""The charts of the modes plan, one `ChartStep` each: when a scene wants it, what it draws, and the
function that draws it (scene -> step ``chart-<key>`` -> ``<scene>_<key>.png`` on the report page).

`CHART_STEPS` is read three times, so a chart is declared here once: `vibra.pipeline.plan.model.modes_plan`
appends a ``chart-<key>`` step for every chart the scene wants, in this table's order, after
its analyses and renders; `vibra.pipeline.plan.steps.STEPS` runs it; `CHART_STEP_KEYS` names the
scene key a failing chart is reported at. A chart's ``[draw]`` key, and the scene kinds it
applies to, are its `vibra.pipeline.scene.specs.DrawSpec` field (``chart_key``), which the
scene schema reads. Adding a chart: its drawing function in ``vibra/charts/<topic>.py``, its
``[draw]`` key in ``DrawSpec``, its `ChartStep` here.

A chart's `run(scene, context)` draws what the analysis steps left in `context` (the execution's
state, `vibra.pipeline.plan.steps`) and saves it with ``context.save_chart(figure, key, caption)``;
it returns its accuracy figure in words, or None.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from vibra._core.text import counted
from vibra.pipeline.plan.analysis import LINE_WIDTH_CM1, molecule_spectra, molecule_structure
from vibra.pipeline.plan.electronic import electronic_spectra, experiment_comparison, scene_engine
from vibra.pipeline.scene import Scene
from vibra.sources import cite

__all__ = ["ChartStep", "CHART_STEPS", "CHART_STEP_KEYS", "chart_steps"]


@dataclass(frozen=True)
class ChartStep:
    """One chart of the modes plan.

    Attributes
    ----------
    key : str
        The step is ``chart-<key>``; the ``[draw]`` key of that name asks for it unless `wanted`
        says otherwise.
    what : str or callable
        What it draws, in words, for the plan (``what(scene) -> str`` when it depends on the scene).
    run : callable
        ``run(scene, context) -> str or None``: draws, saves with ``context.save_chart``, returns
        its accuracy figure in words.
    wanted : callable or None
        ``wanted(scene) -> bool`` for a chart no ``[draw]`` key of its own asks for (None: the key).
    scene_key : str or None
        The scene key a failing chart is reported at (None: ``draw.<key>``; ``""``: none, the scene).
    """

    key: str
    what: str | Callable[[Scene], str]
    run: Callable[[Scene, Any], str | None]
    wanted: Callable[[Scene], bool] | None = None
    scene_key: str | None = None

    @property
    def step(self) -> str:
        return f"chart-{self.key}"

    def describe(self, scene: Scene) -> str:
        return self.what if isinstance(self.what, str) else self.what(scene)

    def wanted_by(self, scene: Scene) -> bool:
        return bool(self.wanted(scene) if self.wanted is not None else getattr(scene.draw, self.key))


def _spectrum(scene: Scene, context: Any) -> str | None:
    if scene.kind == "molecule" and context.modes.shapes is not None:
        from vibra.charts.spectra import plot_molecule_spectra

        structure = context.structure or molecule_structure(scene, context.system)
        if context.electronic is not None:  # an engine's dipole and polarisability derivatives
            spectra = electronic_spectra(context.electronic, line_width=LINE_WIDTH_CM1)
        else:
            spectra = molecule_spectra(context.system, context.modes, structure.symbols, structure.bonds,
                                       context.symmetry)
        figure = plot_molecule_spectra(spectra, title=scene.title)
        context.save_chart(figure, "spectrum",
                           f"{scene.title}: IR and Raman spectra, Lorentzian lines (FWHM {LINE_WIDTH_CM1:g} cm^-1) "
                           f"with the lines beneath, species on the peaks; {spectra.ir_model}; {spectra.raman_model}")
        return None
    from vibra.charts.modes import spectrum_figure

    figure, caption = spectrum_figure(scene, context.modes)
    context.save_chart(figure, "spectrum", caption)
    return None


def _experiment(scene: Scene, context: Any) -> str | None:
    """The computed (scaled) against observed chart, where the molecule has observed values."""
    from vibra.charts.experiment import plot_experiment_comparison

    comparison = experiment_comparison(context.electronic)
    if comparison is None:
        return "no observed fundamentals bundled for this molecule"
    figure = plot_experiment_comparison(comparison, title=scene.title)
    intensities = " and IR intensities" if comparison.intensity_source else ""
    context.save_chart(figure, "experiment",
                       f"{scene.title}: {comparison.level} fundamentals, harmonic x {comparison.scale_factor:g}, "
                       f"against the observed gas-phase fundamentals{intensities}: computed up, observed down, "
                       f"deviations in the table (largest {comparison.largest_deviation_percent():.1f} %)")
    return f"largest deviation {comparison.largest_deviation_percent():.1f} % (scale {comparison.scale_factor:g})"


def _dispersion(scene: Scene, context: Any) -> str | None:
    from vibra.charts import chains as chain_charts

    figure = chain_charts.plot_dispersion(context.dispersion, title=f"{scene.title}: dispersion")
    context.save_chart(figure, "dispersion",
                       f"{scene.title}: dispersion relation omega(q) over the Brillouin zone, with the "
                       f"{context.modes.n_modes} modes of the finite chain on top")
    return None


def _response(scene: Scene, context: Any) -> str | None:
    from vibra.charts import response as response_charts

    if scene.kind == "oscillator":
        oscillators = context.system
        figure = response_charts.plot_oscillator_response(list(oscillators), context.response, units=scene.units)
        gammas = ", ".join(f"{o.gamma:g}" for o in oscillators)
        caption = (f"{scene.title}: amplitude and phase against omega ({cite('003')}, eqs. 120-123) "
                   f"for gamma = {gammas}, omega0 = {oscillators[0].w0:g}")
    else:
        r = scene.compute.response
        assert r is not None  # the scene schema refuses draw.response without a response table
        natural = None if context.modes is None else np.asarray(context.modes.omega)
        figure = response_charts.plot_frf(context.response, r.force_site, natural_frequencies=natural,
                                          title=f"{scene.title}: response of dof {r.force_site}")
        caption = (f"{scene.title}: receptance at the driven dof {r.force_site} for a unit force "
                   f"({context.response.solver} solver, C = {r.alpha:g} M + {r.beta:g} K)"
                   + (", resonances marked" if natural is not None else ""))
    context.save_chart(figure, "response", caption)
    return None


def _bfactors(scene: Scene, context: Any) -> str | None:
    from vibra.charts.networks import b_factor_axis, plot_b_factors

    network = context.network
    fit = network.fit
    if fit is None:  # the file's B column is flat: nothing to fit, the raw prediction is drawn
        fitted, correlation, scale, method = network.predicted, network.correlation, None, "sum"
        how = "unscaled (kT/gamma = 1: the file's B-factors are all equal, nothing to fit)"
    else:
        fitted, correlation, scale, method = fit.predicted, fit.correlation, fit.scale, fit.method
        how = ("scaled as ProDy's calcTempFactors does, to the crystallographic sum" if method == "sum"
               else "scaled by least squares onto the crystallographic values") + f" (x {fit.scale:.3g})"
    figure = plot_b_factors(network.labels, network.experimental, fitted, correlation, scale=scale,
                            method=method, title=scene.title)
    axis = b_factor_axis(network.experimental, fitted)
    n_rigid = int(np.sum(context.modes.zero_modes(1e-6)))
    used = (f"all {network.n_modes - n_rigid}" if network.n_modes == context.system.n_dof else
            f"the {network.n_modes - n_rigid} lowest") + f" non-rigid modes ({counted(n_rigid, 'rigid-body mode')} left out)"
    context.save_chart(figure, "bfactors",
                       f"{scene.title}: B-factors per residue, crystallographic and predicted from {used}, "
                       f"{how}, on one {axis} axis; Pearson correlation r = {correlation:.3f}")
    return None


def _correlations(scene: Scene, context: Any) -> str | None:
    from vibra.charts.networks import plot_cross_correlations

    network = context.network
    figure = plot_cross_correlations(network.labels, network.cross_correlations, n_modes=network.n_modes,
                                     title=scene.title)
    context.save_chart(figure, "correlations",
                       f"{scene.title}: residue cross-correlations C_ij from the {network.n_modes} lowest modes "
                       "(rigid ones left out): red moves together, blue in opposition")
    return None


def _convergence(scene: Scene, context: Any) -> str | None:
    from vibra.charts import chains as chain_charts

    figure = chain_charts.plot_convergence(context.continuum)
    c = scene.compute.continuum
    assert c is not None  # the scene schema refuses draw.convergence without a continuum table
    context.save_chart(figure, "convergence",
                       f"Relative error of modes {list(c.modes)} of a {c.ends}-end chain against the wave equation, "
                       f"versus N at fixed length ({cite('003')}, eqs. 162-165)")
    return None


def _spectrum_what(scene: Scene) -> str:
    return ("IR and Raman spectra (model intensities, Lorentzian lines)" if scene.kind == "molecule"
            else "stick spectrum of the frequencies")


#: The modes plan's charts, in the order the plan draws them.
CHART_STEPS: tuple[ChartStep, ...] = (
    ChartStep("spectrum", _spectrum_what, _spectrum),
    ChartStep("experiment", "computed (scaled) against observed fundamentals and IR intensities, where the "
              "molecule has observed values bundled", _experiment,
              wanted=lambda scene: scene.draw.spectrum and scene_engine(scene) is not None, scene_key="draw.spectrum"),
    ChartStep("dispersion", "dispersion relation with the chain's modes", _dispersion),
    ChartStep("response", "response amplitude and phase against frequency", _response),
    ChartStep("bfactors", "fitted against crystallographic B-factors per residue, on one axis", _bfactors),
    ChartStep("correlations", "residue cross-correlation map of the computed modes", _correlations,
              wanted=lambda scene: scene.kind == "network", scene_key=""),
    ChartStep("convergence", "error of the chain's modes against N (log-log)", _convergence),
)

#: step name -> the scene key a failing chart is reported at.
CHART_STEP_KEYS = {chart.step: f"draw.{chart.key}" if chart.scene_key is None else chart.scene_key
                   for chart in CHART_STEPS}


def chart_steps(scene: Scene) -> list[tuple[str, str]]:
    """``(step name, what)`` of every chart `scene` wants, in `CHART_STEPS` order."""
    return [(chart.step, chart.describe(scene)) for chart in CHART_STEPS if chart.wanted_by(scene)]
