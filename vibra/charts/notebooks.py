"""Charts the teaching notebooks need and no other chart module draws.

`plot_cost_vs_error` puts solver runs on a time-versus-error plane (the speed/accuracy
trade); `plot_step_errors` draws a finite-difference error against the step, with the
power laws it should follow; `plot_time_series` draws a few signals against time (a
transient settling into its steady state). All return a `matplotlib.figure.Figure` drawn with vibra's
shared style; save it with `vibra.charts.save_figure`.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import ArrayLike

from vibra._core import validate as _validate
from vibra.charts._style import new_figure

__all__ = ["plot_cost_vs_error", "plot_step_errors", "plot_time_series"]


def _labels(labels: Sequence[str], n: int, name: str) -> list[str]:
    if isinstance(labels, str) or not isinstance(labels, Sequence):
        raise TypeError(f"{name} must be a sequence of str, got {type(labels).__name__}")
    if len(labels) != n:
        raise ValueError(f"{name} has {len(labels)} entries; expected {n}, one per row of data")
    for i, label in enumerate(labels):
        if not isinstance(label, str):
            raise TypeError(f"{name}[{i}] must be a str, got {type(label).__name__}")
    return list(labels)


def _positive_values(values: ArrayLike, name: str, ndim: int) -> np.ndarray:
    """`values` as a finite float array of `ndim` dimensions, every entry > 0 (a log axis)."""
    array = _validate.real_array(values, name, ndim=ndim)
    _validate.positive(array, name, "value on a log axis")
    return array


def plot_cost_vs_error(
    labels: Sequence[str],
    seconds: ArrayLike,
    errors: ArrayLike,
    *,
    groups: Sequence[str] | None = None,
    error_label: str = "relative error (dimensionless)",
    title: str | None = None,
) -> Figure:
    """Each run as a labelled point: wall time (log x) against its error (log y).

    Parameters
    ----------
    labels : (n,) sequence of str
        One label per run (e.g. the solver path), written beside its point.
    seconds : (n,) array_like
        Wall time of each run, in s, > 0.
    errors : (n,) array_like
        Error of each run, > 0 (dimensionless when relative; say so in `error_label`).
    groups : (n,) sequence of str, optional
        A group per run (e.g. the problem size); points of one group share a colour and
        the legend lists the groups.
    error_label : str
        Label of the error axis, with its unit.
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    TypeError
        labels or groups not a sequence of str.
    ValueError
        seconds or errors not 1-D, of another length than labels, or not positive and finite.
    """
    times = _positive_values(seconds, "seconds", 1)
    names = _labels(labels, times.shape[0], "labels")
    errs = _positive_values(errors, "errors", 1)
    if errs.shape != times.shape:
        raise ValueError(f"errors has {errs.shape[0]} values; expected {times.shape[0]}, one per run")
    group_names = _labels(groups, times.shape[0], "groups") if groups is not None else [""] * times.shape[0]
    fig, ax = new_figure()
    for group in dict.fromkeys(group_names):
        chosen = [i for i, g in enumerate(group_names) if g == group]
        ax.loglog(times[chosen], errs[chosen], "o", ms=8, label=group or None)
        for i in chosen:
            ax.annotate(names[i], (times[i], errs[i]), textcoords="offset points", xytext=(7, 4), fontsize=10)
    ax.set_xlabel("wall time (s)")
    ax.set_ylabel(error_label)
    if any(group_names):
        ax.legend(loc="best")
    low, high = errs.min(), errs.max()
    ax.set_ylim(low / 10.0, high * 10.0)
    left, right = times.min(), times.max()
    ax.set_xlim(left / 3.0, right * 6.0)  # room on the right for the labels
    ax.set_title(title if title is not None else "Speed against accuracy")
    return fig


def plot_step_errors(
    steps: ArrayLike,
    errors: ArrayLike,
    labels: Sequence[str],
    *,
    estimates: ArrayLike | None = None,
    orders: Sequence[float] | None = None,
    step_label: str = "step h (Angstrom)",
    error_label: str = "relative error (dimensionless)",
    title: str | None = None,
) -> Figure:
    """Error of a step-size method (finite differences) against the step, log-log.

    Parameters
    ----------
    steps : (n_steps,) array_like
        Step sizes, > 0, in the unit named by `step_label`.
    errors : (n_curves, n_steps) array_like
        Measured errors, > 0, one row per method.
    labels : (n_curves,) sequence of str
        Method names (e.g. "2-point").
    estimates : (n_curves, n_steps) array_like, optional
        The methods' own error estimates, drawn dashed in the same colours.
    orders : (n_curves,) sequence of float, optional
        Expected truncation orders p: a dotted guide C h^p through each curve's
        largest-step point.
    step_label, error_label : str
        Axis labels, with units.
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    TypeError
        labels not a sequence of str.
    ValueError
        Shapes that do not match, or values not positive and finite.
    """
    h = _positive_values(steps, "steps", 1)
    err = _positive_values(errors, "errors", 2)
    if err.shape[1] != h.shape[0]:
        raise ValueError(f"errors has {err.shape[1]} columns; expected {h.shape[0]}, one per step")
    names = _labels(labels, err.shape[0], "labels")
    est = None
    if estimates is not None:
        est = _positive_values(estimates, "estimates", 2)
        if est.shape != err.shape:
            raise ValueError(f"estimates has shape {est.shape}; expected {err.shape}, the shape of errors")
    if orders is not None:
        p = _validate.real_array(orders, "orders", ndim=1)
        if p.shape[0] != err.shape[0]:
            raise ValueError(f"orders has {p.shape[0]} values; expected {err.shape[0]}, one per curve")
    fig, ax = new_figure()
    order = np.argsort(h)
    for row, name in enumerate(names):
        line, = ax.loglog(h[order], err[row, order], "o-", label=f"{name}: measured")
        if est is not None:
            ax.loglog(h[order], est[row, order], "--", color=line.get_color(), lw=1.2,
                      label=f"{name}: own estimate")
        if orders is not None:
            last = order[-1]
            guide = err[row, last] * (h[order] / h[last]) ** p[row]
            ax.loglog(h[order], guide, ":", color=line.get_color(), lw=1.2, label=f"$\\propto h^{{{p[row]:g}}}$")
    ax.set_xlabel(step_label)
    ax.set_ylabel(error_label)
    ax.set_ylim(err.min() / 10.0, err.max() * 10.0)
    ax.legend(loc="best", ncols=2)
    ax.set_title(title if title is not None else "Finite differences: error against step")
    return fig


def plot_time_series(
    t: ArrayLike,
    series: ArrayLike,
    labels: Sequence[str],
    *,
    styles: Sequence[str] | None = None,
    time_label: str,
    value_label: str,
    title: str | None = None,
) -> Figure:
    """Several signals against the same times, one line each.

    Parameters
    ----------
    t : (n_t,) array_like
        Times, in the unit named by `time_label`.
    series : (n_series, n_t) array_like
        The signals, in the unit named by `value_label`.
    labels : (n_series,) sequence of str
        Legend entries.
    styles : (n_series,) sequence of str, optional
        matplotlib format strings (e.g. "-", "--", ":"); solid lines by default.
    time_label, value_label : str
        Axis labels with their units, e.g. ``"time t (s)"``; required, as the signals
        carry no unit of their own.
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    TypeError
        labels or styles not a sequence of str; time_label or value_label not a str.
    ValueError
        series not 2-D, or with another number of columns than t has times.
    """
    times = _validate.real_array(t, "t", ndim=1)
    values = _validate.real_array(series, "series", ndim=2)
    if values.shape[1] != times.shape[0]:
        raise ValueError(f"series has {values.shape[1]} columns; expected {times.shape[0]}, one per time")
    names = _labels(labels, values.shape[0], "labels")
    formats = _labels(styles, values.shape[0], "styles") if styles is not None else ["-"] * values.shape[0]
    for label, name in ((time_label, "time_label"), (value_label, "value_label")):
        if not isinstance(label, str):
            raise TypeError(f"{name} must be a str (an axis label with its unit), got {type(label).__name__}")
    fig, ax = new_figure(figsize=(10.0, 4.6))
    for row, (name, fmt) in enumerate(zip(names, formats)):
        ax.plot(times, values[row], fmt, label=name)
    ax.set_xlabel(time_label)
    ax.set_ylabel(value_label)
    ax.legend(loc="best")
    if title is not None:
        ax.set_title(title)
    return fig
