"""Chart of a sweep: every frequency of every point against the first swept key, branches as curves.

Takes a `vibra.pipeline.sweep.SweepTable` (duck-typed: charts draw what the higher stages computed and
import none of them) and returns the figure and a caption; save it with
`vibra.charts.save_figure`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, Sequence

from vibra.charts._style import new_figure

if TYPE_CHECKING:
    import numpy as np
    from matplotlib.figure import Figure
    from numpy.typing import NDArray

__all__ = ["sweep_figure", "key_label", "SweepTableLike"]

#: Unit of a swept scene key, by its last name and the scene's unit system.
_KEY_UNITS = {
    "SI": {"mass": "kg", "stiffness": "N/m", "spacing": "m", "length": "m", "damping": "kg/s"},
    "ASE": {"mass": "amu", "stiffness": "eV/Å²", "spacing": "Å", "length": "Å"},
}
_KEY_KINDS = {"masses": "mass", "m": "mass", "springs": "stiffness", "kappa": "stiffness", "k": "stiffness",
              "cutoff": "length", "alpha": "damping"}


def key_label(key: str, units: str) -> str:
    """The x label of a swept key with its unit: ``"system.stiffness (N/m)"``.

    >>> key_label("system.masses[1]", "SI"), key_label("member", "SI"), key_label("system.n", "SI")
    ('system.masses[1] (kg)', 'ensemble member (index)', 'system.n (count)')
    """
    if key == "member":
        return "ensemble member (index)"
    name = key.rsplit(".", 1)[-1].split("[", 1)[0]
    if name in ("n", "n_cells", "n_modes"):
        return f"{key} (count)"
    if units not in _KEY_UNITS:
        return f"{key} (dimensionless)"
    kind = _KEY_KINDS.get(name, name)
    unit = _KEY_UNITS[units].get(kind)
    return f"{key} ({unit})" if unit else f"{key} (in the scene's {units} units)"

#: Branches named in the legend at most (beyond, the colours alone tell them apart).
_LEGEND_BRANCHES = 10
_LINE_STYLES = ("-", "--", ":", "-.")


class SweepTableLike(Protocol):
    """What `sweep_figure` reads of a sweep (`vibra.pipeline.sweep.SweepTable`, a stage above the
    charts, which they do not import): its name, swept keys, unit system and rows, and its
    branches as lines (`SweepTable.branch_lines`: the other keys' values, x, and omega per branch,
    in the table's units)."""

    @property
    def name(self) -> str: ...

    @property
    def keys(self) -> tuple[str, ...]: ...

    @property
    def units(self) -> str: ...

    @property
    def rows(self) -> Sequence[object]: ...

    def branch_lines(self) -> Sequence[tuple[Sequence[tuple[str, object]], NDArray[np.float64],
                                             NDArray[np.float64]]]: ...


def sweep_figure(table: SweepTableLike, *, title: str | None = None) -> tuple[Figure, str]:
    """Frequencies against the first swept key: one curve per branch (`SweepTable.branch_lines`, modes
    connected by overlap, so crossing branches keep their colour), one line style per value of
    the other swept keys.

    For an ensemble (key ``member``) the x axis is the member index and each member's modes are
    dots. Omega is drawn in the table's units (rad/s for SI scenes).

    Returns
    -------
    (Figure, str)
        The figure and its caption.
    """
    if not table.rows:
        raise ValueError("table has no rows; nothing to draw")
    key = table.keys[0]
    figure, axes = new_figure()
    lines = table.branch_lines()
    n_branches = max(omega.shape[1] for _, _, omega in lines)
    ensemble = key == "member"
    for number, (values, x, omega) in enumerate(lines):
        style = _LINE_STYLES[number % len(_LINE_STYLES)]
        series = ", ".join(f"{k} = {v:g}" for k, v in values)
        for b in range(omega.shape[1]):
            label = None
            if number == 0 and n_branches <= _LEGEND_BRANCHES and not ensemble:
                label = f"branch {b}"
            axes.plot(x, omega[:, b], "." if ensemble else style, marker=".", markersize=5,
                      color=f"C{b % 10}", linewidth=1.4, label=label)
        if series and not ensemble:
            axes.plot([], [], style, color="0.3", label=series)
    unit = "rad/s" if table.units == "SI" else f"rad per time unit ({table.units or 'dimensionless'})"
    axes.set_xlabel(key_label(key, table.units))
    axes.set_ylabel(f"angular frequency $\\omega$ ({unit})")
    axes.set_title(title or f"{table.name}: {len(table.rows)} points")
    if axes.get_legend_handles_labels()[0]:
        axes.legend(loc="best", fontsize=9)
    how = ("one dot per mode of each member" if ensemble else
           "one curve per branch: each mode joined to the mode of the previous point it overlaps most "
           "(mass-weighted vectors), so branches that cross keep their colour")
    caption = (f"Frequencies of {table.name} at {len(table.rows)} points of {', '.join(table.keys)} "
               f"({how}; omega in {unit}).")
    return figure, caption
