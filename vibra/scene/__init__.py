"""Scene files (TOML) -> frozen `Scene` objects: data only, never code.

A scene states what system to build (a builder from a fixed table and its parameters),
what to compute (how many modes, shapes or not, response, continuum comparison,
cross-check) and what to draw. `load_scene(path)` reads a file with `tomllib` and
`Scene.from_dict(data, source=path)` validates every key before any work: unknown keys
(with the closest valid key suggested), wrong types and impossible values are reported as
`SceneError` with the file name and the key path. The schema is documented in
``docs/scenes.md``.

Nothing in a scene is executed: a builder name is looked up in `BUILD_FUNCTIONS`, a fixed
table, and every value is a number, a string, a boolean or a list of those.

- `vibra.scene.specs`: the frozen parts of a scene (`SystemSpec`, `ComputeSpec`, ...) and
  `SceneError`.
- `vibra.scene.values`: value checks. `vibra.scene.builders`: the builder table, whose
  parameter names, required keys and defaults come from the builders' signatures.
- `vibra.scene.schema`: the tables and the checks of combinations.

>>> scene = Scene.from_dict({"kind": "chain", "system": {"builder": "linear_chain", "n": 4}},
...                         source="four.toml")
>>> scene.name, scene.units, scene.system.parameters["ends"]
('four', 'SI', 'free')
"""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

from vibra.scene.builders import BUILD_FUNCTIONS, BUILDERS, builder_function
from vibra.scene.schema import Reader, check_combinations, parse_compute, parse_draw, parse_system
from vibra.scene.specs import (
    DEFAULT_UNITS, KINDS, SAFE_NAME, UNITS, ComputeSpec, ContinuumSpec, DrawSpec, ResponseSpec, SceneError,
    SystemSpec,
)
from vibra.scene.values import field_spec, one_of, string, table

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = [
    "SceneError", "Scene", "SystemSpec", "ComputeSpec", "ResponseSpec", "ContinuumSpec",
    "DrawSpec", "BUILDERS", "BUILD_FUNCTIONS", "KINDS", "load_scene", "find_scene_files", "builder_function",
    "tomllib",
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
        reader = Reader(src)
        top = reader.table(data, "", {
            "kind": field_spec(one_of(*KINDS), required=True),
            "name": field_spec(string, Path(src).stem if src != "<scene>" else None),
            "title": field_spec(string),
            "description": field_spec(string, ""),
            "units": field_spec(one_of(*UNITS)),
            "system": field_spec(table, required=True),
            "compute": field_spec(table, {}),
            "draw": field_spec(table, {}),
        })
        kind = top["kind"]
        name = top["name"]
        if name is None:
            reader.fail("name", "is required when the scene has no file name")
        if not SAFE_NAME.match(name) or ".." in name:
            given = "name" in data
            reader.fail("name", f"{name!r}{'' if given else ' (the file name, as no name is given)'} "
                        "is not a safe file name: use letters, digits, '_', '.', '-' (no spaces, '/', '..' "
                        "or absolute paths); outputs stay inside the output folder"
                        + ("" if given else "; rename the file or add a name = \"...\" line"))
        units = top["units"] or DEFAULT_UNITS[kind]
        system = parse_system(reader, data["system"], kind)
        compute = parse_compute(reader, data.get("compute", {}), kind)
        draw = parse_draw(reader, data.get("draw", {}))
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
