"""Scene files (TOML) -> frozen `Scene` objects: data only, never code.

A scene states what system to build (a builder from a fixed table and its parameters),
what to compute (how many modes, shapes or not, response, continuum comparison,
cross-check) and what to draw. `load_scene(path)` reads a file with `tomllib` and
`Scene.from_dict(data, source=path)` validates every key before any work: unknown keys
(with the closest valid key suggested), wrong types and impossible values are reported as
`SceneError` with the file name and the key path, every problem of every section at once
(`SceneError.errors`). The schema is documented in
``docs/scenes.md``.

Nothing in a scene is executed: a builder name is looked up in `BUILD_FUNCTIONS`, a fixed
table, and every value is a number, a string, a boolean or a list of those.

- `vibra.pipeline.scene.specs`: the frozen parts of a scene (`SystemSpec`, `ComputeSpec`, ...) and
  `SceneError`.
- `vibra.pipeline.scene.values`: value checks. `vibra.pipeline.scene.builders`: the builder table, whose
  parameter names, required keys and defaults come from the builders' signatures.
- `vibra.pipeline.scene.schema`: the tables and the checks of combinations.

>>> scene = Scene.from_dict({"kind": "chain", "system": {"builder": "linear_chain", "n": 4}},
...                         source="four.toml")
>>> scene.name, scene.units, scene.system.parameters["ends"]
('four', 'SI', 'free')
"""

from __future__ import annotations

import os
import re
import stat
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

from vibra.pipeline.scene.builders import BUILD_FUNCTIONS, builder_function
from vibra.pipeline.scene.dynamics import DynamicsSpec
from vibra.pipeline.scene.files import scene_inputs
from vibra.pipeline.scene.kinds import BUILDERS, DEFAULT_UNITS, KINDS, SCENE_KINDS, SceneKind
from vibra.pipeline.scene.schema import Reader, check_combinations, parse_compute, parse_draw, parse_system
from vibra.pipeline.scene.specs import (
    SAFE_NAME, UNITS, units_name, ComputeSpec, ContinuumSpec, CrystalSpec, DrawSpec, ResponseSpec, SceneError,
    SystemSpec,
)
from vibra.pipeline.scene.values import field_spec, one_of, string, table

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = [
    "SceneError", "Scene", "SystemSpec", "ComputeSpec", "ResponseSpec", "ContinuumSpec",
    "DrawSpec", "CrystalSpec", "DynamicsSpec", "BUILDERS", "BUILD_FUNCTIONS", "KINDS", "SCENE_KINDS", "SceneKind",
    "load_scene", "find_scene_files", "builder_function",
    "tomllib", "MAX_SCENE_BYTES", "MAX_SCENE_DEPTH", "read_scene_bytes", "parse_scene_text",
    "scene_inputs",
]



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
    crystal : CrystalSpec or None
        What a crystal scene computes and draws (its own ``[compute]`` and ``[draw]`` keys);
        None for the other kinds.
    dynamics : DynamicsSpec or None
        What a dynamics scene integrates and draws (its own ``[compute]`` and ``[draw]`` keys);
        None for the other kinds.
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
    crystal: CrystalSpec | None = None
    dynamics: DynamicsSpec | None = None

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
            inconsistent combination, with the file name and key path. Every key of every
            section is checked before it is raised: one error carries all their problems
            (`SceneError.errors`, one line each in its message). The combinations of valid
            values are checked after that, and the first one that fails is raised.
        """
        src = str(source)
        reader = Reader(src)
        errors: list[SceneError] = []

        def section(read: Any) -> Any:  # one section: its problems collected, the next one read too
            try:
                value = read()
            except SceneError as error:
                errors.append(error)
                reader.pending = []
                return None
            if reader.pending:
                errors.append(reader.take())
                return None
            return value

        # a bad kind or [system] stops here (the sections depend on them); any other problem is noted
        top = reader.table(data, "", {
            "kind": field_spec(one_of(*KINDS), required=True),
            "name": field_spec(string, Path(src).stem if src != "<scene>" else None),
            "title": field_spec(string),
            "description": field_spec(string, ""),
            "units": field_spec(units_name),  # through vibra.units.unit_system, as the library reads units
            "system": field_spec(table, required=True),
            "compute": field_spec(table, {}),
            "draw": field_spec(table, {}),
        })
        kind = top["kind"]
        name = top["name"]
        if name is None:
            reader.note("name", "is required when the scene has no file name")
        elif not SAFE_NAME.match(name) or ".." in name:
            given = "name" in data
            reader.note("name", f"{name!r}{'' if given else ' (the file name, as no name is given)'} "
                        "is not a safe file name: use letters, digits, '_', '.', '-' (no spaces, '/', '..' "
                        "or absolute paths); outputs stay inside the output folder"
                        + ("" if given else "; rename the file or add a name = \"...\" line"))
        if reader.pending:
            errors.append(reader.take())
        units = top["units"] or DEFAULT_UNITS[kind]
        system = section(lambda: parse_system(reader, top["system"], SCENE_KINDS[kind]))
        own = SCENE_KINDS[kind].tables
        if own is not None:  # a kind with its own [compute] and [draw] keys
            parse, check, field = own.parse, own.check, own.field
            parsed = section(lambda: parse(reader, top["compute"], top["draw"]))
            if errors:
                raise SceneError.combine(errors)
            draw, spec = parsed
            scene = cls(source=src, kind=kind, name=name, title=top["title"] or name,
                        description=top["description"], units=units, system=system,
                        compute=ComputeSpec(), draw=draw, **{field: spec})
            check(reader, scene)
            return scene
        compute = section(lambda: parse_compute(reader, top["compute"], kind))
        draw = section(lambda: parse_draw(reader, top["draw"]))
        if errors:  # every problem of every section at once; the combinations need them all valid
            raise SceneError.combine(errors)
        scene = cls(source=src, kind=kind, name=name, title=top["title"] or name,
                    description=top["description"], units=units, system=system,
                    compute=compute, draw=draw)
        check_combinations(reader, scene)
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


#: Largest scene file `load_scene` reads, in bytes (1 MiB; the bundled scenes are under 2 KiB).
MAX_SCENE_BYTES = 1 << 20
#: Deepest nesting of lists and tables a scene may use (a matrix is 2 deep, ``compute.response`` 2).
MAX_SCENE_DEPTH = 8

#: Brackets and braces nested this deep in a file's text refuse it before the TOML parser runs:
#: tomllib recurses per level, so whether a deeper file parses (and reaches the `MAX_SCENE_DEPTH`
#: check, which names the key) or raises RecursionError would depend on the interpreter's
#: recursion limit, which other libraries raise; at 100 levels every limit parses.
MAX_TEXT_DEPTH = 100

#: What holds no nesting in TOML text: strings (multi-line first) and comments.
_NOT_NESTING = re.compile(r'"""[\s\S]*?"""|\'\'\'[\s\S]*?\'\'\'|"(?:\\.|[^"\\\n])*"|\'[^\'\n]*\'|#[^\n]*')


def read_scene_bytes(path: str | os.PathLike[str]) -> bytes:
    """The bytes of the scene file `path`, read only when it is a regular file of at most `MAX_SCENE_BYTES`.

    A FIFO, a device (a symlink to ``/dev/zero``), a socket or a folder is refused before
    anything is read, so a bad path can neither hang the command nor fill the memory.

    Raises
    ------
    SceneError
        Missing, unreadable, not a regular file, or larger than `MAX_SCENE_BYTES`.
    """
    source = str(path)
    try:
        info = os.stat(path)  # follows symlinks: the target is what would be read
    except FileNotFoundError:
        raise SceneError(source, "", "file not found (or a symlink to a missing file)") from None
    except OSError as error:
        raise SceneError(source, "", f"cannot read file ({error.strerror}); expected a readable scene file") from None
    if stat.S_ISDIR(info.st_mode):
        raise SceneError(source, "", "is a folder; expected a scene file (a folder is expanded only when "
                         "given on the command line)")
    if not stat.S_ISREG(info.st_mode):
        what = ("a FIFO" if stat.S_ISFIFO(info.st_mode) else "a device" if stat.S_ISCHR(info.st_mode)
                or stat.S_ISBLK(info.st_mode) else "a socket" if stat.S_ISSOCK(info.st_mode) else "not a file")
        raise SceneError(source, "", f"is {what}, not a regular file; scene files are read from regular files "
                         "only (nothing was read)")
    if info.st_size > MAX_SCENE_BYTES:
        raise SceneError(source, "", f"is {info.st_size} bytes; a scene file may hold at most "
                         f"{MAX_SCENE_BYTES} bytes (1 MiB)")
    try:
        descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    except OSError as error:
        raise SceneError(source, "", f"cannot read file ({error.strerror}); expected a readable scene file") from None
    try:
        if not stat.S_ISREG(os.fstat(descriptor).st_mode):  # replaced between stat and open
            raise SceneError(source, "", "is not a regular file; scene files are read from regular files only")
        chunks, size = [], 0
        while size <= MAX_SCENE_BYTES:
            chunk = os.read(descriptor, MAX_SCENE_BYTES + 1 - size)
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
    except OSError as error:
        raise SceneError(source, "", f"cannot read file ({error.strerror}); expected a readable scene file") from None
    finally:
        os.close(descriptor)
    if size > MAX_SCENE_BYTES:
        raise SceneError(source, "", f"holds more than {MAX_SCENE_BYTES} bytes; a scene file may hold at most "
                         "1 MiB")
    return b"".join(chunks)


def _text_depth(text: str) -> int:
    """The deepest nesting of [ and { in TOML text, strings and comments left out (a table
    header's brackets open and close on its line, so they add 1 at most)."""
    depth = deepest = 0
    for mark in re.findall(r"[\[\]{}]", _NOT_NESTING.sub("", text)):
        depth = depth + 1 if mark in "[{" else max(depth - 1, 0)
        deepest = max(deepest, depth)
    return deepest


def _depth(data: Any) -> tuple[int, str]:
    """Deepest nesting of lists and tables in `data` and the key path that reaches it (no recursion)."""
    deepest, where = 0, ""
    stack: list[tuple[Any, int, str]] = [(data, 0, "")]
    while stack:
        value, level, path = stack.pop()
        if level > deepest:
            deepest, where = level, path
        if level > MAX_SCENE_DEPTH:
            break
        if isinstance(value, dict):
            stack.extend((v, level + 1, f"{path}.{k}" if path else str(k)) for k, v in value.items())
        elif isinstance(value, list):
            stack.extend((v, level + 1, f"{path}[{i}]") for i, v in enumerate(value))
    return deepest, where


def parse_scene_text(data: bytes, source: str) -> dict[str, Any]:
    """The TOML table in `data` (UTF-8, a leading byte-order mark allowed), nesting checked.

    Raises
    ------
    SceneError
        Not UTF-8, invalid TOML, or lists and tables nested deeper than `MAX_SCENE_DEPTH`.
    """
    try:
        text = data.decode("utf-8-sig")  # editors on some systems start UTF-8 files with a BOM
    except UnicodeDecodeError as error:
        raise SceneError(source, "", f"not UTF-8 text (byte {error.start}); save the file as UTF-8") from None
    if _text_depth(text) > MAX_TEXT_DEPTH:
        raise SceneError(source, "", f"lists or tables nested too deeply to parse; a scene nests at most "
                         f"{MAX_SCENE_DEPTH} levels")
    try:
        parsed = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise SceneError(source, "", f"invalid TOML: {error}") from None
    except RecursionError:
        raise SceneError(source, "", f"lists or tables nested too deeply to parse; a scene nests at most "
                         f"{MAX_SCENE_DEPTH} levels") from None
    depth, where = _depth(parsed)
    if depth > MAX_SCENE_DEPTH:
        raise SceneError(source, where.split("[", 1)[0], f"nested more than {MAX_SCENE_DEPTH} levels deep; a scene "
                         f"nests at most {MAX_SCENE_DEPTH} levels (a matrix is 2)")
    return parsed


def load_scene(path: str | os.PathLike[str]) -> Scene:
    """Read and validate one scene file.

    The file must be a regular file of at most `MAX_SCENE_BYTES` (checked before reading),
    UTF-8 (a byte-order mark is allowed) and TOML nested at most `MAX_SCENE_DEPTH` levels.

    Raises
    ------
    SceneError
        Missing, unreadable, not a regular file, too large, invalid TOML, or an invalid scene.
    """
    data = parse_scene_text(read_scene_bytes(path), str(path))
    return Scene.from_dict(data, source=str(path))


def find_scene_files(paths: Sequence[str | os.PathLike[str]]) -> list[Path]:
    """Scene files named by `paths`: files as given, folders expanded to their ``*.toml`` and those of
    their subfolders (``networks`` finds ``networks/ubiquitin/ubiquitin-anm.toml``), sorted, a folder's
    own files before its subfolders'.

    Hidden folders (``.vibra``, ``.git``) and folder links (which could loop) are not entered.
    A path that does not exist is kept (loading it reports "file not found").
    """
    files: list[Path] = []
    for entry in paths:
        path = Path(entry)
        if path.is_dir():
            files.extend(_folder_scenes(path))
        else:
            files.append(path)
    return files


def _folder_scenes(folder: Path) -> list[Path]:
    """The ``*.toml`` of `folder`, then those of its subfolders in name order (recursively)."""
    found = sorted(p for p in folder.glob("*.toml") if not p.is_dir())
    for sub in sorted(p for p in folder.iterdir() if p.is_dir() and not p.is_symlink() and not p.name.startswith(".")):
        found.extend(_folder_scenes(sub))
    return found
