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
frequencies, the branch of each frequency, derived quantities, solver, accuracy figures), written with
`SweepTable.to_csv` and `SweepTable.to_json` (atomically). Rows do not depend on where or
in which order the points ran (there is no timing in them): a table from 1 worker equals
the table from 100 when every worker does its linear algebra alike (Dask's workers use one
BLAS thread each).

Branches (``track=True``, the default; `vibra.pipeline.sweep.tracking`): along each line of a grid
(the first swept key varying, the others fixed) each mode is paired with a mode of the previous
point by the overlap of their mass-weighted vectors (`vibra.compare.match_modes`), so a branch
keeps its number through a crossing instead of swapping with its neighbour. Branch b is the
(b + 1)-th lowest mode at the line's first point. Tracking solves each point with vectors, which
travel back from Dask workers with the rows (n_dof x n_modes numbers a point): sweep large
systems with ``track=False`` (branches are then the ranks).
"""

from __future__ import annotations

import csv
import dataclasses
import io
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
from vibra.pipeline.scene import Scene, SceneError
from vibra.solvers.budget import describe_seconds
from vibra.pipeline.sweep.applies import NOT_SWEPT, SOLVE_KEYS, SweepWarning, check_swept_keys, warn_if_constant
from vibra.pipeline.sweep.tables import scene_at, scene_table
from vibra.pipeline.sweep.tracking import BranchTracker
from vibra.pipeline.sweep.points import (
    DEFAULT_MAX_POINTS, Axis, Ensemble, Grid, GridPoints, ValueRange, ensemble, grid, member_rng,
    parse_vary, vary,
)

__all__ = ["Axis", "vary", "parse_vary", "Grid", "grid", "Ensemble", "ensemble", "member_rng", "SweepRow",
           "SweepTable", "sweep", "ValueRange", "GridPoints", "DEFAULT_MAX_POINTS",
           "estimate_seconds", "SweepWarning", "SOLVE_KEYS", "NOT_SWEPT", "check_swept_keys"]

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

    def __post_init__(self) -> None:
        freeze_arrays(self)

    def as_json(self) -> dict[str, Any]:
        """JSON-ready row (floats as floats)."""
        return {"index": self.index, "parameters": dict(self.parameters),
                "omega": [float(w) for w in self.omega], "derived": dict(self.derived),
                "solver": self.solver, "residual": _finite_or_none(self.residual),
                "omega_error": _finite_or_none(self.omega_error), "units": self.units,
                "branch": None if self.branch is None else [int(b) for b in self.branch]}


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

    def branch_lines(self) -> list[tuple[tuple[tuple[str, Any], ...], NDArray[np.float64], NDArray[np.float64]]]:
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
        """The table as JSON: name, keys, units and every row."""
        return json.dumps({"name": self.name, "keys": list(self.keys), "units": self.units,
                           "rows": [row.as_json() for row in self.rows]}, indent=1) + "\n"

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


def _finite_or_none(value: float) -> float | None:
    """JSON has no NaN: a figure that was not computed (NaN) is written as null."""
    return value if math.isfinite(value) else None


def _cell(value: Any) -> str:
    return repr(float(value)) if isinstance(value, (float, np.floating)) else str(value)


# ---------------------------------------------------------------------- one point
def _solve_scene(table: Mapping[str, Any], source: str, vectors: bool = False) -> tuple[Any, Any, str]:
    scene = Scene.from_dict(table, source=source)
    system = build_system(scene)
    c = scene.compute
    modes = system.modes(c.n_modes, accuracy=c.accuracy, vectors=vectors, band=c.band, solver=c.solver)
    return system, modes, scene.units


def _point_task(kind: str, target: Any, index: int, parameters: tuple[tuple[str, Any], ...], payload: Any,
                options: Mapping[str, Any], derive: Any) -> tuple[SweepRow, Any]:
    """One point (the task a worker runs): build, solve (with vectors when tracking), derive; the row
    and the mass-weighted vectors (None without tracking, or for complex modes)."""
    if kind == "scene":
        data, source = target
        if payload is None:  # an ensemble member: draw its values here, from its own generator
            drawn = dict(options["draw"](member_rng(options["seed"], index)))
            _, payload = scene_at(data, source, drawn)
            parameters = parameters + tuple((str(k), v) for k, v in drawn.items()
                                            if isinstance(v, (int, float)) and not isinstance(v, bool))
        else:  # the point's values: its table is made here (the grid keeps none)
            _, payload = scene_at(data, source, dict(payload))
        system, modes, _ = _solve_scene(payload, source, options.get("track", False))
    else:
        kwargs = dict(payload) if payload is not None else {"rng": member_rng(options["seed"], index)}
        system = target(**kwargs)
        modes = system.modes(options["n_modes"], accuracy=options["accuracy"], vectors=options.get("track", False),
                             band=options["band"], solver=options["solver"])
    extra: tuple[tuple[str, float], ...] = ()
    if derive is not None:
        extra = tuple((str(k), float(v)) for k, v in dict(derive(system, modes)).items())
    errors = np.asarray(modes.omega_error)
    vectors = getattr(modes, "vectors", None) if options.get("track", False) else None
    if vectors is not None and (np.iscomplexobj(vectors) or np.ndim(vectors) != 2):
        vectors = None
    row = SweepRow(index=index, parameters=parameters, omega=np.asarray(modes.omega, dtype=float), derived=extra,
                   solver=str(modes.solver), residual=float(modes.residual),
                   omega_error=float(errors.max()) if errors.size else 0.0, units=str(modes.units.name))
    return row, (None if vectors is None else (np.asarray(vectors), errors))


def _chunk_task(arguments: Sequence[tuple[Any, ...]], labels: Sequence[str]) -> list[tuple[SweepRow, Any]]:
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
          chunk_size: int = 1, max_points: int = DEFAULT_MAX_POINTS, track: bool = True) -> SweepTable:
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
    track : bool
        Connect each mode to a branch by overlap along the grid's lines (`SweepRow.branch`; see
        the module); False: frequencies only, branches by rank.

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
    options: dict[str, Any] = {"n_modes": n_modes, "band": band, "accuracy": accuracy, "solver": solver,
                               "track": bool(track) and isinstance(points, Grid)}
    if isinstance(points, Ensemble):
        options.update(seed=points.seed, draw=points.draw)
    count = len(points.points) if isinstance(points, Grid) else points.n
    if count > max_points:
        _refuse_size(target, points, options, name, derive, count, int(max_points))
    tasks, labels, units, table_name = _prepare(target, points, options, name)
    kind = "builder" if callable(target) and not isinstance(target, (Scene, Mapping, str, os.PathLike)) else "scene"
    arguments = _Lazy(len(tasks), lambda i: (kind, *tasks[i], options, derive))  # made when read
    rows: list[tuple[SweepRow, Any]] = []
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
        chunks = _Lazy(len(starts), lambda c: (arguments[starts[c]:starts[c] + chunk_size],
                                               labels[starts[c]:starts[c] + chunk_size]))
        chunk_labels = _Lazy(len(starts), lambda c: labels[starts[c]] if chunk_size == 1 else
                             f"points {starts[c]}-{min(starts[c] + chunk_size, len(arguments)) - 1}")
        with connect(client, n_workers=n_workers, timeout=timeout) as opened:
            results, failures = run_tasks(opened, _chunk_task, chunks, labels=chunk_labels, progress=progress,
                                          name="vibra-sweep")
        if failures:
            raise RuntimeError(f"{len(failures)} of {len(chunks)} sweep tasks failed: "
                               + "; ".join(f.describe() for f in failures[:5])
                               + ("; ..." if len(failures) > 5 else ""))
        rows = [row for chunk_rows in results for row in chunk_rows]
    if units is None:
        units = rows[0][0].units if rows else ""
    keys = points.keys if isinstance(points, Grid) else ("member",)
    warn_if_constant(rows, keys, table_name)
    return SweepTable(name=table_name, keys=tuple(keys), units=units or "", rows=_tracked(rows, keys))


def _tracked(results: Sequence[tuple[SweepRow, Any]], keys: Sequence[str]) -> tuple[SweepRow, ...]:
    """The rows with their branches: by overlap along each line of the grid where vectors came back,
    by rank elsewhere (an ensemble, complex modes, ``track=False``)."""
    tracker = BranchTracker()
    rows = []
    for row, extra in results:
        if extra is None:
            branch = np.arange(row.omega.size, dtype=np.intp)
        else:
            vectors, errors = extra
            values = dict(row.parameters)
            branch = tracker.add(tuple(values.get(k) for k in keys[1:]), row.omega, vectors, errors)
        rows.append(dataclasses.replace(row, branch=branch))
    return tuple(rows)


def _refuse_size(target: Any, points: Grid | Ensemble, options: dict[str, Any], name: str | None, derive: Any,
                 count: int, max_points: int) -> None:
    """Raise the refusal of a sweep of `count` > `max_points` points, with its estimated time."""
    raise ValueError(f"{count:,} points is more than max_points={max_points:,} (--max-points); "
                     f"{_estimate_text(target, points, options, name, count)}; sweep fewer points, or raise "
                     "max_points (--max-points) to run it")


def _estimate_text(target: Any, points: Grid | Ensemble, options: dict[str, Any], name: str | None,
                   count: int) -> str:
    estimate = _point_estimate(target, points, options, name)
    if estimate is None:
        return "its time cannot be estimated before it runs (the first point's solve is not planned)"
    seconds, what = estimate
    return (f"one point is estimated at ~{describe_seconds(seconds)} from its size ({what}), so the sweep would "
            f"take about {describe_seconds(count * seconds)} in one process")


def _point_estimate(target: Any, points: Grid | Ensemble, options: dict[str, Any], name: str | None
                    ) -> tuple[float, str] | None:
    """(seconds, what) of the first point's solve, from the solver registry's cost of its sizes
    (`vibra.pipeline.plan.checks.solve_request`: the estimate ``vibra validate`` prints), never from
    the clock: the first point's system is built (cheap), not solved. None when the registry does
    not plan it (a quadratic system, a request it would refuse)."""
    from vibra.pipeline.plan.checks import solve_request

    first: Grid | Ensemble = (Grid(points.keys, (points.points[0],)) if isinstance(points, Grid)
                              else Ensemble(points.seed, 1, points.draw))
    tasks, _, _, _ = _prepare(target, first, options, name)
    payload_target, index, _, payload = tasks[0]
    if callable(payload_target) and not isinstance(payload_target, tuple):  # a builder
        kwargs = dict(payload) if payload is not None else {"rng": member_rng(options["seed"], index)}
        system = payload_target(**kwargs)
        request = dict(n_modes=options["n_modes"], band=options["band"], solver=options["solver"],
                       accuracy=options["accuracy"])
    else:
        data, source = payload_target
        if payload is None:
            payload = dict(options["draw"](member_rng(options["seed"], index)))
        scene, _ = scene_at(data, source, dict(payload))
        system = build_system(scene)
        c = scene.compute
        request = dict(n_modes=c.n_modes, band=c.band, solver=c.solver, accuracy=c.accuracy)
    planned = solve_request(system, vectors=bool(options.get("track", False)), **request)
    if planned is None:
        return None
    return float(planned.cost.seconds), f"{system.n_dof} dofs, {planned.path} path"


def estimate_seconds(target: Any, points: Grid | Ensemble | Axis | Mapping[str, Sequence[float]], *,
                     n_modes: int | None = None, band: tuple[float, float] | None = None,
                     accuracy: Literal["high", "fast"] = "high", solver: str = "auto") -> tuple[float, str] | None:
    """(seconds per point, what) of a sweep, estimated from the first point's sizes before any
    solve (the solver registry's cost, as ``vibra validate`` prints it); None when the registry
    does not plan the solve. Arguments as in `sweep`."""
    if isinstance(points, Axis) or (isinstance(points, Mapping) and not isinstance(points, Grid)):
        points = grid(points)
    options: dict[str, Any] = {"n_modes": n_modes, "band": band, "accuracy": accuracy, "solver": solver}
    if isinstance(points, Ensemble):
        options.update(seed=points.seed, draw=points.draw)
    return _point_estimate(target, points, options, None)


class _Lazy(Sequence[Any]):
    """`n` items, item i made by `make(i)` when read: a sweep's tasks and labels, never held as lists."""

    def __init__(self, n: int, make: Callable[[int], Any]) -> None:
        self._n, self._make = n, make

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, index: Any) -> Any:
        if isinstance(index, slice):
            return [self._make(i) for i in range(*index.indices(self._n))]
        i = int(index) + (self._n if int(index) < 0 else 0)
        if not 0 <= i < self._n:
            raise IndexError(f"index {index} out of range for {self._n} items")
        return self._make(i)


def _prepare(target: Any, points: Grid | Ensemble, options: dict[str, Any], name: str | None
             ) -> tuple[Sequence[tuple[Any, int, tuple[tuple[str, Any], ...], Any]], Sequence[str], str | None, str]:
    """Per point: (target payload, index, parameters, point payload); labels; units; table name.

    The tasks and labels are lazy sequences (`_Lazy`): point i's are made when read, so a grid
    of 10^5 points holds no list of them (a scene's points are each validated here first, and
    nothing of them kept).
    """
    builder = callable(target) and not isinstance(target, (Scene, Mapping, str, os.PathLike))
    if builder:
        payload: Any = target
        units, table_name = None, str(name or getattr(target, "__name__", "sweep"))
    else:
        data, source = scene_table(target)
        scene, _ = scene_at(data, source, {})
        if scene.kind in NOT_SWEPT:
            raise SceneError(source, "kind", NOT_SWEPT[scene.kind])
        if isinstance(points, Grid):
            for values in points.points:  # every point validated before any work (not kept)
                scene_at(data, source, dict(zip(points.keys, values)))
            check_swept_keys(points.keys, source, scene.kind)
        elif points.draw is None:
            raise ValueError("an ensemble of a scene needs draw(generator) -> {key: value}, the values of each member")
        payload, units, table_name = (data, source), scene.units, name or scene.name
    if isinstance(points, Grid):
        grid_points, keys = points.points, points.keys

        def task(index: int) -> tuple[Any, int, tuple[tuple[str, Any], ...], Any]:
            parameters = tuple(zip(keys, grid_points[index]))
            return payload, index, parameters, parameters

        def label(index: int) -> str:
            return f"point {index}: " + ", ".join(f"{k}={v:g}" for k, v in zip(keys, grid_points[index]))

        count = len(grid_points)
    else:
        def task(index: int) -> tuple[Any, int, tuple[tuple[str, Any], ...], Any]:
            return payload, index, (("member", index),), None

        def label(index: int) -> str:
            return f"member {index}"

        count = points.n
    return _Lazy(count, task), _Lazy(count, label), units, table_name
