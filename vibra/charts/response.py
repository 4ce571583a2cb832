"""Charts of forced, damped response: the seed's figure 7, a chain's FRF, Rayleigh damping.

Each function takes result objects or arrays and returns a matplotlib Figure; save it with
`vibra.charts.save_figure`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.sparse as sp
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra.charts._style import new_figure
from vibra.modes import normal_modes
from vibra.response import FrequencyResponse, Oscillator, rayleigh_damping_ratio
from vibra.units import DIMENSIONLESS, UnitSystem, unit_system

__all__ = ["plot_oscillator_response", "plot_frf", "plot_rayleigh_damping"]


def plot_oscillator_response(
    oscillators: Sequence[Oscillator] | None = None,
    omegas: ArrayLike | None = None,
    *,
    F0: float = 1.0,
    units: str | UnitSystem = DIMENSIONLESS,
) -> Figure:
    """Amplitude |u0(w)| (eq. 121) and phase phi(w) (eq. 123) against w: the seed's figure 7.

    Parameters
    ----------
    oscillators : sequence of Oscillator, optional
        One curve each. Default: w0 = 1, m = 1 and gamma = 1/2, 1, 2, 4 (figure 7).
    omegas : (n,) array_like, optional
        Driving angular frequencies >= 0, in rad per time unit; default 0 to 3 w0.
    F0 : float
        Force amplitude |F0|, in force units (figure 7: |F0|/m = 1).
    units : str or UnitSystem
        Unit system of the oscillators, named on the axes (default dimensionless, as in
        figure 7).

    Returns
    -------
    Figure
        Left: amplitude in length units; right: phase in units of pi, from 0 to -pi. The
        amplitude peak (at `Oscillator.resonance_frequency`) is marked where there is one.
    """
    if oscillators is None:
        oscillators = [Oscillator(w0=1.0, gamma=g) for g in (0.5, 1.0, 2.0, 4.0)]
    oscillators = list(oscillators)
    if not oscillators:
        raise ValueError("oscillators is empty; give at least one Oscillator")
    for i, oscillator in enumerate(oscillators):
        if not isinstance(oscillator, Oscillator):
            raise TypeError(f"oscillators[{i}] must be an Oscillator, got {type(oscillator).__name__}")
    top = 3.0 * max(o.w0 for o in oscillators)
    w = np.linspace(0.0, top, 601) if omegas is None else _validate.real_array(omegas, "omegas", ndim=1)
    fig, (left, right) = new_figure(1, 2, figsize=(11.0, 4.6))
    for oscillator in oscillators:
        label = f"$\\gamma$ = {oscillator.gamma:g}"
        line, = left.plot(w, oscillator.amplitude(w, F0), label=label)
        peak = oscillator.resonance_frequency()
        if peak is not None and w.min() <= peak <= w.max():
            left.plot([peak], [oscillator.amplitude(peak, F0)], "o", color=line.get_color(), ms=5)
        right.plot(w, oscillator.phase(w) / np.pi, label=label, color=line.get_color())
    w0 = oscillators[0].w0
    unit = unit_system(units)
    length = "length" if unit.time_s is None else unit.length
    left.set_xlabel(f"driving angular frequency $\\omega$ ({unit.omega})")
    left.set_ylabel(f"amplitude $|u_0(\\omega)|$ ({length})")
    left.set_title(f"amplitude (eq. 121), $\\omega_0$ = {w0:g}, $|F_0|/m$ = {F0 / oscillators[0].m:g}")
    left.set_ylim(bottom=0.0)
    left.legend(title="dots: resonance peak")
    right.set_xlabel(f"driving angular frequency $\\omega$ ({unit.omega})")
    right.set_ylabel(r"phase $\phi(\omega)$ ($\pi$ rad)")
    right.set_title("phase lag of u behind F (eq. 123)")
    right.set_ylim(-1.05, 0.05)
    right.axhline(-0.5, color="0.5", lw=0.8, ls="--")
    right.legend()
    return fig


def plot_frf(
    result: FrequencyResponse,
    dof: int,
    *,
    natural_frequencies: ArrayLike | None = None,
    K: ArrayLike | sp.spmatrix | None = None,
    M: ArrayLike | None = None,
    reference: FrequencyResponse | None = None,
    title: str | None = None,
) -> Figure:
    """Magnitude (log scale) and phase of one dof's response against w, natural frequencies marked.

    Every natural frequency within the plotted band gets a vertical line on both panels, for
    every method: those given, else the undamped ones of (K, M) when given, else those the
    result carries (modal: the kept modes; state space: |Im s| of the complex modes). A direct
    result carries none, so it needs K and M or `natural_frequencies`.

    Parameters
    ----------
    result : FrequencyResponse
        The response to draw.
    dof : int
        Which degree of freedom.
    natural_frequencies : (n,) array_like, optional
        Angular frequencies to mark, in rad per time unit of `result.units`; an empty
        sequence marks none.
    K : (n_dof, n_dof) array_like or scipy.sparse matrix, optional
        Stiffness of the system the response belongs to, with `M`: its undamped natural
        frequencies within the band (`vibra.normal_modes(K, M, band=...)`, in the result's
        units) are marked. Not for a gyroscopic result, whose resonances K and M miss.
    M : (n_dof,) or (n_dof, n_dof) array_like, optional
        Masses of that system, with `K`.
    reference : FrequencyResponse, optional
        A second response (e.g. the direct solve) drawn dashed for comparison.
    title : str, optional
        Title of the magnitude panel (default "frequency response of dof <dof>").

    Returns
    -------
    Figure
        Top: |x_dof(w)| per unit force (the receptance, in the unit system's
        `receptance` unit: m/N in SI) on a log scale; bottom: phase in units of pi. The
        x axis is w in `result.units` (rad/s in SI, rad per time unit when dimensionless).

    Raises
    ------
    TypeError
        `result` not a FrequencyResponse.
    ValueError
        `dof` out of range; only one of K and M; K and M not matching the result's dofs, or
        given for a gyroscopic result; no natural frequencies at all (a direct result
        without K and M or `natural_frequencies`).
    """
    if not isinstance(result, FrequencyResponse):
        raise TypeError(f"result must be a FrequencyResponse, got {type(result).__name__}")
    index = _validate.count(dof, "dof", low=0, high=result.n_dof - 1)
    w = result.omegas
    marks = _natural_frequencies(result, natural_frequencies, K, M)
    unit = result.units.omega
    fig, (top, bottom) = new_figure(2, 1, sharex=True, figsize=(9.0, 6.5))
    label = _label(result)
    top.semilogy(w, np.abs(result.response[:, index]), label=label)
    bottom.plot(w, np.angle(result.response[:, index]) / np.pi)
    if reference is not None:
        top.semilogy(reference.omegas, np.abs(reference.response[:, index]), "--",
                     label=_label(reference))
        bottom.plot(reference.omegas, np.angle(reference.response[:, index]) / np.pi, "--")
    shown = [float(f) for f in marks if w.min() <= f <= w.max()]
    for i, frequency in enumerate(shown):
        for axis in (top, bottom):
            axis.axvline(frequency, color="tab:red", lw=0.7, alpha=0.5,
                         label="natural frequencies" if (i == 0 and axis is top) else None)
    top.set_ylabel(f"$|x_{{{index}}}(\\omega)|$ per unit force ({result.units.receptance})")
    top.set_title(title if title is not None else f"frequency response of dof {index}")
    top.legend(loc="best")
    bottom.set_xlabel(f"driving angular frequency $\\omega$ ({unit})")
    bottom.set_ylabel(r"phase ($\pi$ rad)")
    bottom.set_ylim(-1.05, 1.05)
    return fig


def _natural_frequencies(result: FrequencyResponse, given: ArrayLike | None, K: ArrayLike | sp.spmatrix | None,
                         M: ArrayLike | None) -> NDArray[np.float64]:
    """(n,) the angular frequencies `plot_frf` marks, in rad per time unit of the result."""
    if (K is None) != (M is None):
        raise ValueError("give K and M together (the undamped natural frequencies of both), or neither")
    if given is not None:
        return _validate.real_array(given, "natural_frequencies", ndim=1)
    if K is not None:
        if result.gyroscopic:
            raise ValueError("K and M give the undamped natural frequencies, which a gyroscopic result's resonances "
                             "are not; give natural_frequencies= (e.g. method='state_space' gives them)")
        if np.shape(K) != (result.n_dof, result.n_dof):  # type: ignore[arg-type]
            raise ValueError(f"K has shape {np.shape(K)}; expected ({result.n_dof}, {result.n_dof}) as the result's "
                             f"{result.n_dof} dofs")
        band = (float(result.omegas.min()), float(result.omegas.max()))
        return np.asarray(normal_modes(K, M, vectors=False, band=band, units=result.units).omega)
    if result.natural_frequencies is not None:
        return np.asarray(result.natural_frequencies, dtype=float)
    raise ValueError(f"result (method={result.method!r}) carries no natural frequencies; give K and M (its "
                     "undamped natural frequencies in the band are marked) or natural_frequencies= (() marks none)")


def plot_rayleigh_damping(
    a: float,
    b: float,
    omegas: ArrayLike,
    *,
    natural_frequencies: ArrayLike | None = None,
    units: str | UnitSystem = DIMENSIONLESS,
) -> Figure:
    """Damping ratio zeta(w) = a/(2w) + b w/2 of Rayleigh damping C = a M + b K.

    Parameters
    ----------
    a, b : float
        Rayleigh coefficients (1 / time unit, time unit).
    omegas : (n,) array_like
        Angular frequencies > 0, in rad per time unit.
    natural_frequencies : (n_modes,) array_like, optional
        Modes to mark on the curve (their damping ratios), in rad per time unit.
    units : str or UnitSystem
        Unit system of a, b and the frequencies, named on the x axis (default dimensionless:
        "rad / time unit"; "SI": rad/s).

    Returns
    -------
    Figure
        zeta against w, with the mass (a/2w) and stiffness (bw/2) parts.
    """
    w = _validate.real_array(omegas, "omegas", ndim=1)
    unit = unit_system(units)
    zeta = rayleigh_damping_ratio(w, a, b)
    fig, ax = new_figure()
    ax.plot(w, zeta, label=r"$\zeta(\omega) = a/2\omega + b\omega/2$")
    ax.plot(w, a / (2.0 * w), ":", label=rf"mass part $a/2\omega$, a = {a:g}")
    ax.plot(w, 0.5 * b * w, "--", label=rf"stiffness part $b\omega/2$, b = {b:g}")
    if natural_frequencies is not None:
        modes = _validate.real_array(natural_frequencies, "natural_frequencies", ndim=1)
        modes = modes[modes > 0]
        ax.plot(modes, rayleigh_damping_ratio(modes, a, b), "o", ms=4, label="normal modes")
    ax.set_xlabel(f"angular frequency $\\omega$ ({unit.omega})")
    ax.set_ylabel(r"damping ratio $\zeta$ (dimensionless)")
    ax.set_title("Rayleigh damping C = a M + b K")
    ax.set_ylim(0.0, min(float(np.max(zeta)), 4.0 * float(np.min(zeta)) + 0.05) * 1.1)
    ax.legend()
    return fig


def _label(result: FrequencyResponse) -> str:
    if result.method == "modal":
        extra = " + static correction" if result.residual_correction else ""
        return f"modal, {result.n_modes} modes{extra}"
    return f"{result.method.replace('_', ' ')} ({result.solver})"
