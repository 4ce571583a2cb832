"""The scene schema: tables checked key by key, and combinations checked together.

`Reader.table` checks one table against its fields (unknown keys are refused with the
closest valid key suggested); `parse_system`, `parse_compute` and `parse_draw` read the three
sections; `check_combinations` checks what is valid alone but impossible together. The
``[system]`` keys come from `vibra.pipeline.scene.builders` (derived from the builders' signatures)
and the solver names from `vibra.solvers.names.SOLVER_NAMES`.
"""

from __future__ import annotations

import difflib
from dataclasses import fields as dataclass_fields
from types import MappingProxyType
from typing import Any, Collection, Mapping, NoReturn

from vibra.solvers.names import SOLVER_NAMES as SOLVERS
from vibra.solvers.accuracy import DEFAULT as DEFAULT_ACCURACY, LEVELS as ACCURACY_LEVELS, uses_springs
from vibra._core.text import counted
from vibra.pipeline.scene.limits import (
    DEFAULT_TIME_LIMIT_S, all_modes_seconds, default_memory_limit, gib, memory_estimate, n_dof_bound, sites_and_dim,
)
from vibra.pipeline.scene.builders import BUILD_FUNCTIONS, builder_fields, planar
from vibra.pipeline.scene.files import check_phonopy_scene_files, scene_data_path
from vibra.pipeline.scene.specs import (
    FREQUENCY_UNITS, ComputeSpec, ContinuumSpec, CrystalSpec, DrawSpec, ResponseSpec, SceneError, SystemSpec,
)
from vibra.pipeline.scene.values import (
    Fail, FieldSpec, boolean, brief, element_symbol, field_spec, integer, kind_name, list_of, nonnegative, number, one_of, positive,
    string, table,
)

# A `Scene` and a `SceneKind` are typed Any here: the scene package and its kinds import this module
# (naming them would close an import cycle, even for type checkers).

__all__ = ["Reader", "unknown_key", "parse_system", "parse_compute", "parse_draw", "check_combinations", "parse_crystal",
           "check_crystal"]


class Reader:
    """Checks tables against field specs, failing with file and key path, and collects what it finds.

    `table` checks every key of a table before it stops: an unknown key, a missing required key
    and a bad value each become a problem in `pending`, and the table's values come back with
    the default in place of a bad one, so the next table of the section is checked too. A bad
    required key stops the section at once (what follows needs it), and so does `fail`, the
    check of a combination: with problems pending it raises those instead of its own, which may
    only echo them (a bad ``compute.temperature`` read as absent is "required" again).
    `Scene.from_dict` runs each section, takes `pending` after it (`take`), and raises them all.
    """

    def __init__(self, source: str) -> None:
        self.source = source
        self.pending: list[SceneError] = []

    def fail(self, key: str, message: str) -> NoReturn:
        if self.pending:
            raise self.take()
        raise SceneError(self.source, key, message)

    def note(self, key: str, message: str) -> None:
        """A problem that stops nothing: checking goes on, and the scene is refused at the end."""
        self.pending.append(SceneError(self.source, key, message))

    def take(self) -> SceneError:
        """The pending problems as one `SceneError` (`SceneError.combine`), cleared from the reader."""
        error = SceneError.combine(self.pending)
        self.pending = []
        return error

    def _failer(self, key: str) -> Fail:
        def fail(message: str) -> NoReturn:
            raise SceneError(self.source, key, message)
        return fail

    def table(self, data: Any, path: str, fields: Mapping[str, FieldSpec]) -> dict[str, Any]:
        if not isinstance(data, Mapping):
            self.note(path, f"expected a table, got {kind_name(data)} ({brief(data)})")
            raise self.take()
        before = len(self.pending)
        for key in data:
            if key not in fields:
                full = f"{path}.{key}" if path else str(key)
                full = full if len(full) <= 60 and "\n" not in full else brief(full).strip("'")
                self.note(full, unknown_key(str(key), fields))
        out: dict[str, Any] = {}
        stop = False
        for key, spec in fields.items():
            full = f"{path}.{key}" if path else key
            if key not in data:
                if spec.required:
                    self.note(full, "is required")
                    stop = True
                out[key] = spec.default
                continue
            try:
                out[key] = spec.check(data[key], self._failer(full))
            except SceneError as error:
                self.pending.append(error)
                out[key] = spec.default
                stop = stop or spec.required
        if stop and len(self.pending) > before:
            raise self.take()
        return out


def unknown_key(key: str, allowed: Collection[str]) -> str:
    """The problem of an unknown key: the closest allowed key suggested, then all of them."""
    close = difflib.get_close_matches(key, list(allowed), n=1, cutoff=0.6)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    return f"unknown key{hint} (allowed here: {', '.join(sorted(allowed))})"


def parse_system(reader: Reader, data: Any, scene_kind: Any) -> SystemSpec:
    """The ``[system]`` table of a scene of `scene_kind`: a builder that makes that kind, and its keys."""
    kind = scene_kind.name
    if not isinstance(data, Mapping):
        reader.fail("system", f"expected a table, got {kind_name(data)}")
    def builders() -> str:  # (read only for a message: listing them imports the lattice builders)
        return ", ".join(b for b in BUILD_FUNCTIONS if scene_kind.makes(b))

    if "builder" not in data:
        reader.fail("system.builder", f"is required (for kind {kind!r}: {builders()})")
    builder = data["builder"]
    if not isinstance(builder, str):
        reader.fail("system.builder", f"expected a string, got {kind_name(builder)} ({brief(builder)})")
    if builder not in BUILD_FUNCTIONS:
        close = difflib.get_close_matches(builder, list(BUILD_FUNCTIONS), n=1, cutoff=0.6)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        reader.fail("system.builder", f"unknown builder {brief(builder)}{hint} (known: {', '.join(BUILD_FUNCTIONS)})")
    if not scene_kind.makes(builder):
        reader.fail("system.builder", f"builder {builder!r} does not make a {kind!r} scene "
                    f"(for {kind!r}: {builders()})")
    params = {k: v for k, v in data.items() if k != "builder"}
    values = reader.table(params, "system", builder_fields(builder))
    if (values.get("defect_site") is None) != (values.get("defect_mass") is None):
        reader.fail("system.defect_mass", "defect_site and defect_mass go together; give both or neither")
    return SystemSpec(builder=builder, parameters=MappingProxyType(values))


def _band(value: Any, fail: Fail) -> tuple[float, float]:
    low, high = list_of(number, length=2)(value, fail)
    if not low < high:
        fail(f"must be [low, high] with low < high, got {brief(value)}")
    return (low, high)


def parse_compute(reader: Reader, data: Any, kind: str) -> ComputeSpec:
    values = reader.table(data, "compute", {
        "n_modes": field_spec(integer(1)),
        "band": field_spec(_band),
        "shapes": field_spec(boolean, False),
        "accuracy": field_spec(one_of(*ACCURACY_LEVELS), DEFAULT_ACCURACY),
        "solver": field_spec(one_of(*SOLVERS), "auto"),
        "response": field_spec(table),
        "continuum": field_spec(table),
        "crosscheck": field_spec(boolean, False),
        "memory_limit_gib": field_spec(positive),
        "time_limit_s": field_spec(positive),
    })
    if values["n_modes"] is not None and values["band"] is not None:
        reader.fail("compute.band", "give either n_modes or band, not both")
    response = None
    if values["response"] is not None:
        r = reader.table(values["response"], "compute.response", {
            "omega_min": field_spec(nonnegative, required=True),
            "omega_max": field_spec(positive, required=True),
            "n_points": field_spec(integer(2, 100_000), 400),
            "alpha": field_spec(nonnegative, 0.0),
            "beta": field_spec(nonnegative, 0.0),
            "force_site": field_spec(integer(0), 0),
            "method": field_spec(one_of("direct", "modal"), "direct"),
            "n_modes": field_spec(integer(1)),
        })
        if r["n_modes"] is not None and r["method"] != "modal":
            reader.fail("compute.response.n_modes", "applies to method = \"modal\" only (the direct method "
                        "solves the full system at every frequency); remove n_modes or set method = \"modal\"")
        if not r["omega_min"] < r["omega_max"]:
            reader.fail("compute.response.omega_max",
                        f"must exceed omega_min ({r['omega_min']:g}), got {r['omega_max']:g}")
        response = ResponseSpec(**r)
    continuum = None
    if values["continuum"] is not None:
        c = reader.table(values["continuum"], "compute.continuum", {
            "modes": field_spec(list_of(integer(1)), (1, 2, 3)),
            "sizes": field_spec(list_of(integer(2, 1_000_000)), (8, 16, 32, 64, 128, 256)),
            "ends": field_spec(one_of("free", "fixed", "periodic"), "free"),
        })
        if len(c["sizes"]) < 2:
            reader.fail("compute.continuum.sizes", "needs at least 2 sizes to show convergence")
        for i in range(1, len(c["sizes"])):
            if c["sizes"][i] <= c["sizes"][i - 1]:
                reader.fail(f"compute.continuum.sizes[{i}]", f"is {c['sizes'][i]} <= sizes[{i - 1}] = "
                            f"{c['sizes'][i - 1]}; the chain lengths must increase")
        if max(c["modes"]) >= min(c["sizes"]):
            reader.fail("compute.continuum.modes",
                        f"mode {max(c['modes'])} needs chains longer than the smallest size {min(c['sizes'])}")
        continuum = ContinuumSpec(**c)
    if values["solver"] == "sparse" and values["n_modes"] is None and values["band"] is None:
        reader.fail("compute.solver", "'sparse' computes a few modes; give compute.n_modes or compute.band, "
                    "or choose another solver")
    if values["solver"] == "accurate" and not uses_springs(values["accuracy"]):
        reader.fail("compute.solver", "'accurate' needs accuracy = \"high\" or \"certified\" (the fast path drops the spring "
                    "factor the accurate solver works on)")
    return ComputeSpec(n_modes=values["n_modes"], band=values["band"], shapes=values["shapes"],
                       accuracy=values["accuracy"], solver=values["solver"], response=response,
                       continuum=continuum, crosscheck=values["crosscheck"],
                       memory_limit_gib=values["memory_limit_gib"], time_limit_s=values["time_limit_s"])


#: The checkers of the ``[draw]`` keys that are not charts (a chart's key is a boolean:
#: `DrawSpec.chart_keys`); the defaults are `DrawSpec`'s own.
_DRAW_CHECKS = {"modes": boolean, "n_draw": integer(1, 24), "gif": boolean,
                "window_size": list_of(integer(64, 4096), length=2)}


def parse_draw(reader: Reader, data: Any) -> DrawSpec:
    charts = DrawSpec.chart_keys()
    fields = {}
    for spec in dataclass_fields(DrawSpec):  # in the fields' order: where errors list them
        check = boolean if spec.name in charts else _DRAW_CHECKS.get(spec.name)
        if check is None:
            raise TypeError(f"DrawSpec.{spec.name} has no checker: make it a chart_key, or add it to _DRAW_CHECKS")
        fields[spec.name] = field_spec(check, spec.default)
    values = reader.table(data, "draw", fields)
    return DrawSpec(**values)


def check_combinations(reader: Reader, scene: Any) -> None:
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
    if draw.dispersion and scene.system.builder == "linear_chain":
        for key in ("mass", "stiffness"):
            if isinstance(params[key], tuple):
                reader.fail("draw.dispersion", f"needs a uniform chain, but system.{key} is a list; a chain of "
                            "unequal masses or springs has no single dispersion relation (for a two-site cell "
                            "use builder = \"diatomic_chain\", for one heavier site defect_site and defect_mass)")
    if scene.system.builder == "molecule":
        _check_molecule(reader, params)
    if compute.crosscheck and not (scene.system.builder == "h2o" or (
            scene.system.builder == "co2" and params["dims"] == 3)):
        reader.fail("compute.crosscheck", "is available for the 3-D molecules 'co2' (dims = 3) and 'h2o'")
    if draw.gif and kind not in ("chain", "molecule"):
        reader.fail("draw.gif", f"animates chains and molecules, not a {kind!r} scene")
    if scene.system.builder in ("anm", "gnm"):
        scene_data_path(reader.source, "system.pdb", params["pdb"])
        for key in ("gif", "dispersion", "response"):
            if getattr(draw, key):
                reader.fail(f"draw.{key}", "a network scene draws its slowest modes on the C-alpha trace "
                            "(draw.modes), the B-factors (draw.bfactors) and the spectrum")
    for key, chart in DrawSpec.chart_keys().items():  # the kinds each chart applies to, from its DrawSpec field
        if getattr(draw, key) and chart.kinds is not None and kind not in chart.kinds:
            reader.fail(f"draw.{key}", f"{chart.purpose}, not of a {kind!r} scene")
    if scene.system.builder == "charged_particle":
        _check_gyroscopic(reader, compute, draw)
    if kind == "oscillator":
        for key in ("modes", "gif", "spectrum", "dispersion"):
            if getattr(draw, key):
                reader.fail(f"draw.{key}", "an oscillator scene draws only its response")
    _check_memory(reader, scene)  # before anything counts sites one by one
    if scene.system.builder == "springs":
        _check_springs(reader, params)  # before counting: the site count comes from positions
    n_dof = _check_frozen(reader, scene)
    if n_dof is not None:
        if compute.n_modes is not None and compute.n_modes > n_dof:
            reader.fail("compute.n_modes", f"is {compute.n_modes}; the system has only {counted(n_dof, 'degree of freedom')}")
        if compute.response is not None and compute.response.force_site >= n_dof:
            reader.fail("compute.response.force_site",
                        f"is {compute.response.force_site}; degrees of freedom run from 0 to {n_dof - 1}")
        if compute.response is not None and (compute.response.n_modes or 0) > n_dof:
            reader.fail("compute.response.n_modes",
                        f"is {compute.response.n_modes}; the system has only {counted(n_dof, 'degree of freedom')}")
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


def _check_gyroscopic(reader: Reader, compute: ComputeSpec, draw: DrawSpec) -> None:
    """A gyroscopic scene (M q'' + G q' + K q = 0) solves all its complex modes and draws their orbits
    (and its forced response, `vibra.response` taking G: K - w^2 M + i w (C + G))."""
    for key in ("n_modes", "band"):
        if getattr(compute, key) is not None:
            reader.fail(f"compute.{key}", "a gyroscopic system is solved for all its modes (complex shapes); "
                        f"remove {key}")
    for key in ("spectrum", "gif", "dispersion"):
        if getattr(draw, key):
            reader.fail(f"draw.{key}", "a gyroscopic scene draws its mode orbits (draw.modes), its forced "
                        "response (draw.response) and lists its frequencies in the table")


def _check_memory(reader: Reader, scene: Any) -> None:
    """Refuse a scene whose memory or time estimate (`limits`) exceeds its limit, before any work."""
    compute = scene.compute
    estimate = memory_estimate(scene.system.builder, scene.system.parameters, compute, scene.draw)
    if estimate is None:
        return
    limit = default_memory_limit() if compute.memory_limit_gib is None else compute.memory_limit_gib * 2**30
    if estimate.total > limit:
        source = "compute.memory_limit_gib" if compute.memory_limit_gib is not None else (
            "half the physical memory, or less under ulimit -v or a cgroup limit")
        reader.fail(estimate.key, f"would need about {gib(estimate.total)} of memory (mostly {estimate.largest}), "
                    f"more than the limit of {gib(limit)} ({source}); ask for {estimate.advice}, or raise "
                    "compute.memory_limit_gib if the machine has the memory")
    seconds = all_modes_seconds(scene.system.builder, scene.system.parameters, compute)
    time_limit = DEFAULT_TIME_LIMIT_S if compute.time_limit_s is None else compute.time_limit_s
    if seconds > time_limit:
        n_dof = n_dof_bound(scene.system.builder, scene.system.parameters)
        reader.fail("compute.n_modes", f"is not given, so all {n_dof} modes are asked for: O(N^2) work, about "
                    f"{seconds:.2g} s, more than the limit of {time_limit:g} s (compute.time_limit_s); ask for "
                    "compute.n_modes or compute.band (a partial solver), or raise compute.time_limit_s")


def _check_frozen(reader: Reader, scene: Any) -> int | None:
    """Check frozen_sites / frozen_dofs against the system's size; return the free dof count.

    None when the count does not follow from the parameters alone.
    """
    p = scene.system.parameters
    builder = scene.system.builder
    if builder in ("double_pendulum", "charged_particle"):
        return 2
    if builder == "matrices":
        return len(p["M"])
    geometry = sites_and_dim(builder, p)
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


def _check_springs(reader: Reader, params: Mapping[str, Any]) -> None:
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
            if element_symbol(symbol) not in atomic_numbers:
                reader.fail(f"system.symbols[{i}]", f"is {symbol!r}, not a chemical symbol (e.g. 'H', 'C', 'O'; "
                            "'D' and 'T' for hydrogen's isotopes)")


def _check_molecule(reader: Reader, params: Mapping[str, Any]) -> None:
    """The 'molecule' builder: a name or an .xyz file beside the scene (inside its folder), isotopes or masses."""
    if (params["name"] is None) == (params["xyz"] is None):
        reader.fail("system.name", "give the molecule as name = \"CH4\" (any ase.build.molecule name) or as "
                    "xyz = \"file.xyz\" (a file beside the scene), one of the two")
    if params["xyz"] is not None:
        scene_data_path(reader.source, "system.xyz", params["xyz"])
    if params["isotopes"] is not None and params["masses"] is not None:
        reader.fail("system.masses", "give isotopes (labels) or masses (amu), not both")
    _check_engine(reader, params)


def _check_engine(reader: Reader, params: Mapping[str, Any]) -> None:
    """``engine``, ``method`` and ``basis`` by name (`vibra.molecules.engines.choice`: nothing runs); a
    missing package is left to `vibra validate` and the report (`vibra.pipeline.plan.electronic`)."""
    if params.get("engine") is None and params.get("method") is None and params.get("basis") is None:
        return
    from vibra.molecules.engines.choice import EngineChoiceError, EngineMissingError, check_engine_choice

    try:
        choice = check_engine_choice(params.get("engine"), params.get("method"), params.get("basis"), require=False)
    except EngineChoiceError as error:
        reader.fail(f"system.{error.key}", str(error))
    except EngineMissingError:
        return
    if choice.electronic:
        for key in ("stretch", "bend", "torsion"):
            if params.get(key) is not None:
                reader.fail(f"system.{key}", f"sets the bundled force field, but engine = {choice.engine!r} "
                            "computes the molecule; remove it")


# ---------------------------------------------------------------------- crystal scenes
def _path_runs(value: Any, fail: Fail) -> tuple[tuple[str, ...], ...]:
    """``["GAMMA", "X", "L"]`` (one run) or ``[["GAMMA", "X"], ["L", "GAMMA"]]`` (runs with breaks)."""
    if not isinstance(value, list) or not value:
        fail(f"expected a list of point labels or a list of runs of them, got {kind_name(value)} ({brief(value)})")
    runs = [value] if all(isinstance(v, str) for v in value) else value
    out = []
    for r, run in enumerate(runs):
        labels = list_of(string, min_length=2)(run, lambda m, r=r: fail(f"[{r}] {m}" if len(runs) > 1 else m))
        out.append(labels)
    return tuple(out)


def _wave_vector(value: Any, fail: Fail) -> str | tuple[float, ...]:
    """A special-point label (``"X"``) or 3 fractional coordinates."""
    if isinstance(value, str):
        return value
    return list_of(number, length=3)(value, fail)


def parse_crystal(reader: Reader, compute: Any, draw: Any) -> tuple[DrawSpec, CrystalSpec]:
    """The ``[compute]`` and ``[draw]`` tables of a crystal scene."""
    c = reader.table(compute, "compute", {
        "path": field_spec(_path_runs),
        "npoints": field_spec(integer(2, 100_000), 300),
        "mesh": field_spec(list_of(integer(1, 200), length=3), (16, 16, 16)),
        "dos": field_spec(one_of("tetrahedron", "gaussian"), "tetrahedron"),
        "temperatures": field_spec(list_of(nonnegative, length=2), (0.0, 1000.0)),
        "n_temperatures": field_spec(integer(2, 10_000), 101),
    })
    d = reader.table(draw, "draw", {
        "bands": field_spec(boolean, True),
        "frequency_unit": field_spec(one_of(*FREQUENCY_UNITS), "THz"),
        "thermal": field_spec(boolean, False),
        "mode": field_spec(boolean, False),
        "mode_q": field_spec(_wave_vector, "X"),
        "mode_branch": field_spec(integer(0), 0),
        "supercell": field_spec(list_of(integer(1, 12), length=3), (4, 4, 4)),
        "frames": field_spec(integer(2, 120), 24),
        "window_size": field_spec(list_of(integer(64, 4096), length=2), (1024, 640)),
    })
    low, high = c["temperatures"]
    if not low < high:
        reader.fail("compute.temperatures", f"must be [low, high] in K with low < high, got [{low:g}, {high:g}]")
    spec = CrystalSpec(path=c["path"], npoints=c["npoints"], mesh=c["mesh"], dos_method=c["dos"],
                       temperatures=(low, high), n_temperatures=c["n_temperatures"], bands=d["bands"],
                       frequency_unit=d["frequency_unit"], thermal=d["thermal"], mode=d["mode"],
                       mode_q=d["mode_q"], mode_branch=d["mode_branch"], supercell=d["supercell"],
                       frames=d["frames"])
    return DrawSpec(window_size=d["window_size"]), spec


def check_crystal(reader: Reader, scene: Any) -> None:
    """What a crystal scene's keys must agree on before anything is built."""
    spec, builder, params = scene.crystal, scene.system.builder, scene.system.parameters
    if not (spec.bands or spec.thermal or spec.mode):
        reader.fail("draw", "a crystal scene draws nothing: set draw.bands, draw.thermal or draw.mode to true")
    if builder == "phonopy":
        if scene.units != "ASE":
            reader.fail("units", f"is {scene.units!r}; a phonopy file is in phonopy's units (eV, Angstrom, amu): "
                        "use units = \"ASE\"")
        check_phonopy_scene_files(reader.source, params)  # inside the folder and whole, at each key
    elif scene.units == "dimensionless":
        reader.fail("units", "is 'dimensionless'; a crystal scene draws frequencies in THz or cm^-1 and thermal "
                    "properties in kJ/mol: use units = \"ASE\" (eV, Angstrom, amu) or \"SI\"")
    if planar(builder):
        if spec.supercell[2] != 1:
            reader.fail("draw.supercell", f"is {list(spec.supercell)}; a 2-D crystal has one cell along z (the "
                        "vacuum axis): use [n1, n2, 1]")
        if spec.mesh[2] != 1:
            reader.fail("compute.mesh", f"is {list(spec.mesh)}; a 2-D crystal needs 1 point along z: use [n1, n2, 1]")
