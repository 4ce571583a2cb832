"""Sweeps: one scene (or builder) solved at many parameter points, as a table; on Dask when asked.

A sweep is a scene file (or a parsed scene table, or a Python builder) and a set of points:

- a **grid** (`grid`, `vary`): the Cartesian product of value ranges, one per dotted key of
  the scene (``system.defect_mass``, ``system.stiffness``, one value of a list such as
  ``system.stiffness[1]``, ``compute.n_modes``, ``compute.response.alpha``), linear or
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
closest valid one), every point before any is solved, and a key that changes nothing a sweep
computes is refused naming it (`vibra.pipeline.sweep.applies`: a dynamics scene's time step,
a chart's setting); the system is built and its modes solved as ``vibra modes`` does (the
scene's ``[compute]`` choices: ``n_modes``, ``band``, ``accuracy``, ``solver``; frequencies
only), and a scene with ``[compute.response]`` adds the peak of its forced response as two
derived columns (`response_summary`: ``peak_receptance (m/N)`` and ``peak_omega (rad/s)`` for
SI), so a sweep of its damping tabulates what the damping changes. An optional
``derive(system, modes)`` adds derived quantities (a mapping of names to numbers) per point. Tasks run in this process
(``client=None``) or on a Dask cluster (`vibra.cluster`: ``"local"``, an address or a
``Client``); a builder, ``draw`` and ``derive`` are then pickled and sent to the workers
(module-level functions, or anything cloudpickle ships).

The result is a frozen `SweepTable` (`vibra.pipeline.sweep.results`): one `SweepRow` per point in
point order (parameters, frequencies, the branch of each frequency, derived quantities, solver,
accuracy figures), written with `SweepTable.to_csv` and `SweepTable.to_json` (atomically), and
stored to load back with `save` / `load` as every result is. Rows do not depend on where or
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

import dataclasses
import os
from typing import TYPE_CHECKING, Any, Callable, Mapping, Sequence, Union

import numpy as np

from vibra.cluster import ClientOption, ProgressOption, check_client, connect, progress_callback, run_tasks
from vibra.pipeline.plan import build_system
from vibra.pipeline.scene import Scene, SceneError
from vibra.solvers.accuracy import Accuracy, check as check_accuracy
from vibra.solvers.budget import describe_seconds
from vibra.pipeline.sweep.applies import (
    NOT_SWEPT, SOLVE_KEYS, SweepWarning, check_swept_keys, response_summary, warn_if_constant,
)
from vibra.pipeline.sweep.tables import scene_at, scene_table
from vibra.pipeline.sweep.cost import check_sweep_memory
from vibra.pipeline.sweep.tracking import BranchTracker
from vibra.pipeline.sweep.results import SweepRow, SweepTable
from vibra.pipeline.sweep.points import (
    DEFAULT_MAX_POINTS, Axis, Ensemble, Grid, GridPoints, ValueRange, ensemble, grid, member_rng,
    parse_vary, vary,
)

if TYPE_CHECKING:
    from vibra.generalized import GeneralizedSystem
    from vibra.modes import Modes
    from vibra.solvers.structured.quadratic import QuadraticModes
    from vibra.system import System

#: What a sweep solves: a scene file, a parsed scene table, a `Scene`, or a builder returning a `System`.
SweepTarget = Union[str, "os.PathLike[str]", Mapping[str, object], Scene, Callable[..., "System | GeneralizedSystem"]]

__all__ = ["Axis", "vary", "parse_vary", "Grid", "grid", "Ensemble", "ensemble", "member_rng", "SweepRow",
           "SweepTable", "sweep", "ValueRange", "GridPoints", "DEFAULT_MAX_POINTS",
           "estimate_seconds", "SweepWarning", "SOLVE_KEYS", "NOT_SWEPT", "check_swept_keys"]


# ---------------------------------------------------------------------- one point
def _solve_scene(table: Mapping[str, Any], source: str, vectors: bool = False
                 ) -> tuple[Any, Any, tuple[tuple[str, float], ...]]:
    """The point's system, its modes and its response columns (`response_summary`; () without a response)."""
    scene = Scene.from_dict(table, source=source)
    system = build_system(scene)
    c = scene.compute
    modes = system.modes(c.n_modes, accuracy=c.accuracy, vectors=vectors, band=c.band, solver=c.solver)
    return system, modes, response_summary(scene, system)


def _point_task(kind: str, target: Any, index: int, parameters: tuple[tuple[str, Any], ...], payload: Any,
                options: Mapping[str, Any], derive: Any) -> tuple[SweepRow, Any]:
    """One point (the task a worker runs): build, solve (with vectors when tracking), derive; the row
    and the mass-weighted vectors (None without tracking, or for complex modes)."""
    if kind == "scene":
        data, source = target
        if payload is None:  # an ensemble member: draw its values here, from its own generator
            drawn = dict(options["draw"](member_rng(options["seed"], index)))
            scene, payload = scene_at(data, source, drawn)
            check_swept_keys(tuple(drawn), source, scene)
            parameters = parameters + tuple((str(k), v) for k, v in drawn.items()
                                            if isinstance(v, (int, float)) and not isinstance(v, bool))
        else:  # the point's values: its table is made here (the grid keeps none)
            _, payload = scene_at(data, source, dict(payload))
        system, modes, response = _solve_scene(payload, source, options.get("track", False))
    else:
        response = ()
        kwargs = dict(payload) if payload is not None else {"rng": member_rng(options["seed"], index)}
        system = target(**kwargs)
        modes = system.modes(options["n_modes"], accuracy=options["accuracy"], vectors=options.get("track", False),
                             band=options["band"], solver=options["solver"])
    extra: tuple[tuple[str, float], ...] = response
    if derive is not None:
        extra += tuple((str(k), float(v)) for k, v in dict(derive(system, modes)).items())
    errors = np.asarray(modes.omega_error)
    vectors = getattr(modes, "vectors", None) if options.get("track", False) else None
    if vectors is not None and (np.iscomplexobj(vectors) or np.ndim(vectors) != 2):
        vectors = None
    row = SweepRow(index=index, parameters=parameters, omega=np.asarray(modes.omega, dtype=float), derived=extra,
                   solver=str(modes.path), residual=float(modes.residual),
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
def sweep(target: SweepTarget, points: Grid | Ensemble | Axis | Mapping[str, Sequence[float]], *,
          derive: Callable[[System | GeneralizedSystem, Modes | QuadraticModes], Mapping[str, float]] | None = None,
          client: ClientOption = None,
          progress: ProgressOption = None, n_workers: int | None = None, timeout: float = 10.0,
          n_modes: int | None = None, band: tuple[float, float] | None = None,
          accuracy: Accuracy = "high", solver: str = "auto", name: str | None = None,
          chunk_size: int = 1, max_points: int = DEFAULT_MAX_POINTS, track: bool = True,
          max_memory: float | None = None) -> SweepTable:
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
    max_memory : float, optional
        Bytes the sweep may hold (its rows, the tracked vectors and one solve:
        `vibra.pipeline.sweep.cost`, from the first point's sizes, before any point is solved);
        None takes the solvers' `MEMORY_LIMIT` or the memory available, ``float("inf")`` none.

    Returns
    -------
    SweepTable

    Raises
    ------
    SceneError
        A point's scene is invalid: an unknown key (the closest valid key suggested), a
        wrong value, an index past the end of a swept list (``system.stiffness[5]``: the
        message gives the list's length) or into a value that is not a list; checked for
        every point before any is solved. A swept key that changes nothing a sweep computes
        (`check_swept_keys`: a dynamics scene's run, a chart's setting), named.
    ValueError, TypeError
        Malformed points, target, client or options; an ensemble of a scene without ``draw``;
        more points than `max_points` (the message gives the count and the time estimate); more
        memory than `max_memory` (`vibra.solvers.ResourceLimitError`, naming the points that fit).
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
    options: dict[str, Any] = {"n_modes": n_modes, "band": band, "accuracy": check_accuracy(accuracy), "solver": solver,
                               "track": bool(track) and isinstance(points, Grid)}
    if isinstance(points, Ensemble):
        options.update(seed=points.seed, draw=points.draw)
    count = len(points.points) if isinstance(points, Grid) else points.n
    if count > max_points:
        _refuse_size(target, points, options, name, derive, count, int(max_points))
    tasks, labels, units, table_name = _prepare(target, points, options, name)
    _check_memory(target, points, options, name, count, distributed=client is not None, max_memory=max_memory)
    kind = "builder" if callable(target) and not isinstance(target, (Scene, Mapping, str, os.PathLike)) else "scene"
    arguments = _Lazy(len(tasks), lambda i: (kind, *tasks[i], options, derive))  # made when read
    keys = points.keys if isinstance(points, Grid) else ("member",)
    tracker = BranchTracker()
    rows: list[SweepRow] = []
    if client is None:  # each row tracked as it comes (grid order): only each line's last vectors are held
        callback = progress_callback(progress, len(arguments))
        for done, args in enumerate(arguments, start=1):
            try:
                rows.append(_track(tracker, *_point_task(*args), keys))
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
        rows = [_track(tracker, row, extra, keys) for chunk_rows in results for row, extra in chunk_rows]
    if units is None:
        units = rows[0].units if rows else ""
    warn_if_constant([(row, None) for row in rows], keys, table_name)
    return SweepTable(name=table_name, keys=tuple(keys), units=units or "", rows=tuple(rows))


def _track(tracker: BranchTracker, row: SweepRow, extra: Any, keys: Sequence[str]) -> SweepRow:
    """The row with its branches: by overlap along its line of the grid where vectors came back,
    by rank elsewhere (an ensemble, complex modes, ``track=False``); the vectors are dropped."""
    if extra is None:
        branch = np.arange(row.omega.size, dtype=np.intp)
    else:
        vectors, errors = extra
        values = dict(row.parameters)
        branch = tracker.add(tuple(values.get(k) for k in keys[1:]), row.omega, vectors, errors)
    return dataclasses.replace(row, branch=branch)


def _check_memory(target: Any, points: Grid | Ensemble, options: dict[str, Any], name: str | None, count: int,
                  *, distributed: bool, max_memory: float | None) -> None:
    """Refuse a sweep whose rows, tracked vectors and one solve exceed the memory left
    (`vibra.pipeline.sweep.cost`), from the first point's sizes, before any point is solved."""
    try:
        first = _first_plan(target, points, options, name)
    except SceneError:
        raise
    except Exception:  # noqa: BLE001 - a point that fails to build is reported by the sweep itself, named
        return
    if first is None:
        return
    system, planned = first
    n_dof = int(system.n_dof)
    n_modes = n_dof if planned.problem is None or planned.problem.n_modes is None else int(planned.problem.n_modes)
    lines = len({tuple(p[1:]) for p in points.points}) if isinstance(points, Grid) else 1
    check_sweep_memory(count, n_dof=n_dof, n_modes=min(n_modes, n_dof), solve=float(planned.cost.memory),
                       track=bool(options.get("track", False)), lines=lines, distributed=distributed,
                       max_memory=max_memory)


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
    first = _first_plan(target, points, options, name)
    if first is None:
        return None
    system, planned = first
    return float(planned.cost.seconds), f"{system.n_dof} dofs, {planned.path} path"


def _first_plan(target: Any, points: Grid | Ensemble, options: dict[str, Any], name: str | None
                ) -> tuple[Any, Any] | None:
    """(system, the solver registry's plan) of the first point, built and planned, not solved."""
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
    return None if planned is None else (system, planned)


def estimate_seconds(target: SweepTarget, points: Grid | Ensemble | Axis | Mapping[str, Sequence[float]], *,
                     n_modes: int | None = None, band: tuple[float, float] | None = None,
                     accuracy: Accuracy = "high", solver: str = "auto") -> tuple[float, str] | None:
    """(seconds per point, what) of a sweep, estimated from the first point's sizes before any
    solve (the solver registry's cost, as ``vibra validate`` prints it); None when the registry
    does not plan the solve. Arguments as in `sweep`."""
    if isinstance(points, Axis) or (isinstance(points, Mapping) and not isinstance(points, Grid)):
        points = grid(points)
    options: dict[str, Any] = {"n_modes": n_modes, "band": band, "accuracy": check_accuracy(accuracy), "solver": solver}
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
        if isinstance(points, Grid):  # the first point, then its keys, then every point, before any work
            for number, values in enumerate(points.points):  # (nothing of them kept)
                scene_at(data, source, dict(zip(points.keys, values)))
                if number == 0:
                    check_swept_keys(points.keys, source, scene)
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
