"""A sweep's result: `SweepRow` (one point) and `SweepTable` (the rows, in point order).

`SweepTable` is a `vibra._results.Result`: ``len`` counts rows and ``table[k]`` /
``table[a:b]`` / ``table[mask]`` give a smaller table; `to_dict` / `save` store the rows as
array columns, so that a table of 10^5 rows is bounded as any array is (`load(max_bytes=...)`)
and checked whole on `load` as every result is: ``index``, ``residual``, ``omega_error``,
``solvers``, ``row_units`` per row; every row's ``omega`` and ``branch`` end to end, with
``n_omega`` counting each row's; the parameters and derived quantities as (n_rows, n_names)
arrays with their names (a parameter is an int or a float: ``parameter_kinds`` says which, 0
where a row lacks it; ``derived_present`` likewise). A row's parameters come back in the order
of ``parameter_names`` (the order the rows first name them, as `csv_text` lists them).
`json_text` / `to_json` write the table as one JSON object per row (`SweepRow.to_dict`),
`csv_text` / `to_csv` as a CSV table.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np
from numpy.typing import NDArray

from vibra._core.frozen import Frozen, span
from vibra._core.filesystem import atomic_write_text
from vibra._results import Result, stored

__all__ = ["SweepRow", "SweepTable"]


@dataclass(frozen=True, eq=False)
class SweepRow(Frozen):
    """The result at one point.

    Attributes
    ----------
    index : int
        Position of the point (grid order, or the ensemble member).
    parameters : tuple of (str, value)
        The swept values (``("member", i)`` first for an ensemble, then the scalar values drawn).
    omega : (n_modes,) ndarray
        Angular frequencies, ascending, in the system's units (rad/s for SI scenes).
    derived : tuple of (str, float)
        What ``derive`` returned, in its own units.
    solver : str
        The solver path (`Modes.path`).
    residual : float
        Largest eigen-residual, in the units of omega**2.
    omega_error : float
        Largest error estimate of omega (`Modes.omega_error`), in the units of omega.
    units : str
        Name of the unit system of omega (``"SI"``: rad/s).
    branch : (n_modes,) ndarray of int or None
        The branch of each frequency (`vibra.pipeline.sweep.tracking`): omega[k] lies on branch
        branch[k]; None in a row made before the sweep tracked it.
    """

    index: int
    parameters: tuple[tuple[str, Any], ...]
    omega: NDArray[np.float64]
    derived: tuple[tuple[str, float], ...]
    solver: str
    residual: float
    omega_error: float
    units: str = ""
    branch: NDArray[np.intp] | None = None

    def as_json(self) -> dict[str, Any]:
        """The row as `to_dict` gives it (the older name)."""
        return self.to_dict()

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready row (floats as floats; a figure not computed, NaN, as None): one row of
        `SweepTable.json_text`."""
        return {"index": self.index, "parameters": dict(self.parameters),
                "omega": [float(w) for w in self.omega], "derived": dict(self.derived),
                "solver": self.solver, "residual": _finite_or_none(self.residual),
                "omega_error": _finite_or_none(self.omega_error), "units": self.units,
                "branch": None if self.branch is None else [int(b) for b in self.branch]}


@dataclass(frozen=True, eq=False, repr=False)
class SweepTable(Result):
    """A sweep's rows, in point order (a `vibra._results.Result` over its rows: module docstring).

    Attributes
    ----------
    name : str
        The scene's name (or the builder's), for file names.
    keys : tuple of str
        The swept keys (``("member",)`` for an ensemble).
    units : str
        Unit system of omega (``"SI"``: rad/s; ``"ASE"``: rad per ASE time unit; ...).
    rows : tuple of SweepRow

    `path` names the solver paths of the rows (``"dense"``, or ``"tridiagonal+dense"`` where
    points took different paths). A stored table keeps the branches when every row has them
    (a table from `sweep` always does), none otherwise.
    """

    STORED = {"index": stored(("n_rows",), kind="int"), "residual": stored(("n_rows",)),  # the stored columns
              "omega_error": stored(("n_rows",)), "n_omega": stored(("n_rows",), kind="int"),
              "solvers": stored(("n_rows",), kind="text"), "row_units": stored(("n_rows",), kind="text"),
              "omega": stored(("n_values",)), "branch": stored(("n_values",), kind="int", optional=True),
              "parameter_names": stored(("n_parameters",), kind="text"),
              "parameters": stored(("n_rows", "n_parameters")),
              "parameter_kinds": stored(("n_rows", "n_parameters"), kind="int"),
              "derived_names": stored(("n_derived",), kind="text"), "derived": stored(("n_rows", "n_derived")),
              "derived_present": stored(("n_rows", "n_derived"), kind="bool")}
    SCALARS = {"name": str, "keys": tuple[str, ...], "units": str}
    SIZED, AXIS, NOUNS = {"rows": "n_rows"}, "n_rows", ("row", "rows")

    name: str
    keys: tuple[str, ...]
    units: str
    rows: tuple[SweepRow, ...]

    @property
    def path(self) -> str:
        """The solver paths of the rows, each once, joined by ``+`` (``"none"`` without rows)."""
        return "+".join(dict.fromkeys(row.solver for row in self.rows)) or "none"

    def _repr_parts(self) -> tuple[str, ...]:
        omega = np.concatenate([row.omega for row in self.rows]) if self.rows else np.zeros(0)
        return self._size(), repr(self.name), f"keys {', '.join(self.keys)}", f"omega {span(omega)}"

    def _stored_fields(self) -> dict[str, Any]:
        rows = self.rows
        tracked = bool(rows) and all(row.branch is not None for row in rows)
        out = {"name": self.name, "keys": self.keys, "units": self.units,
               "index": np.array([row.index for row in rows], dtype=np.int64),
               "residual": np.array([row.residual for row in rows], dtype=float),
               "omega_error": np.array([row.omega_error for row in rows], dtype=float),
               "n_omega": np.array([row.omega.size for row in rows], dtype=np.int64),
               "solvers": np.array([row.solver for row in rows], dtype=str),
               "row_units": np.array([row.units for row in rows], dtype=str),
               "omega": np.concatenate([row.omega for row in rows]) if rows else np.zeros(0),
               "branch": np.concatenate([row.branch for row in rows]).astype(np.int64) if tracked  # type: ignore[misc]
               else None}
        out["parameter_names"], out["parameters"], out["parameter_kinds"] = _columns([row.parameters for row in rows])
        out["derived_names"], out["derived"], present = _columns([row.derived for row in rows])
        out["derived_present"] = present > 0
        return out

    @classmethod
    def _from_stored(cls, values: dict[str, Any], where: Callable[[str], str]) -> SweepTable:
        """The rows from the columns, once ``n_omega`` is checked to cut ``omega`` into them."""
        counts, kinds = values["n_omega"], values["parameter_kinds"]
        if np.any(counts < 0) or int(counts.sum()) != values["omega"].size:
            raise ValueError(f"{where('n_omega')} sums to {int(counts.sum())} (entries >= 0); expected the "
                             f"{values['omega'].size} values of omega, each row's in turn")
        if np.any((kinds < 0) | (kinds > 2)):
            raise ValueError(f"{where('parameter_kinds')} holds {int(kinds[(kinds < 0) | (kinds > 2)][0])}; expected "
                             "0 (absent), 1 (a float) or 2 (an int)")
        ends = np.cumsum(counts)
        cuts = [slice(int(end - count), int(end)) for end, count in zip(ends, counts)]
        branch, names, derived = values["branch"], values["parameter_names"], values["derived_names"]
        rows = tuple(SweepRow(
            index=int(values["index"][k]), omega=values["omega"][cut],
            parameters=tuple((str(name), int(value) if kind == 2 else float(value))
                             for name, value, kind in zip(names, values["parameters"][k], kinds[k]) if kind),
            derived=tuple((str(name), float(value))
                          for name, value, present in zip(derived, values["derived"][k], values["derived_present"][k])
                          if present),
            solver=str(values["solvers"][k]), residual=float(values["residual"][k]),
            omega_error=float(values["omega_error"][k]), units=str(values["row_units"][k]),
            branch=None if branch is None else branch[cut]) for k, cut in enumerate(cuts))
        return cls(name=values["name"], keys=values["keys"], units=values["units"], rows=rows)

    def column(self, key: str) -> NDArray[np.float64]:
        """(n_rows,) values of one parameter or derived quantity."""
        out = []
        for row in self.rows:
            values = dict(row.parameters) | dict(row.derived)
            if key not in values:
                raise KeyError(f"{key!r} is not a parameter or derived quantity of this table "
                               f"(have: {', '.join(list(dict(row.parameters)) + list(dict(row.derived)))})")
            out.append(float(values[key]))
        return np.array(out)

    def branch_lines(self) -> list[tuple[tuple[tuple[str, object], ...], NDArray[np.float64], NDArray[np.float64]]]:
        """The branches of each line of the grid, for drawing them as curves.

        Returns
        -------
        list of (others, x, omega)
            One entry per line: the values of the other swept keys (pairs), the (n_points,)
            values of the first swept key (the member index for an ensemble), and the
            (n_points, n_branches) omega of each branch at each point (NaN where a point has no
            mode on that branch), in the table's units.
        """
        key = self.keys[0]
        lines: dict[tuple[tuple[str, Any], ...], list[SweepRow]] = {}
        for row in self.rows:
            values = dict(row.parameters)
            lines.setdefault(tuple((k, values.get(k)) for k in self.keys[1:]), []).append(row)
        out = []
        for others, rows in lines.items():
            width = max((int(np.max(r.branch, initial=-1)) + 1 if r.branch is not None else r.omega.size
                         for r in rows), default=0)
            omega = np.full((len(rows), width), np.nan)
            for i, row in enumerate(rows):
                branch = np.arange(row.omega.size) if row.branch is None else row.branch
                omega[i, branch] = row.omega
            x = np.array([float(dict(r.parameters).get(key, r.index)) for r in rows])
            out.append((others, x, omega))
        return out

    def json_text(self) -> str:
        """The table as JSON: name, keys, units and every row (`SweepRow.to_dict`): what `to_dict`
        holds, one object per row."""
        return json.dumps({"name": self.name, "keys": list(self.keys), "units": self.units,
                           "rows": [row.to_dict() for row in self.rows]}, indent=1) + "\n"

    def csv_text(self) -> str:
        """The table as CSV: index, parameters, derived, solver, residual, omega_error, n_modes, omega_0, ...,
        then branch_0, ...: the branch of omega_0, ... (see `SweepRow.branch`)."""
        parameters = list(dict.fromkeys(k for row in self.rows for k, _ in row.parameters))
        derived = list(dict.fromkeys(k for row in self.rows for k, _ in row.derived))
        width = max((row.omega.shape[0] for row in self.rows), default=0)
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        tracked = any(row.branch is not None for row in self.rows)
        writer.writerow(["index", *parameters, *derived, "solver", "residual", "omega_error", "n_modes",
                         *(f"omega_{k}" for k in range(width)), *(f"branch_{k}" for k in range(width if tracked else 0))])
        for row in self.rows:
            p, d = dict(row.parameters), dict(row.derived)
            writer.writerow([row.index, *(_cell(p.get(k, "")) for k in parameters),
                             *(_cell(d.get(k, "")) for k in derived), row.solver, repr(row.residual),
                             repr(row.omega_error), row.omega.shape[0], *(repr(float(w)) for w in row.omega),
                             *([""] * (width - row.omega.shape[0]) if tracked else []),
                             *((str(int(b)) for b in row.branch) if tracked and row.branch is not None else ())])
        return buffer.getvalue()

    def to_json(self, path: str | os.PathLike[str]) -> Path:
        """Write `json_text` to `path` atomically."""
        return atomic_write_text(path, self.json_text())

    def to_csv(self, path: str | os.PathLike[str]) -> Path:
        """Write `csv_text` to `path` atomically."""
        return atomic_write_text(path, self.csv_text())


def _columns(rows: list[tuple[tuple[str, Any], ...]]
             ) -> tuple[NDArray[np.str_], NDArray[np.float64], NDArray[np.int64]]:
    """The names of (name, number) pairs in the order the rows first give them, the (n_rows, n_names)
    values (NaN where a row lacks one) and how each is kept (`_kind`; 0 where a row lacks it)."""
    names = list(dict.fromkeys(key for row in rows for key, _ in row))
    values, kinds = np.full((len(rows), len(names)), np.nan), np.zeros((len(rows), len(names)), np.int64)
    for k, row in enumerate(rows):
        for key, value in row:
            values[k, names.index(key)], kinds[k, names.index(key)] = value, _kind(key, value)
    return np.array(names, dtype=str), values, kinds


def _kind(key: str, value: Any) -> int:
    """How a parameter's value is stored: 2 an int (exact as a float), 1 a float."""
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        if float(value) != value:
            raise ValueError(f"parameter {key!r} is {value}; a stored sweep table keeps ints up to 2^53")
        return 2
    if isinstance(value, (float, np.floating)):
        return 1
    raise TypeError(f"parameter {key!r} is {value!r} ({type(value).__name__}); a sweep's parameters are numbers")


def _finite_or_none(value: float) -> float | None:
    """JSON has no NaN: a figure that was not computed (NaN) is written as null."""
    return value if math.isfinite(value) else None


def _cell(value: Any) -> str:
    return repr(float(value)) if isinstance(value, (float, np.floating)) else str(value)
