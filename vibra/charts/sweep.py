"""Chart of a sweep: every frequency of every point against the first swept key.

Takes a `vibra.pipeline.sweep.SweepTable` (duck-typed: charts draw what the higher stages computed and
import none of them) and returns the figure and a caption; save it with
`vibra.charts.save_figure`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vibra.charts._style import new_figure

__all__ = ["sweep_figure", "key_label"]

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


def sweep_figure(table: Any, *, title: str | None = None) -> tuple[Any, str]:
    """Frequencies (one dot per mode) against the first swept key; the rest of the keys as series.

    For an ensemble (key ``member``) the x axis is the member index. Omega is drawn in the
    table's units (rad/s for SI scenes).

    Returns
    -------
    (Figure, str)
        The figure and its caption.
    """
    if not table.rows:
        raise ValueError("table has no rows; nothing to draw")
    key = table.keys[0]
    others = [k for k in table.keys[1:]]
    figure, axes = new_figure()
    series: dict[tuple[Any, ...], list[Any]] = {}
    for row in table.rows:
        values = dict(row.parameters)
        series.setdefault(tuple(values.get(k) for k in others), []).append(row)
    for label, rows in series.items():
        x = np.concatenate([np.full(row.omega.shape[0], float(dict(row.parameters)[key])) for row in rows])
        y = np.concatenate([np.asarray(row.omega, dtype=float) for row in rows])
        name = ", ".join(f"{k} = {v:g}" for k, v in zip(others, label)) or None
        axes.plot(x, y, ".", markersize=4, label=name)
    unit = "rad/s" if table.units == "SI" else f"rad per time unit ({table.units or 'dimensionless'})"
    axes.set_xlabel(key_label(key, table.units))
    axes.set_ylabel(f"angular frequency $\\omega$ ({unit})")
    axes.set_title(title or f"{table.name}: {len(table.rows)} points")
    if others:
        axes.legend(loc="best")
    caption = (f"Frequencies of {table.name} at {len(table.rows)} points of {', '.join(table.keys)} "
               f"(one dot per mode; omega in {unit}).")
    return figure, caption
