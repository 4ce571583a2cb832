"""A swept scene's table: read from a file, a mapping or a `Scene`; one key set to a value (a deep
copy), or one value of a list (``system.stiffness[1]``); the validated scene of a point.
"""

from __future__ import annotations

import copy
import os
import re
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from vibra.pipeline.scene import BUILDERS, Scene, SceneError, tomllib
from vibra.pipeline.scene.schema import unknown_key
from vibra.pipeline.scene.values import brief, kind_name

__all__ = ["override", "scene_at", "scene_table", "split_key", "strip_none"]

#: The last part of a swept key: a name, then one ``[i]`` per level of a nested list.
_LAST_PART = re.compile(r"^([^\[\]]+)((?:\[\d+\])*)$")
_FORM = ("a swept key must be a dotted path into a table, such as system.defect_mass, with [i] for one value "
         "of a list, such as system.stiffness[1]")


def split_key(key: str, source: str = "<scene>") -> tuple[tuple[str, ...], tuple[int, ...]]:
    """The dotted parts of a swept key and the list indices of its last part.

    >>> split_key("system.stiffness[1]")
    (('system', 'stiffness'), (1,))
    >>> split_key("compute.response.alpha")
    (('compute', 'response', 'alpha'), ())

    Raises
    ------
    SceneError
        Fewer than two parts, an empty part, or brackets that are not ``[i]`` (i >= 0) at the end.
    """
    parts = key.split(".")
    if len(parts) < 2 or not all(parts) or any("[" in p or "]" in p for p in parts[:-1]):
        raise SceneError(source, key, _FORM)
    match = _LAST_PART.match(parts[-1])
    if match is None:
        raise SceneError(source, key, _FORM)
    indices = tuple(int(i) for i in re.findall(r"\[(\d+)\]", match.group(2)))
    return (*parts[:-1], match.group(1)), indices


def override(data: Mapping[str, Any], key: str, value: Any, source: str) -> dict[str, Any]:
    """A deep copy of a scene table with ``data[section][...][name] = value``, or with one value of the
    list there set (``name[i]``, ``name[i][j]``).

    Raises
    ------
    SceneError
        A malformed key (`split_key`); a part that is a value, not a table; for ``name[i]``: a
        name the table does not take (the closest one suggested), a value that is not a list,
        or an index past the list's end (the message gives its length).
    """
    parts, indices = split_key(key, source)
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
    plain = value.tolist() if isinstance(value, np.ndarray) else value
    if not indices:
        node[parts[-1]] = plain
        return out
    name, base = parts[-1], ".".join(parts)
    given = name in node
    if not given:
        node[name] = _default_list(out, parts, key, source)
    holder, slot = node, name
    for level, index in enumerate(indices):
        current = holder[slot]
        where = base + "".join(f"[{i}]" for i in indices[:level])
        default = "" if given or level else " (its default: the scene does not give it)"
        if not isinstance(current, list):
            raise SceneError(source, key, f"{where} is {brief(current)}{default}, {kind_name(current)}, not a list: "
                             f"[{index}] picks one value of a list; give {where} as a list in the scene, or sweep "
                             f"{where} itself")
        if index >= len(current):
            held = f"has {len(current)} value{'' if len(current) == 1 else 's'} (indices 0 to {len(current) - 1})" \
                if current else "is an empty list"
            raise SceneError(source, key, f"index {index} is out of range: {where}{default} {held}")
        holder, slot = current, index
    holder[slot] = plain
    return out


def _default_list(table: Mapping[str, Any], parts: tuple[str, ...], key: str, source: str) -> Any:
    """The value a ``[system]`` key the scene does not give takes (its builder's default, a list for a
    tuple), for ``key`` to pick one of its values; an unknown name is refused with the closest known one."""
    base = ".".join(parts)
    system = table.get("system")
    builder = system.get("builder") if isinstance(system, dict) else None
    if len(parts) != 2 or parts[0] != "system" or not isinstance(builder, str) or builder not in BUILDERS:
        raise SceneError(source, key, f"{base} is not given in the scene, so it has no values to pick from; give "
                         f"{base} as a list in the scene to sweep one of its values")
    fields = BUILDERS[builder][1]
    if parts[1] not in fields:
        raise SceneError(source, key, unknown_key(parts[1], fields))
    default = fields[parts[1]].default
    if default is None:
        raise SceneError(source, key, f"{base} is not given in the scene (and has no default), so it has no values "
                         f"to pick from; give {base} as a list in the scene to sweep one of its values")
    return [list(v) if isinstance(v, tuple) else v for v in default] if isinstance(default, tuple) else default


def scene_at(data: Mapping[str, Any], source: str, values: Mapping[str, object]) -> tuple[Scene, dict[str, Any]]:
    """The validated scene with `values` set, and the table it was built from.

    Raises
    ------
    SceneError
        What `override` refuses, a list swept whole and by one of its values, or what
        `Scene.from_dict` refuses in the point's table.
    """
    for key in values:
        base = ".".join(split_key(key, source)[0])
        if base != key and base in values:
            raise SceneError(source, key, f"{base} is swept too; sweep the list {base} or one of its values, not both")
    table = dict(data)
    for key, value in values.items():
        table = override(table, key, value, source)
    try:
        return Scene.from_dict(table, source=source), table
    except SceneError as error:  # an integer key swept with float values: 3.0 -> 3
        whole = {k: int(v) for k, v in values.items() if isinstance(v, float) and v.is_integer()}
        if not whole or "expected an integer" not in str(error):
            raise
        for key, value in whole.items():
            table = override(table, key, value, source)
        return Scene.from_dict(table, source=source), table


def scene_table(target: object) -> tuple[dict[str, Any], str]:
    """The raw scene table and its source name, from a path, a mapping or a `Scene`."""
    if isinstance(target, Scene):
        data = strip_none(target.dump())
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


def strip_none(value: Any) -> Any:
    """A `Scene.dump` as a scene table: no None values (defaults), no 'source', lists for tuples."""
    if isinstance(value, Mapping):
        return {k: strip_none(v) for k, v in value.items() if v is not None and k != "source"}
    if isinstance(value, (list, tuple)):
        return [strip_none(v) for v in value]
    return value
