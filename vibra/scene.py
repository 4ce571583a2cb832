"""Scene files (TOML) -> frozen `Scene` objects: data only, never code.

A scene states what system to build (a builder from a fixed table and its parameters),
what to compute (how many modes, shapes or not, response, continuum comparison,
cross-check) and what to draw. `load_scene(path)` reads a file with `tomllib` and
`Scene.from_dict(data, source=path)` validates every key before any work: unknown keys
(with the closest valid key suggested), wrong types and impossible values are reported as
`SceneError` with the file name and the key path. The schema is documented in
``docs/scenes.md``; the tables below are its single source of truth.

Nothing in a scene is executed: a builder name is looked up in `BUILDERS`, a fixed table,
and every value is a number, a string, a boolean or a list of those.
"""

from __future__ import annotations

import difflib
import math
import os
import re
import sys
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any, Callable, Mapping, Sequence

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = [
    "SceneError", "Scene", "SystemSpec", "ComputeSpec", "ResponseSpec", "ContinuumSpec",
    "DrawSpec", "BUILDERS", "KINDS", "load_scene", "find_scene_files",
]

KINDS = ("chain", "molecule", "oscillator", "generalized")
_UNITS = ("SI", "ASE", "dimensionless")
_DEFAULT_UNITS = {"chain": "SI", "molecule": "ASE", "oscillator": "SI", "generalized": "SI"}
_SAFE_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")


class SceneError(ValueError):
    """A scene file that cannot be used; the message reads ``file: key.path: problem``."""

    def __init__(self, source: str, key: str, message: str) -> None:
        self.source = source
        self.key = key
        self.problem = message
        where = f"{key}: " if key else ""
        super().__init__(f"{source}: {where}{message}")


# ---------------------------------------------------------------------- value checks
# Each check takes (value, fail) and returns the normalised value (lists become tuples);
# `fail(message)` raises a SceneError at the key being checked.
Check = Callable[[Any, Callable[[str], Any]], Any]


def _kind_name(value: Any) -> str:
    names = {bool: "a boolean", int: "an integer", float: "a number", str: "a string",
             list: "a list", dict: "a table"}
    return names.get(type(value), type(value).__name__)


def _number(value: Any, fail: Callable[[str], Any]) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        fail(f"expected a number, got {_kind_name(value)} ({value!r})")
    if not math.isfinite(value):
        fail(f"expected a finite number, got {value!r}")
    return float(value)


def _positive(value: Any, fail: Callable[[str], Any]) -> float:
    number = _number(value, fail)
    if number <= 0:
        fail(f"must be positive, got {value!r}")
    return number


def _nonnegative(value: Any, fail: Callable[[str], Any]) -> float:
    number = _number(value, fail)
    if number < 0:
        fail(f"must be >= 0, got {value!r}")
    return number


def _integer(low: int, high: int | None = None) -> Check:
    def check(value: Any, fail: Callable[[str], Any]) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            fail(f"expected an integer, got {_kind_name(value)} ({value!r})")
        if value < low or (high is not None and value > high):
            bound = f"{low} <= value <= {high}" if high is not None else f">= {low}"
            fail(f"must be {bound}, got {value}")
        return int(value)
    return check


def _boolean(value: Any, fail: Callable[[str], Any]) -> bool:
    if not isinstance(value, bool):
        fail(f"expected true or false, got {_kind_name(value)} ({value!r})")
    return bool(value)


def _string(value: Any, fail: Callable[[str], Any]) -> str:
    if not isinstance(value, str):
        fail(f"expected a string, got {_kind_name(value)} ({value!r})")
    return str(value)


def _one_of(*allowed: Any) -> Check:
    def check(value: Any, fail: Callable[[str], Any]) -> Any:
        if value not in allowed or isinstance(value, bool) != isinstance(allowed[0], bool):
            options = ", ".join(repr(a) for a in allowed)
            fail(f"is {value!r}; expected one of {options}")
        return value
    return check


def _list_of(item: Check, *, length: int | None = None, min_length: int = 1) -> Check:
    def check(value: Any, fail: Callable[[str], Any]) -> tuple[Any, ...]:
        if not isinstance(value, list):
            fail(f"expected a list, got {_kind_name(value)} ({value!r})")
        if length is not None and len(value) != length:
            fail(f"needs {length} values, got {len(value)}")
        if len(value) < min_length:
            fail(f"needs at least {min_length} values, got {len(value)}")
        out = []
        for i, entry in enumerate(value):
            out.append(item(entry, _prefixed(fail, f"[{i}] ")))
        return tuple(out)
    return check


def _prefixed(fail: Callable[[str], Any], prefix: str) -> Callable[[str], Any]:
    def prefixed(message: str) -> Any:
        return fail(prefix + message)
    return prefixed


def _scalar_or_list(item: Check) -> Check:
    listed = _list_of(item)

    def check(value: Any, fail: Callable[[str], Any]) -> Any:
        return listed(value, fail) if isinstance(value, list) else item(value, fail)
    return check


def _index_pairs(value: Any, fail: Callable[[str], Any]) -> tuple[tuple[int, int], ...]:
    return _list_of(_list_of(_integer(0), length=2), min_length=0)(value, fail)


def _matrix(value: Any, fail: Callable[[str], Any]) -> tuple[tuple[float, ...], ...]:
    rows = _list_of(_list_of(_number))(value, fail)
    if any(len(row) != len(rows) for row in rows):
        fail(f"must be a square matrix (a list of {len(rows)} rows of {len(rows)} numbers)")
    return rows


def _coordinates(value: Any, fail: Callable[[str], Any]) -> tuple[Any, ...]:
    if not isinstance(value, list) or not value:
        fail(f"expected a non-empty list of coordinates, got {_kind_name(value)}")
    if all(not isinstance(v, list) for v in value):
        return _list_of(_number)(value, fail)
    rows = _list_of(_list_of(_number))(value, fail)
    if len({len(r) for r in rows}) != 1 or len(rows[0]) not in (1, 2, 3):
        fail("every site needs the same number (1, 2 or 3) of coordinates")
    return rows


@dataclass(frozen=True)
class _Field:
    check: Check
    default: Any = None
    required: bool = False


def _field(check: Check, default: Any = None, *, required: bool = False) -> _Field:
    return _Field(check, default, required)


_MASS = _scalar_or_list(_positive)
_FROZEN = {
    "frozen_sites": _field(_list_of(_integer(0), min_length=0)),
    "frozen_dofs": _field(_list_of(_integer(0), min_length=0)),
}

#: builder name -> (scene kinds it serves, parameter table). The plan maps each name to one
#: function in vibra (see `vibra.plan`); nothing read from a file is ever imported or run.
BUILDERS: Mapping[str, tuple[tuple[str, ...], Mapping[str, _Field]]] = MappingProxyType({
    "linear_chain": (("chain",), {
        "n": _field(_integer(2), required=True),
        "mass": _field(_MASS, 1.0),
        "stiffness": _field(_scalar_or_list(_positive), 1.0),
        "spacing": _field(_positive, 1.0),
        "ends": _field(_one_of("free", "fixed", "periodic"), "free"),
        "defect_site": _field(_integer(0)),
        "defect_mass": _field(_positive),
        **_FROZEN,
    }),
    "diatomic_chain": (("chain",), {
        "n_cells": _field(_integer(1), required=True),
        "masses": _field(_list_of(_positive, length=2), required=True),
        "stiffness": _field(_scalar_or_list(_positive), 1.0),
        "spacing": _field(_positive, 1.0),
        "ends": _field(_one_of("free", "fixed", "periodic"), "free"),
        **_FROZEN,
    }),
    "beaded_string": (("chain",), {
        "n": _field(_integer(1), required=True),
        "mass": _field(_positive, 1.0),
        "tension": _field(_positive, 1.0),
        "spacing": _field(_positive, 1.0),
        "ends": _field(_one_of("fixed", "free", "periodic"), "fixed"),
        **_FROZEN,
    }),
    "springs": (("chain", "molecule"), {
        "positions": _field(_coordinates, required=True),
        "masses": _field(_MASS, required=True),
        "springs": _field(_index_pairs, required=True),
        "stiffness": _field(_scalar_or_list(_positive), required=True),
        "anchors": _field(_list_of(_integer(0), min_length=0)),
        "anchor_stiffness": _field(_scalar_or_list(_positive)),
        "symbols": _field(_list_of(_string)),
        **_FROZEN,
    }),
    "co2": (("molecule",), {
        "dims": _field(_one_of(1, 3), 3),
        **_FROZEN,
    }),
    "h2o": (("molecule",), {**_FROZEN}),
    "double_pendulum": (("generalized",), {
        "m": _field(_positive, 1.0),
        "m_prime": _field(_positive, 1.0),
        "a": _field(_positive, 1.0),
        "b": _field(_positive, 1.0),
        "g": _field(_positive, 9.81),
    }),
    "matrices": (("generalized",), {
        "M": _field(_matrix, required=True),
        "K": _field(_matrix, required=True),
        "coordinates": _field(_list_of(_string)),
    }),
    "oscillator": (("oscillator",), {
        "w0": _field(_positive, 1.0),
        "gamma": _field(_scalar_or_list(_nonnegative), 0.5),
        "m": _field(_positive, 1.0),
    }),
})


@dataclass(frozen=True)
class SystemSpec:
    """What system a scene builds.

    Attributes
    ----------
    builder : str
        A key of `BUILDERS`.
    parameters : Mapping[str, Any]
        Read-only builder parameters with defaults filled in (lists as tuples), in the
        scene's units.
    """

    builder: str
    parameters: Mapping[str, Any]


@dataclass(frozen=True)
class ResponseSpec:
    """A forced-damped response over a frequency range (``[compute.response]``).

    Attributes
    ----------
    omega_min, omega_max : float
        Angular-frequency range, in rad per time unit of the scene's units.
    n_points : int
        Number of frequencies, spaced linearly.
    alpha : float
        Mass-proportional damping C = alpha M + beta K, in 1 / time unit (seed 003 §2.6: eta).
    beta : float
        Stiffness-proportional damping, in time units.
    force_site : int
        Degree of freedom driven by a unit harmonic force.
    method : str
        ``"direct"`` or ``"modal"``.
    n_modes : int or None
        Modes kept by the modal method (all when None).
    """

    omega_min: float
    omega_max: float
    n_points: int = 400
    alpha: float = 0.0
    beta: float = 0.0
    force_site: int = 0
    method: str = "direct"
    n_modes: int | None = None


@dataclass(frozen=True)
class ContinuumSpec:
    """The continuum-limit comparison (``[compute.continuum]``).

    Attributes
    ----------
    modes : tuple of int
        Mode numbers k (1-based, lowest non-zero modes) compared with the wave equation.
    sizes : tuple of int
        Chain lengths N, at fixed total length.
    ends : str
        ``"free"``, ``"fixed"`` or ``"periodic"``.
    """

    modes: tuple[int, ...] = (1, 2, 3)
    sizes: tuple[int, ...] = (8, 16, 32, 64, 128, 256)
    ends: str = "free"


@dataclass(frozen=True)
class ComputeSpec:
    """What a scene computes (``[compute]``).

    Attributes
    ----------
    n_modes : int or None
        Number of lowest modes (a partial solver); all when None and `band` is None.
    band : (float, float) or None
        Only modes with omega in [low, high], in rad per time unit of the scene's units.
    shapes : bool
        Compute mode shapes even when nothing drawn needs them.
    accuracy : str
        ``"high"`` or ``"fast"`` (`vibra.System.modes`).
    solver : str
        ``"auto"`` or a solver path of `vibra.normal_modes`.
    response : ResponseSpec or None
    continuum : ContinuumSpec or None
    crosscheck : bool
        Compare against ASE and phonopy (molecules only).
    """

    n_modes: int | None = None
    band: tuple[float, float] | None = None
    shapes: bool = False
    accuracy: str = "high"
    solver: str = "auto"
    response: ResponseSpec | None = None
    continuum: ContinuumSpec | None = None
    crosscheck: bool = False


@dataclass(frozen=True)
class DrawSpec:
    """What a scene draws (``[draw]``).

    Attributes
    ----------
    modes : bool
        Render mode shapes off-screen with pyvista (atoms and bonds, or a row of masses).
    n_draw : int
        How many modes to draw (the lowest non-zero ones).
    spectrum : bool
        Stick spectrum chart of the frequencies.
    dispersion : bool
        Dispersion chart with the chain's modes on top (chains).
    response : bool
        Response chart (needs ``[compute.response]``, or an oscillator scene).
    convergence : bool
        Continuum-convergence chart (needs ``[compute.continuum]``).
    gif : bool
        Animated GIF of the lowest drawn mode.
    window_size : (int, int)
        Size of rendered images in pixels (width, height).
    """

    modes: bool = False
    n_draw: int = 6
    spectrum: bool = False
    dispersion: bool = False
    response: bool = False
    convergence: bool = False
    gif: bool = False
    window_size: tuple[int, int] = (1024, 640)

    @property
    def needs_shapes(self) -> bool:
        """True when a drawing needs mode shapes."""
        return self.modes or self.gif


@dataclass(frozen=True)
class Scene:
    """A validated scene file.

    Build with `Scene.from_dict` or `load_scene`, never ``Scene(**data)``.

    Attributes
    ----------
    source : str
        Where the scene came from (file path), used in messages.
    kind : str
        One of `KINDS`.
    name : str
        Safe file stem (letters, digits, ``_ . -``): output files are ``<name>_<what>.png``.
    title : str
        Human-readable title.
    description : str
        Free text shown in the report.
    units : str
        ``"SI"``, ``"ASE"`` or ``"dimensionless"``.
    system : SystemSpec
    compute : ComputeSpec
    draw : DrawSpec
    """

    source: str
    kind: str
    name: str
    title: str
    description: str
    units: str
    system: SystemSpec
    compute: ComputeSpec
    draw: DrawSpec

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], *, source: str | Path = "<scene>") -> Scene:
        """Validate a parsed scene table and build the `Scene`.

        Parameters
        ----------
        data : Mapping
            The table read from a TOML file.
        source : str or Path
            File name used in error messages; its stem is the default scene name.

        Raises
        ------
        SceneError
            Unknown key (closest valid key suggested), wrong type, impossible value or an
            inconsistent combination, with the file name and key path.
        """
        src = str(source)
        reader = _Reader(src)
        top = reader.table(data, "", {
            "kind": _field(_one_of(*KINDS), required=True),
            "name": _field(_string, Path(src).stem if src != "<scene>" else None),
            "title": _field(_string),
            "description": _field(_string, ""),
            "units": _field(_one_of(*_UNITS)),
            "system": _field(_table_marker, required=True),
            "compute": _field(_table_marker, {}),
            "draw": _field(_table_marker, {}),
        })
        kind = top["kind"]
        name = top["name"]
        if name is None:
            reader.fail("name", "is required when the scene has no file name")
        if not _SAFE_NAME.match(name) or ".." in name:
            given = "name" in data
            reader.fail("name", f"{name!r}{'' if given else ' (the file name, as no name is given)'} "
                        "is not a safe file name: use letters, digits, '_', '.', '-' (no spaces, '/', '..' "
                        "or absolute paths); outputs stay inside the output folder"
                        + ("" if given else "; rename the file or add a name = \"...\" line"))
        units = top["units"] or _DEFAULT_UNITS[kind]
        system = _system(reader, data["system"], kind)
        compute = _compute(reader, data.get("compute", {}), kind)
        draw = _draw(reader, data.get("draw", {}))
        scene = cls(source=src, kind=kind, name=name, title=top["title"] or name,
                    description=top["description"], units=units, system=system,
                    compute=compute, draw=draw)
        _cross_checks(reader, scene)
        return scene

    def dump(self) -> dict[str, Any]:
        """A JSON-ready description of the scene (for summaries), lists for tuples."""
        def plain(value: Any) -> Any:
            if isinstance(value, (tuple, list)):
                return [plain(v) for v in value]
            if isinstance(value, Mapping):
                return {k: plain(v) for k, v in value.items()}
            if hasattr(value, "__dataclass_fields__"):
                return {k: plain(getattr(value, k)) for k in value.__dataclass_fields__}
            return value
        return {k: plain(getattr(self, k)) for k in self.__dataclass_fields__}


def _table_marker(value: Any, fail: Callable[[str], Any]) -> Any:
    if not isinstance(value, dict):
        fail(f"expected a table ([section]), got {_kind_name(value)} ({value!r})")
    return value


class _Reader:
    """Checks tables against field specs, failing with file and key path."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, key: str, message: str) -> Any:
        raise SceneError(self.source, key, message)

    def _failer(self, key: str) -> Callable[[str], Any]:
        def fail(message: str) -> Any:
            return self.fail(key, message)
        return fail

    def table(self, data: Any, path: str, fields: Mapping[str, _Field]) -> dict[str, Any]:
        if not isinstance(data, Mapping):
            self.fail(path, f"expected a table, got {_kind_name(data)} ({data!r})")
        for key in data:
            if key not in fields:
                full = f"{path}.{key}" if path else key
                close = difflib.get_close_matches(key, list(fields), n=1, cutoff=0.6)
                hint = f"; did you mean {close[0]!r}?" if close else ""
                allowed = ", ".join(sorted(fields))
                self.fail(full, f"unknown key{hint} (allowed here: {allowed})")
        out: dict[str, Any] = {}
        for key, spec in fields.items():
            full = f"{path}.{key}" if path else key
            if key not in data:
                if spec.required:
                    self.fail(full, "is required")
                out[key] = spec.default
                continue
            out[key] = spec.check(data[key], self._failer(full))
        return out


def _system(reader: _Reader, data: Any, kind: str) -> SystemSpec:
    if not isinstance(data, Mapping):
        reader.fail("system", f"expected a table, got {_kind_name(data)}")
    builders = [b for b, (kinds, _) in BUILDERS.items() if kind in kinds]
    if "builder" not in data:
        reader.fail("system.builder", f"is required (for kind {kind!r}: {', '.join(builders)})")
    builder = data["builder"]
    if not isinstance(builder, str):
        reader.fail("system.builder", f"expected a string, got {_kind_name(builder)} ({builder!r})")
    if builder not in BUILDERS:
        close = difflib.get_close_matches(builder, list(BUILDERS), n=1, cutoff=0.6)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        reader.fail("system.builder", f"unknown builder {builder!r}{hint} (known: {', '.join(BUILDERS)})")
    kinds, fields = BUILDERS[builder]
    if kind not in kinds:
        reader.fail("system.builder", f"builder {builder!r} does not make a {kind!r} scene "
                    f"(for {kind!r}: {', '.join(builders)})")
    params = {k: v for k, v in data.items() if k != "builder"}
    values = reader.table(params, "system", fields)
    if (values.get("defect_site") is None) != (values.get("defect_mass") is None):
        reader.fail("system.defect_mass", "defect_site and defect_mass go together; give both or neither")
    return SystemSpec(builder=builder, parameters=MappingProxyType(values))


def _band(value: Any, fail: Callable[[str], Any]) -> tuple[float, float]:
    low, high = _list_of(_number, length=2)(value, fail)
    if not low < high:
        fail(f"must be [low, high] with low < high, got {value!r}")
    return (low, high)


def _compute(reader: _Reader, data: Any, kind: str) -> ComputeSpec:
    values = reader.table(data, "compute", {
        "n_modes": _field(_integer(1)),
        "band": _field(_band),
        "shapes": _field(_boolean, False),
        "accuracy": _field(_one_of("high", "fast"), "high"),
        "solver": _field(_one_of("auto", "dense", "tridiagonal", "sparse", "accurate"), "auto"),
        "response": _field(_table_marker),
        "continuum": _field(_table_marker),
        "crosscheck": _field(_boolean, False),
    })
    if values["n_modes"] is not None and values["band"] is not None:
        reader.fail("compute.band", "give either n_modes or band, not both")
    response = None
    if values["response"] is not None:
        r = reader.table(values["response"], "compute.response", {
            "omega_min": _field(_nonnegative, required=True),
            "omega_max": _field(_positive, required=True),
            "n_points": _field(_integer(2, 100_000), 400),
            "alpha": _field(_nonnegative, 0.0),
            "beta": _field(_nonnegative, 0.0),
            "force_site": _field(_integer(0), 0),
            "method": _field(_one_of("direct", "modal"), "direct"),
            "n_modes": _field(_integer(1)),
        })
        if not r["omega_min"] < r["omega_max"]:
            reader.fail("compute.response.omega_max",
                        f"must exceed omega_min ({r['omega_min']:g}), got {r['omega_max']:g}")
        response = ResponseSpec(**r)
    continuum = None
    if values["continuum"] is not None:
        c = reader.table(values["continuum"], "compute.continuum", {
            "modes": _field(_list_of(_integer(1)), (1, 2, 3)),
            "sizes": _field(_list_of(_integer(2, 1_000_000)), (8, 16, 32, 64, 128, 256)),
            "ends": _field(_one_of("free", "fixed", "periodic"), "free"),
        })
        if len(c["sizes"]) < 2:
            reader.fail("compute.continuum.sizes", "needs at least 2 sizes to show convergence")
        if max(c["modes"]) >= min(c["sizes"]):
            reader.fail("compute.continuum.modes",
                        f"mode {max(c['modes'])} needs chains longer than the smallest size {min(c['sizes'])}")
        continuum = ContinuumSpec(**c)
    return ComputeSpec(n_modes=values["n_modes"], band=values["band"], shapes=values["shapes"],
                       accuracy=values["accuracy"], solver=values["solver"], response=response,
                       continuum=continuum, crosscheck=values["crosscheck"])


def _draw(reader: _Reader, data: Any) -> DrawSpec:
    values = reader.table(data, "draw", {
        "modes": _field(_boolean, False),
        "n_draw": _field(_integer(1, 24), 6),
        "spectrum": _field(_boolean, False),
        "dispersion": _field(_boolean, False),
        "response": _field(_boolean, False),
        "convergence": _field(_boolean, False),
        "gif": _field(_boolean, False),
        "window_size": _field(_list_of(_integer(64, 4096), length=2), (1024, 640)),
    })
    return DrawSpec(**values)


def _cross_checks(reader: _Reader, scene: Scene) -> None:
    """Combinations that are individually valid but impossible together."""
    kind, compute, draw = scene.kind, scene.compute, scene.draw
    params = scene.system.parameters
    if draw.response and compute.response is None and kind != "oscillator":
        reader.fail("draw.response", "needs a [compute.response] table")
    if draw.convergence and compute.continuum is None:
        reader.fail("draw.convergence", "needs a [compute.continuum] table")
    if compute.continuum is not None and kind != "chain":
        reader.fail("compute.continuum", f"applies to chains, not to a {kind!r} scene")
    if draw.dispersion and scene.system.builder not in ("linear_chain", "diatomic_chain"):
        reader.fail("draw.dispersion", "needs a linear_chain or diatomic_chain system")
    if compute.crosscheck and not (scene.system.builder == "h2o" or (
            scene.system.builder == "co2" and params["dims"] == 3)):
        reader.fail("compute.crosscheck", "is available for the 3-D molecules 'co2' (dims = 3) and 'h2o'")
    if draw.gif and kind not in ("chain", "molecule"):
        reader.fail("draw.gif", f"animates chains and molecules, not a {kind!r} scene")
    if kind == "oscillator":
        for key in ("modes", "gif", "spectrum", "dispersion"):
            if getattr(draw, key):
                reader.fail(f"draw.{key}", "an oscillator scene draws only its response")
    if scene.system.builder == "springs":
        _check_springs(reader, params)  # before counting: the site count comes from positions
    n_dof = _check_frozen(reader, scene)
    if n_dof is not None:
        if compute.n_modes is not None and compute.n_modes > n_dof:
            reader.fail("compute.n_modes", f"is {compute.n_modes}; the system has only {n_dof} degrees of freedom")
        if compute.response is not None and compute.response.force_site >= n_dof:
            reader.fail("compute.response.force_site",
                        f"is {compute.response.force_site}; degrees of freedom run from 0 to {n_dof - 1}")
        if compute.response is not None and (compute.response.n_modes or 0) > n_dof:
            reader.fail("compute.response.n_modes",
                        f"is {compute.response.n_modes}; the system has only {n_dof} degrees of freedom")
    builder = scene.system.builder
    if builder == "linear_chain":
        n = params["n"]
        for key in ("mass", "stiffness"):
            want = {"mass": n, "stiffness": {"free": n - 1, "fixed": n + 1, "periodic": n}[params["ends"]]}[key]
            value = params[key]
            if isinstance(value, tuple) and len(value) != want:
                reader.fail(f"system.{key}", f"needs {want} values for {n} {params['ends']}-end masses, got {len(value)}")
        if params["defect_site"] is not None and params["defect_site"] >= n:
            reader.fail("system.defect_site", f"is {params['defect_site']}; sites run from 0 to {n - 1}")
    if builder == "diatomic_chain" and isinstance(params["stiffness"], tuple) and len(params["stiffness"]) != 2:
        reader.fail("system.stiffness", f"needs 1 or 2 values (k1, k2), got {len(params['stiffness'])}")
    if builder == "matrices":
        if len(params["M"]) != len(params["K"]):
            reader.fail("system.K", f"must be {len(params['M'])}x{len(params['M'])} like M, got {len(params['K'])}x{len(params['K'])}")
        if params["coordinates"] is not None and len(params["coordinates"]) != len(params["M"]):
            reader.fail("system.coordinates", f"needs {len(params['M'])} names, got {len(params['coordinates'])}")


def _sites_and_dim(scene: Scene) -> tuple[int, int] | None:
    """(number of sites, coordinates per site) of a site-based builder (None otherwise)."""
    p = scene.system.parameters
    builder = scene.system.builder
    if builder == "linear_chain":
        return p["n"], 1
    if builder == "diatomic_chain":
        return 2 * p["n_cells"], 1
    if builder == "beaded_string":
        return p["n"], 2  # (x, y) per bead, x held at rest: transverse motion only
    if builder == "springs":
        first = p["positions"][0]
        return len(p["positions"]), len(first) if isinstance(first, tuple) else 1
    if builder == "co2":
        return 3, p["dims"]
    if builder == "h2o":
        return 3, 3
    return None


def _check_frozen(reader: _Reader, scene: Scene) -> int | None:
    """Check frozen_sites / frozen_dofs against the system's size; return the free dof count.

    None when the count does not follow from the parameters alone.
    """
    p = scene.system.parameters
    builder = scene.system.builder
    if builder == "double_pendulum":
        return 2
    if builder == "matrices":
        return len(p["M"])
    geometry = _sites_and_dim(scene)
    if geometry is None:
        return None
    n_sites, dim = geometry
    frozen = {s * dim for s in range(n_sites)} if builder == "beaded_string" else set()
    for i, site in enumerate(p.get("frozen_sites") or ()):
        if site >= n_sites:
            reader.fail(f"system.frozen_sites[{i}]", f"is {site}; sites run from 0 to {n_sites - 1}")
        frozen.update(site * dim + axis for axis in range(dim))
    for i, dof in enumerate(p.get("frozen_dofs") or ()):
        if dof >= n_sites * dim:
            layout = f" (site * {dim} + axis)" if dim > 1 else ""
            reader.fail(f"system.frozen_dofs[{i}]", f"is {dof}; degrees of freedom{layout} "
                        f"run from 0 to {n_sites * dim - 1}")
        frozen.add(dof)
    n_dof = n_sites * dim - len(frozen)
    if n_dof == 0:
        key = "system.frozen_dofs" if p.get("frozen_dofs") else "system.frozen_sites"
        reader.fail(key, "holds every degree of freedom at rest; nothing is left to vibrate")
    return n_dof


def _check_springs(reader: _Reader, params: Mapping[str, Any]) -> None:
    """Index ranges, anchors and chemical symbols of the 'springs' builder."""
    n_sites = len(params["positions"])
    masses = params["masses"]
    if isinstance(masses, tuple) and len(masses) != n_sites:
        reader.fail("system.masses", f"needs {n_sites} values (one per site), got {len(masses)}")
    for i, pair in enumerate(params["springs"]):
        if max(pair) >= n_sites:
            reader.fail(f"system.springs[{i}]", f"is {list(pair)}; site indices run from 0 to {n_sites - 1}")
        if pair[0] == pair[1]:
            reader.fail(f"system.springs[{i}]", f"is {list(pair)}; a spring joins two different sites")
    stiffness = params["stiffness"]
    if isinstance(stiffness, tuple) and len(stiffness) != len(params["springs"]):
        reader.fail("system.stiffness", f"needs {len(params['springs'])} values (one per spring), got {len(stiffness)}")
    anchors, anchor_stiffness = params["anchors"], params["anchor_stiffness"]
    for i, site in enumerate(anchors or ()):
        if site >= n_sites:
            reader.fail(f"system.anchors[{i}]", f"is {site}; site indices run from 0 to {n_sites - 1}")
    if anchors and anchor_stiffness is None:
        reader.fail("system.anchor_stiffness", "is required with anchors (the stiffness tying each anchor "
                    "to its rest position)")
    if anchor_stiffness is not None and not anchors:
        reader.fail("system.anchor_stiffness", "is given but there are no anchors; add anchors = [site, ...]")
    if isinstance(anchor_stiffness, tuple) and anchors and len(anchor_stiffness) != len(anchors):
        reader.fail("system.anchor_stiffness", f"needs {len(anchors)} values (one per anchor), got {len(anchor_stiffness)}")
    symbols = params["symbols"]
    if symbols is not None:
        if len(symbols) != n_sites:
            reader.fail("system.symbols", f"needs {n_sites} values (one per site), got {len(symbols)}")
        from ase.data import atomic_numbers  # the periodic table only; no calculator

        for i, symbol in enumerate(symbols):
            if symbol not in atomic_numbers:
                reader.fail(f"system.symbols[{i}]", f"is {symbol!r}, not a chemical symbol (e.g. 'H', 'C', 'O')")


# ---------------------------------------------------------------------- files
def load_scene(path: str | Path) -> Scene:
    """Read and validate one scene file.

    Raises
    ------
    SceneError
        Missing or unreadable file, invalid TOML, or an invalid scene.
    """
    file = Path(path)
    try:
        text = file.read_bytes()
    except FileNotFoundError:
        raise SceneError(str(path), "", "file not found") from None
    except OSError as error:
        raise SceneError(str(path), "", f"cannot read file ({error.strerror})") from None
    try:
        data = tomllib.loads(text.decode("utf-8"))
    except UnicodeDecodeError:
        raise SceneError(str(path), "", "not UTF-8 text") from None
    except tomllib.TOMLDecodeError as error:
        raise SceneError(str(path), "", f"invalid TOML: {error}") from None
    return Scene.from_dict(data, source=str(path))


def find_scene_files(paths: Sequence[str | os.PathLike[str]]) -> list[Path]:
    """Scene files named by `paths`: files as given, folders expanded to their ``*.toml``, sorted.

    A path that does not exist is kept (loading it reports "file not found").
    """
    files: list[Path] = []
    for entry in paths:
        path = Path(entry)
        if path.is_dir():
            files.extend(sorted(path.glob("*.toml")))
        else:
            files.append(path)
    return files
