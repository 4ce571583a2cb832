"""Charts of `vibra.dynamics` runs: energy per normal mode, energies and thermostat variables, and
position histograms against the Boltzmann distribution.

Each function draws what the run (a `vibra.dynamics.Trajectory`, duck-typed) or the plan step
computed and returns the figure; save it with `vibra.charts.save_figure`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Sequence

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import ArrayLike

from vibra.charts._style import new_figure

if TYPE_CHECKING:
    from vibra.dynamics.trajectory import Trajectory
    from vibra.units import UnitSystem

__all__ = ["plot_mode_energies", "plot_energies", "plot_position_histograms"]


def _time_label(units: Any) -> str:
    return "time t (s)" if getattr(units, "time_s", None) == 1.0 else (
        "time t (time units)" if getattr(units, "time_s", None) is None else "time t (time units of the scene)")


def _energy_unit(units: Any) -> str:
    name = getattr(units, "energy", "")
    return name if name and getattr(units, "time_s", None) is not None else "energy units"


def plot_mode_energies(t: ArrayLike, energies: ArrayLike, *, total: float, units: UnitSystem | None = None,
                       title: str = "") -> Figure:
    """Energy of each normal mode against time, as a share of the total energy (left axis) and in the
    energy unit (right axis).

    Parameters
    ----------
    t : (n_records,) array_like
        Times, in the system's time unit.
    energies : (n_records, n_modes) array_like
        E_k of the lowest modes (`Trajectory.mode_energies`), in the energy unit; mode k + 1 in
        column k.
    total : float
        The total energy the shares refer to, in the energy unit.
    """
    t = np.asarray(t, dtype=float)
    energies = np.asarray(energies, dtype=float)
    figure, axes = new_figure(figsize=(10.0, 5.0))
    scale = total if total > 0 else 1.0
    for k in range(energies.shape[1]):
        axes.plot(t, energies[:, k] / scale, linewidth=1.4, label=f"mode {k + 1}")
    axes.set_xlabel(_time_label(units))
    axes.set_ylabel("E_k / E (share of the total energy)")
    axes.set_xlim(float(t[0]), float(t[-1]))
    axes.set_ylim(0.0, 1.05 * max(1.0, float(energies.max(initial=0.0)) / scale))
    right = axes.secondary_yaxis("right", functions=(lambda y: y * scale, lambda e: e / scale))
    right.set_ylabel(f"E_k ({_energy_unit(units)})")
    figure.legend(loc="outside right upper")
    axes.set_title(f"{title}{chr(10) if title else ''}energy per normal mode (E = {total:.4g} {_energy_unit(units)})")
    return figure


def plot_energies(run: Trajectory, label: str | None, *, reference: ArrayLike | None = None,
                  target_kinetic: float | None = None, title: str = "") -> Figure:
    """Kinetic, potential and conserved energy against time (top) and one thermostat variable (bottom).

    Parameters
    ----------
    run : Trajectory
        The run drawn.
    label : str or None
        The thermostat variable drawn below (``"mu"``, ``"xi1"``); None: energies only.
    reference : (n_records,) array_like, optional
        A closed form of that variable, drawn dashed over it.
    target_kinetic : float, optional
        The kinetic energy a constraint holds (drawn as a horizontal line).
    """
    t = np.asarray(run.t, dtype=float)
    rows = 2 if label is not None else 1
    figure, axes = new_figure(rows, 1, figsize=(10.0, 3.2 * rows + 1.0), sharex=True, squeeze=False)
    top = axes[0, 0]
    unit = _energy_unit(run.units)
    if np.all(np.isfinite(run.potential)):
        top.plot(t, run.potential, linewidth=1.2, color="C1", label="potential")
    if label == "mu":  # the constraint holds the kinetic energy: it is what is conserved
        top.plot(t, run.kinetic, linewidth=2.0, color="C0", label="kinetic (held by\nthe constraint)")
    else:
        top.plot(t, run.kinetic, linewidth=1.2, color="C0", label="kinetic")
        top.plot(t, run.conserved, linewidth=1.8, color="k", label="extended energy\n(conserved)" if label == "xi1"
                 else "kinetic + potential\n(conserved)")
    if target_kinetic is not None:
        top.axhline(target_kinetic, color="C3", linestyle=":", linewidth=1.4, label="n_dof k_B T / 2")
    top.set_ylabel(f"energy ({unit})")
    top.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0))
    top.set_title(title)
    if label is not None:
        bottom = axes[1, 0]
        values = np.asarray(run.state(label), dtype=float)
        bottom.plot(t, values, linewidth=1.2, color="C2", label=f"{label} (the run)")
        if reference is not None:
            bottom.plot(t, np.asarray(reference, dtype=float), linestyle="--", linewidth=1.0, color="k",
                        label=f"{label}, closed form")
        bottom.set_ylabel(f"{label} (1 / time unit)")
        bottom.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0))
    axes[-1, 0].set_xlabel(_time_label(run.units))
    return figure


def plot_position_histograms(samples: Sequence[ArrayLike], labels: Sequence[str], sigma: float,
                             distances: Sequence[float], *, bins: int = 60, units: UnitSystem | None = None,
                             title: str = "") -> Figure:
    """Histogram of one coordinate's positions, one panel per run, against the Boltzmann Gaussian.

    Parameters
    ----------
    samples : sequence of (n_samples,) array_like
        The positions of each run, in the length unit.
    labels : sequence of str
        One label per run.
    sigma : float
        Standard deviation of the Boltzmann distribution, in the length unit.
    distances : sequence of float
        Each run's Kolmogorov-Smirnov distance D to that Gaussian.
    """
    n = len(samples)
    figure, axes = new_figure(1, n, figsize=(5.5 * n, 4.6), squeeze=False, sharey=True)
    reach = 4.0 * sigma
    for i, (values, label, distance) in enumerate(zip(samples, labels, distances)):
        values = np.asarray(values, dtype=float)
        panel = axes[0, i]
        low = min(-reach, float(values.min(initial=0.0)))
        high = max(reach, float(values.max(initial=0.0)))
        panel.hist(values, bins=bins, range=(low, high), density=True, color="C0", alpha=0.6, label="the run")
        x = np.linspace(low, high, 400)
        panel.plot(x, np.exp(-0.5 * (x / sigma) ** 2) / (sigma * np.sqrt(2 * np.pi)), color="k", linewidth=1.6,
                   label="Boltzmann")
        length = getattr(units, "length", "") if getattr(units, "time_s", None) is not None else "length units"
        panel.set_xlabel(f"position x ({length})")
        panel.set_title(f"{label}\nKolmogorov-Smirnov D = {distance:.3f}")
        panel.legend(loc="upper right")
    axes[0, 0].set_ylabel("probability density")
    figure.suptitle(f"{title}{chr(10) if title else ''}positions against the Boltzmann distribution "
                    f"(sigma = {sigma:.4g})")
    return figure
