"""Sweeps: one scene (or builder) solved at many parameter points, as a table; on Dask when asked.

A sweep is a scene file (or a parsed scene table, or a Python builder) and a set of points:

- a **grid** (`grid`, `vary`): the Cartesian product of value ranges, one per dotted key of
  the scene (``system.defect_mass``, ``system.stiffness``, ``compute.n_modes``), linear or
  logarithmic; for a builder the keys are its keyword arguments. Ranges and grids are lazy
  sequences (`ValueRange`, `GridPoints`): a value is computed when it is read, so a grid of
  10^9 points takes a few bytes until it runs. `sweep` refuses more than ``max_points``
  points (`DEFAULT_MAX_POINTS`, 100,000), with the count and the time one point took;
- an **ensemble** (`ensemble`): n random members. Member i draws from its own generator
  `member_rng` (seed, i) = ``default_rng(SeedSequence(seed, spawn_key=(i,)))``, the i-th
  child of ``SeedSequence(seed).spawn(n)``, so the same seed gives the same members whatever
  the number of workers and the order they finish in. A builder is called as
  ``builder(rng=generator)``; a scene needs ``draw(generator) -> {key: value}``, the
  values to set in that member.

Each point is one task: the scene is rebuilt with the point's values and validated as a
scene file would be (`vibra.pipeline.scene.Scene.from_dict`: an unknown key is refused with the
closest valid one), every point before any is solved; the system is built and its modes
solved as ``vibra modes`` does (the scene's ``[compute]`` choices: ``n_modes``, ``band``,
``accuracy``, ``solver``; frequencies only). An optional ``derive(system, modes)`` adds
derived quantities (a mapping of names to numbers) per point. Tasks run in this process
(``client=None``) or on a Dask cluster (`vibra.cluster`: ``"local"``, an address or a
``Client``); a builder, ``draw`` and ``derive`` are then pickled and sent to the workers
(module-level functions, or anything cloudpickle ships).

The result is a frozen `SweepTable`: one `SweepRow` per point in point order (parameters,
frequencies, derived quantities, solver, accuracy figures), written with
`SweepTable.to_csv` and `SweepTable.to_json` (atomically). Rows do not depend on where or
in which order the points ran (there is no timing in them): a table from 1 worker equals
the table from 100 when every worker does its linear algebra alike (Dask's workers use one
BLAS thread each).
"""

from __future__ import annotations

import copy
import csv
import io
import itertools
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Literal, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from vibra._frozen import freeze_arrays
from vibra._io import atomic_write_text
from vibra.cluster import ProgressOption, check_client, connect, progress_callback, run_tasks
from vibra.pipeline.plan import build_system
from vibra.pipeline.scene import Scene, SceneError, tomllib

__all__ = ["Axis", "vary", "parse_vary", "Grid", "grid", "Ensemble", "ensemble", "member_rng", "SweepRow",
           "SweepTable", "sweep", "ValueRange", "GridPoints", "DEFAULT_MAX_POINTS", "describe_duration"]

#: Points a sweep runs without ``max_points=`` (``--max-points``): 10^5 points of a
#: millisecond each take minutes; more is refused with the count and an estimate.
DEFAULT_MAX_POINTS = 100_000


class ValueRange(Sequence[float]):
    """`n` values from `start` to `stop`, linear or logarithmic, each computed when read.

    Value i is the one ``numpy.linspace`` (``numpy.geomspace``) gives: ``start + i * step``
    (``10 ** (log10(start) + i * step)``), with the ends exactly `start` and `stop`.
    """

    def __init__(self, start: float, stop: float, n: int, spacing: Literal["linear", "log"]) -> None:
        self.start, self.stop, self.n, self.spacing = float(start), float(stop), int(n), spacing
        if spacing == "log":
            self._low, self._high = float(np.log10(self.start)), float(np.log10(self.stop))
        else:
            self._low, self._high = self.start, self.stop
        self._step = (self._high - self._low) / (self.n - 1) if self.n > 1 else 0.0

    def __len__(self) -> int:
        return self.n

    def __getitem__(self, index: Any) -> Any:
        if isinstance(index, slice):
            return tuple(self[i] for i in range(*index.indices(self.n)))
        i = int(index)
        if i < 0:
            i += self.n
        if not 0 <= i < self.n:
            raise IndexError(f"index {index} out of range for {self.n} values")
        if i == 0:
            return self.start
        if i == self.n - 1:
            return self.stop
        value = np.float64(i) * np.float64(self._step) + np.float64(self._low)
        return float(np.power(10.0, value)) if self.spacing == "log" else float(value)

    def __eq__(self, other: object) -> bool:
        if isinstance(other, ValueRange):
            return (self.start, self.stop, self.n, self.spacing) == (other.start, other.stop, other.n, other.spacing)
        if isinstance(other, (tuple, list)):
            return len(other) == self.n and all(a == b for a, b in zip(self, other))
        return NotImplemented

    def __hash__(self) -> int:
        return hash((self.start, self.stop, self.n, self.spacing))

    def __repr__(self) -> str:
        return f"ValueRange({self.start!r}, {self.stop!r}, {self.n}, {self.spacing!r})"


class GridPoints(Sequence[tuple[Any, ...]]):
    """The Cartesian product of value sequences, the first varying slowest; point i computed when read."""

    def __init__(self, axes: Sequence[Sequence[Any]]) -> None:
        self.axes = tuple(axes)
        self._size = math.prod(len(a) for a in self.axes)

    def __len__(self) -> int:
        return self._size

    def __getitem__(self, index: Any) -> Any:
        if isinstance(index, slice):
            return tuple(self[i] for i in range(*index.indices(self._size)))
        i = int(index)
        if i < 0:
            i += self._size
        if not 0 <= i < self._size:
            raise IndexError(f"point {index} out of range for {self._size} points")
        values = []
        for axis in reversed(self.axes):
            i, digit = divmod(i, len(axis))
            values.append(axis[digit])
        return tuple(reversed(values))

    def __iter__(self) -> Any:
        return itertools.product(*self.axes)

    def __eq__(self, other: object) -> bool:
        if isinstance(other, GridPoints):
            return self.axes == other.axes
        if isinstance(other, (tuple, list)):
            return len(other) == self._size and all(a == b for a, b in zip(self, other))
        return NotImplemented

    def __hash__(self) -> int:
        return hash(self.axes)

    def __repr__(self) -> str:
        return f"GridPoints({len(self)} points of {len(self.axes)} axes)"


def describe_duration(seconds: float) -> str:
    """A duration in words: ``"40 s"``, ``"12 min"``, ``"3.5 h"``, ``"9 days"``."""
    if seconds < 120:
        return f"{seconds:.2g} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    if seconds < 3 * 86400:
        return f"{seconds / 3600:.1f} h"
    return f"{seconds / 86400:.0f} days"


# ---------------------------------------------------------------------- points
@dataclass(frozen=True)
class Axis:
    """One swept key and its values, in order.

    Attributes
    ----------
    key : str
        Dotted key of the scene (``system.defect_mass``) or a builder's keyword.
    values : sequence of int or float
        The values, in the key's own unit (a tuple, or a lazy `ValueRange` from `vary`).
    """

    key: str
    values: Sequence[Any]


def vary(key: str, start: float, stop: float, n: int, *, spacing: Literal["linear", "log"] = "linear") -> Axis:
    """`n` values from `start` to `stop` (both included), evenly or logarithmically spaced.

    Raises
    ------
    ValueError
        An empty key, `n` < 1 (an empty range), `start` == `stop` with `n` > 1, non-finite
        bounds, or a non-positive bound with ``spacing="log"``.
    """
    if not isinstance(key, str) or not key.strip():
        raise ValueError(f"key is {key!r}; expected a dotted key such as 'system.defect_mass'")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)):
        raise TypeError(f"n must be an int, got {type(n).__name__}")
    if n < 1:
        raise ValueError(f"{key}: n is {n}; an empty range has nothing to sweep (expected n >= 1)")
    low, high = float(start), float(stop)
    if not (math.isfinite(low) and math.isfinite(high)):
        raise ValueError(f"{key}: start and stop must be finite, got {start!r} and {stop!r}")
    if n > 1 and low == high:
        raise ValueError(f"{key}: start and stop are both {low!r}; {n} points need start != stop")
    if spacing == "log":
        if low <= 0 or high <= 0:
            raise ValueError(f"{key}: log spacing needs positive start and stop, got {start!r} and {stop!r}")
    elif spacing != "linear":
        raise ValueError(f"spacing is {spacing!r}; expected 'linear' or 'log'")
    return Axis(key, ValueRange(low, high, int(n), spacing))  # lazy: nothing allocated for n values


def parse_vary(text: str) -> Axis:
    """An `Axis` from the command-line form ``KEY=START:STOP:N`` or ``KEY=log:START:STOP:N``.

    Raises
    ------
    ValueError
        Malformed text (the message shows the expected form), or what `vary` refuses.
    """
    key, sep, spec = str(text).partition("=")
    form = "expected KEY=START:STOP:N or KEY=log:START:STOP:N, e.g. system.defect_mass=0.2:0.8:7"
    if not sep or not key.strip():
        raise ValueError(f"--vary {text!r}: {form}")
    parts = spec.split(":")
    spacing: Literal["linear", "log"] = "linear"
    if parts and parts[0] in ("log", "lin", "linear"):
        spacing = "log" if parts[0] == "log" else "linear"
        parts = parts[1:]
    if len(parts) != 3:
        raise ValueError(f"--vary {text!r}: {form}")
    try:
        start, stop = float(parts[0]), float(parts[1])
        n = int(parts[2])
    except ValueError:
        raise ValueError(f"--vary {text!r}: START and STOP must be numbers and N an integer; {form}") from None
    return vary(key.strip(), start, stop, n, spacing=spacing)


@dataclass(frozen=True)
class Grid:
    """The Cartesian product of axes: every combination, the first axis varying slowest.

    Attributes
    ----------
    keys : tuple of str
    points : sequence of tuple
        One value per key for each point (a lazy `GridPoints`: ``len`` is the count, point i
        is computed when read).
    """

    keys: tuple[str, ...]
    points: Sequence[tuple[Any, ...]]


def grid(*axes: Axis | Mapping[str, Sequence[float]]) -> Grid:
    """A `Grid` from `Axis` objects (`vary`) and/or mappings ``{key: values}``.

    Raises
    ------
    ValueError
        No axis, an axis without values, or a key given twice.
    """
    flat: list[Axis] = []
    for entry in axes:
        if isinstance(entry, Axis):
            flat.append(entry)
        elif isinstance(entry, Mapping):
            flat.extend(Axis(str(k), tuple(_scalar(k, v) for v in np.atleast_1d(np.asarray(values))))
                        for k, values in entry.items())
        else:
            raise TypeError(f"grid takes Axis objects or mappings {{key: values}}, got {type(entry).__name__}")
    if not flat:
        raise ValueError("grid needs at least one axis (a key and its values)")
    keys = [a.key for a in flat]
    for a in flat:
        if not a.values:
            raise ValueError(f"{a.key}: no values; an empty range has nothing to sweep")
        if keys.count(a.key) > 1:
            raise ValueError(f"{a.key}: the key is swept twice; give each key once")
    return Grid(tuple(keys), GridPoints([a.values for a in flat]))


def _scalar(key: str, value: Any) -> Any:
    """A grid value as a plain Python int or float (ints stay ints: builders take n as an int)."""
    item = value.item() if hasattr(value, "item") else value
    if isinstance(item, bool) or not isinstance(item, (int, float)) or not math.isfinite(item):
        raise ValueError(f"{key}: grid values must be finite numbers, got {value!r}")
    return item


@dataclass(frozen=True)
class Ensemble:
    """`n` random members drawn from `seed` (see `member_rng`).

    Attributes
    ----------
    seed : int
    n : int
    draw : callable or None
        ``draw(generator) -> {key: value}`` for a scene; None for a builder (it gets ``rng=``).
    """

    seed: int
    n: int
    draw: Callable[[np.random.Generator], Mapping[str, Any]] | None = None


def ensemble(seed: int, n: int, draw: Callable[[np.random.Generator], Mapping[str, Any]] | None = None) -> Ensemble:
    """An `Ensemble` of `n` members from `seed` (a non-negative integer)."""
    for name, value in (("seed", seed), ("n", n)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise TypeError(f"{name} must be an int, got {type(value).__name__}")
    if seed < 0:
        raise ValueError(f"seed is {seed}; expected a non-negative integer")
    if n < 1:
        raise ValueError(f"n is {n}; an ensemble needs at least 1 member")
    if draw is not None and not callable(draw):
        raise TypeError(f"draw must be callable (generator -> {{key: value}}), got {type(draw).__name__}")
    return Ensemble(int(seed), int(n), draw)


def member_rng(seed: int, index: int) -> np.random.Generator:
    """The generator of ensemble member `index`: the `index`-th child of ``SeedSequence(seed)``."""
    return np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(int(index),)))


# ---------------------------------------------------------------------- results
@dataclass(frozen=True, eq=False)
class SweepRow:
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
        The solver path (`Modes.solver`).
    residual : float
        Largest eigen-residual, in the units of omega**2.
    omega_error : float
        Largest error estimate of omega (`Modes.omega_error`), in the units of omega.
    units : str
        Name of the unit system of omega (``"SI"``: rad/s).
    """

    index: int
    parameters: tuple[tuple[str, Any], ...]
    omega: NDArray[np.float64]
    derived: tuple[tuple[str, float], ...]
    solver: str
    residual: float
    omega_error: float
    units: str = ""

    def __post_init__(self) -> None:
        freeze_arrays(self)

    def as_json(self) -> dict[str, Any]:
        """JSON-ready row (floats as floats)."""
        return {"index": self.index, "parameters": dict(self.parameters),
                "omega": [float(w) for w in self.omega], "derived": dict(self.derived),
                "solver": self.solver, "residual": _finite_or_none(self.residual),
                "omega_error": _finite_or_none(self.omega_error), "units": self.units}


@dataclass(frozen=True, eq=False)
class SweepTable:
    """A sweep's rows, in point order.

    Attributes
    ----------
    name : str
        The scene's name (or the builder's), for file names.
    keys : tuple of str
        The swept keys (``("member",)`` for an ensemble).
    units : str
        Unit system of omega (``"SI"``: rad/s; ``"ASE"``: rad per ASE time unit; ...).
    rows : tuple of SweepRow
    """

    name: str
    keys: tuple[str, ...]
    units: str
    rows: tuple[SweepRow, ...]

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

    def json_text(self) -> str:
        """The table as JSON: name, keys, units and every row."""
        return json.dumps({"name": self.name, "keys": list(self.keys), "units": self.units,
                           "rows": [row.as_json() for row in self.rows]}, indent=1) + "\n"

    def csv_text(self) -> str:
        """The table as CSV: index, parameters, derived, solver, residual, omega_error, n_modes, omega_0, ..."""
        parameters = list(dict.fromkeys(k for row in self.rows for k, _ in row.parameters))
        derived = list(dict.fromkeys(k for row in self.rows for k, _ in row.derived))
        width = max((row.omega.shape[0] for row in self.rows), default=0)
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow(["index", *parameters, *derived, "solver", "residual", "omega_error", "n_modes",
                         *(f"omega_{k}" for k in range(width))])
        for row in self.rows:
            p, d = dict(row.parameters), dict(row.derived)
            writer.writerow([row.index, *(_cell(p.get(k, "")) for k in parameters),
                             *(_cell(d.get(k, "")) for k in derived), row.solver, repr(row.residual),
                             repr(row.omega_error), row.omega.shape[0], *(repr(float(w)) for w in row.omega)])
        return buffer.getvalue()

    def to_json(self, path: str | os.PathLike[str]) -> Path:
        """Write `json_text` to `path` atomically."""
        return atomic_write_text(path, self.json_text())

    def to_csv(self, path: str | os.PathLike[str]) -> Path:
        """Write `csv_text` to `path` atomically."""
        return atomic_write_text(path, self.csv_text())


def _finite_or_none(value: float) -> float | None:
    """JSON has no NaN: a figure that was not computed (NaN) is written as null."""
    return value if math.isfinite(value) else None


def _cell(value: Any) -> str:
    return repr(float(value)) if isinstance(value, (float, np.floating)) else str(value)


# ---------------------------------------------------------------------- one point
def _override(data: Mapping[str, Any], key: str, value: Any, source: str) -> dict[str, Any]:
    """A deep copy of a scene table with ``data[section][...][name] = value``."""
    parts = key.split(".")
    if len(parts) < 2 or not all(parts):
        raise SceneError(source, key, "a swept key must be a dotted path into a table, such as system.defect_mass")
    out = copy.deepcopy(dict(data))
    node: Any = out
    for depth, part in enumerate(parts[:-1]):
        child = node.get(part) if isinstance(node, dict) else None
        if child is None:
            child = {}
            node[part] = child
        if not isinstance(child, dict):
            raise SceneError(source, ".".join(parts[:depth + 1]), f"is a value, not a table; cannot set {key}")
        node = child
    node[parts[-1]] = value.tolist() if isinstance(value, np.ndarray) else value
    return out


def _scene_at(data: Mapping[str, Any], source: str, values: Mapping[str, Any]) -> tuple[Scene, dict[str, Any]]:
    """The validated scene with `values` set, and the table it was built from."""
    table = dict(data)
    for key, value in values.items():
        table = _override(table, key, value, source)
    try:
        return Scene.from_dict(table, source=source), table
    except SceneError as error:  # an integer key swept with float values: 3.0 -> 3
        whole = {k: int(v) for k, v in values.items() if isinstance(v, float) and v.is_integer()}
        if not whole or "expected an integer" not in str(error):
            raise
        for key, value in whole.items():
            table = _override(table, key, value, source)
        return Scene.from_dict(table, source=source), table


def _solve_scene(table: Mapping[str, Any], source: str) -> tuple[Any, Any, str]:
    scene = Scene.from_dict(table, source=source)
    system = build_system(scene)
    c = scene.compute
    modes = system.modes(c.n_modes, accuracy=c.accuracy, vectors=False, band=c.band, solver=c.solver)
    return system, modes, scene.units


def _point_task(kind: str, target: Any, index: int, parameters: tuple[tuple[str, Any], ...], payload: Any,
                options: Mapping[str, Any], derive: Any) -> SweepRow:
    """One point (the task a worker runs): build, solve (frequencies only), derive."""
    if kind == "scene":
        data, source = target
        if payload is None:  # an ensemble member: draw its values here, from its own generator
            drawn = dict(options["draw"](member_rng(options["seed"], index)))
            _, payload = _scene_at(data, source, drawn)
            parameters = parameters + tuple((str(k), v) for k, v in drawn.items()
                                            if isinstance(v, (int, float)) and not isinstance(v, bool))
        else:  # the point's values: its table is made here (the grid keeps none)
            _, payload = _scene_at(data, source, dict(payload))
        system, modes, _ = _solve_scene(payload, source)
    else:
        kwargs = dict(payload) if payload is not None else {"rng": member_rng(options["seed"], index)}
        system = target(**kwargs)
        modes = system.modes(options["n_modes"], accuracy=options["accuracy"], vectors=False,
                             band=options["band"], solver=options["solver"])
    extra: tuple[tuple[str, float], ...] = ()
    if derive is not None:
        extra = tuple((str(k), float(v)) for k, v in dict(derive(system, modes)).items())
    errors = np.asarray(modes.omega_error)
    return SweepRow(index=index, parameters=parameters, omega=np.asarray(modes.omega, dtype=float), derived=extra,
                    solver=str(modes.solver), residual=float(modes.residual),
                    omega_error=float(errors.max()) if errors.size else 0.0, units=str(modes.units.name))


def _chunk_task(arguments: Sequence[tuple[Any, ...]], labels: Sequence[str]) -> list[SweepRow]:
    """Several points in one task (`sweep`'s ``chunk_size``); a failure names its point."""
    if len(arguments) == 1:
        return [_point_task(*arguments[0])]
    rows = []
    for args, label in zip(arguments, labels):
        try:
            rows.append(_point_task(*args))
        except Exception as error:
            raise RuntimeError(f"{label}: {type(error).__name__}: {error}") from error
    return rows


# ---------------------------------------------------------------------- the sweep
def sweep(target: Any, points: Grid | Ensemble | Axis | Mapping[str, Sequence[float]], *,
          derive: Callable[[Any, Any], Mapping[str, float]] | None = None, client: Any = None,
          progress: ProgressOption = None, n_workers: int | None = None, timeout: float = 10.0,
          n_modes: int | None = None, band: tuple[float, float] | None = None,
          accuracy: Literal["high", "fast"] = "high", solver: str = "auto", name: str | None = None,
          chunk_size: int = 1, max_points: int = DEFAULT_MAX_POINTS) -> SweepTable:
    """Solve `target` at every point of `points`; one row per point, in point order.

    Parameters
    ----------
    target : path-like, Mapping, Scene or callable
        A scene file, a parsed scene table, a `Scene`, or a builder returning a `System`
        (called with the grid's keywords, or with ``rng=`` for an ensemble).
    points : Grid, Axis, Mapping or Ensemble
        The points (`grid`, `vary`, ``{key: values}``, `ensemble`).
    derive : callable, optional
        ``derive(system, modes) -> {name: number}``: derived quantities per point.
    client : None, "local", str or distributed.Client
        Where the points run (see `vibra.cluster.connect`).
    progress : None, bool, "dask" or callable
        A line per finished point on stderr (True), Dask's progress bar or widget, or a
        callable ``(done, total, label)``.
    n_workers : int, optional
        Worker processes of ``client="local"``.
    timeout : float
        Seconds to wait for a scheduler address to answer.
    n_modes, band, accuracy, solver
        For a builder: what to solve (as in `System.modes`); a scene uses its ``[compute]``.
    name : str, optional
        Name of the table (default: the scene's name, or the builder's).
    chunk_size : int
        Points per Dask task. 1 (one task per point) balances the load best when points are
        expensive; points that take about a millisecond run several times faster in chunks
        (the per-task cost of Dask is a few milliseconds: benchmarks/RESULTS_distributed.md).
    max_points : int
        The most points (grid points or ensemble members) this call runs (`DEFAULT_MAX_POINTS`).
        A larger sweep is refused before any work but one point, solved to say how long the
        whole sweep would take (the refusal depends on the count only, never on the clock).

    Returns
    -------
    SweepTable

    Raises
    ------
    SceneError
        A point's scene is invalid: an unknown key (the closest valid key suggested), a
        wrong value; checked for every point before any is solved.
    ValueError, TypeError
        Malformed points, target, client or options; an ensemble of a scene without ``draw``;
        more points than `max_points` (the message gives the count and the time estimate).
    RuntimeError
        One or more points failed while solving (each named with its values).
    vibra.cluster.ClusterError
        No scheduler answered at the address within `timeout`.

    Examples
    --------
    >>> from vibra.chains import linear_chain
    >>> table = sweep(linear_chain, {"n": [3, 4]})
    >>> [row.omega.shape[0] for row in table.rows]
    [3, 4]
    """
    check_client(client)
    if isinstance(chunk_size, bool) or not isinstance(chunk_size, (int, np.integer)) or chunk_size < 1:
        raise ValueError(f"chunk_size is {chunk_size!r}; expected an integer >= 1 (points per task)")
    chunk_size = int(chunk_size)
    if isinstance(points, Axis) or (isinstance(points, Mapping) and not isinstance(points, Grid)):
        points = grid(points)
    if not isinstance(points, (Grid, Ensemble)):
        raise TypeError(f"points must be a Grid, Axis, mapping or Ensemble, got {type(points).__name__}")
    if isinstance(max_points, bool) or not isinstance(max_points, (int, np.integer)) or max_points < 1:
        raise ValueError(f"max_points is {max_points!r}; expected an integer >= 1")
    options: dict[str, Any] = {"n_modes": n_modes, "band": band, "accuracy": accuracy, "solver": solver}
    if isinstance(points, Ensemble):
        options.update(seed=points.seed, draw=points.draw)
    count = len(points.points) if isinstance(points, Grid) else points.n
    if count > max_points:
        _refuse_size(target, points, options, name, derive, count, int(max_points))
    tasks, labels, units, table_name = _prepare(target, points, options, name)
    kind = "builder" if callable(target) and not isinstance(target, (Scene, Mapping, str, os.PathLike)) else "scene"
    arguments = [(kind, payload_target, index, parameters, payload, options, derive)
                 for payload_target, index, parameters, payload in tasks]
    rows: list[SweepRow] = []
    if client is None:
        callback = progress_callback(progress, len(arguments))
        for done, args in enumerate(arguments, start=1):
            try:
                rows.append(_point_task(*args))
            except SceneError:
                raise
            except Exception as error:
                raise RuntimeError(f"sweep point {labels[done - 1]} failed: {type(error).__name__}: {error}") from error
            if callback is not None:
                callback(done, len(arguments), labels[done - 1])
    else:
        starts = range(0, len(arguments), chunk_size)
        chunks = [(arguments[i:i + chunk_size], labels[i:i + chunk_size]) for i in starts]
        chunk_labels = [labels[i] if chunk_size == 1 else f"points {i}-{min(i + chunk_size, len(arguments)) - 1}"
                        for i in starts]
        with connect(client, n_workers=n_workers, timeout=timeout) as opened:
            results, failures = run_tasks(opened, _chunk_task, chunks, labels=chunk_labels, progress=progress,
                                          name="vibra-sweep")
        if failures:
            raise RuntimeError(f"{len(failures)} of {len(chunks)} sweep tasks failed: "
                               + "; ".join(f.describe() for f in failures[:5])
                               + ("; ..." if len(failures) > 5 else ""))
        rows = [row for chunk_rows in results for row in chunk_rows]
    if units is None:
        units = rows[0].units if rows else ""
    keys = points.keys if isinstance(points, Grid) else ("member",)
    return SweepTable(name=table_name, keys=tuple(keys), units=units or "", rows=tuple(rows))


def _refuse_size(target: Any, points: Grid | Ensemble, options: dict[str, Any], name: str | None, derive: Any,
                 count: int, max_points: int) -> None:
    """Raise the refusal of a sweep of `count` > `max_points` points, timed from its first point."""
    import time

    first: Grid | Ensemble = (Grid(points.keys, (points.points[0],)) if isinstance(points, Grid)
                              else Ensemble(points.seed, 1, points.draw))
    tasks, _, _, _ = _prepare(target, first, options, name)
    kind = "builder" if callable(target) and not isinstance(target, (Scene, Mapping, str, os.PathLike)) else "scene"
    payload_target, index, parameters, payload = tasks[0]
    seconds = math.inf
    for _ in range(2):  # the second run, when the first was short, leaves imports and caches out
        start = time.perf_counter()
        _point_task(kind, payload_target, index, parameters, payload, options, derive)
        seconds = min(seconds, time.perf_counter() - start)
        if seconds > 1.0:
            break
    raise ValueError(f"{count:,} points is more than max_points={max_points:,} (--max-points); one point took "
                     f"{seconds:.2g} s here, so the sweep would take about {describe_duration(count * seconds)} in "
                     "one process; sweep fewer points, or raise max_points (--max-points) to run it")


def _prepare(target: Any, points: Grid | Ensemble, options: dict[str, Any], name: str | None
             ) -> tuple[list[tuple[Any, int, tuple[tuple[str, Any], ...], Any]], list[str], str | None, str]:
    """Per point: (target payload, index, parameters, point payload); labels; units; table name."""
    tasks: list[tuple[Any, int, tuple[tuple[str, Any], ...], Any]] = []
    labels: list[str] = []
    if callable(target) and not isinstance(target, (Scene, Mapping, str, os.PathLike)):
        if isinstance(points, Grid):
            for index, values in enumerate(points.points):
                parameters = tuple(zip(points.keys, values))
                tasks.append((target, index, parameters, parameters))
                labels.append(f"point {index}: " + ", ".join(f"{k}={v:g}" for k, v in parameters))
        else:
            for index in range(points.n):
                tasks.append((target, index, (("member", index),), None))
                labels.append(f"member {index}")
        return tasks, labels, None, str(name or getattr(target, "__name__", "sweep"))
    data, source = _scene_table(target)
    scene, _ = _scene_at(data, source, {})
    if scene.kind == "oscillator":
        raise ValueError(f"{source}: an oscillator scene has no normal modes to sweep")
    if isinstance(points, Grid):
        for index, values in enumerate(points.points):
            parameters = tuple(zip(points.keys, values))
            _scene_at(data, source, dict(parameters))  # every point validated before any work (not kept)
            tasks.append(((data, source), index, parameters, parameters))
            labels.append(f"point {index}: " + ", ".join(f"{k}={v:g}" for k, v in parameters))
    else:
        if points.draw is None:
            raise ValueError("an ensemble of a scene needs draw(generator) -> {key: value}, the values of each member")
        for index in range(points.n):
            tasks.append(((data, source), index, (("member", index),), None))
            labels.append(f"member {index}")
    return tasks, labels, scene.units, name or scene.name


def _scene_table(target: Any) -> tuple[dict[str, Any], str]:
    """The raw scene table and its source name, from a path, a mapping or a `Scene`."""
    if isinstance(target, Scene):
        data = _strip_none(target.dump())
        system = data.pop("system")
        data["system"] = {"builder": system["builder"], **system.get("parameters", {})}
        return data, target.source
    if isinstance(target, Mapping):
        return dict(target), str(target.get("name", "<scene>"))
    if isinstance(target, (str, os.PathLike)):
        path = Path(target)
        try:
            text = path.read_bytes().decode("utf-8")
        except FileNotFoundError:
            raise SceneError(str(path), "", "file not found") from None
        except (OSError, UnicodeDecodeError) as error:
            raise SceneError(str(path), "", f"cannot read the scene file ({error})") from None
        try:
            return tomllib.loads(text), str(path)
        except tomllib.TOMLDecodeError as error:
            raise SceneError(str(path), "", f"invalid TOML: {error}") from None
    raise TypeError(f"target must be a scene file, a scene table, a Scene or a builder, got {type(target).__name__}")


def _strip_none(value: Any) -> Any:
    """A `Scene.dump` as a scene table: no None values (defaults), no 'source', lists for tuples."""
    if isinstance(value, Mapping):
        return {k: _strip_none(v) for k, v in value.items() if v is not None and k != "source"}
    if isinstance(value, (list, tuple)):
        return [_strip_none(v) for v in value]
    return value

