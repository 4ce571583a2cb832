"""A swept scene's table: read from a file, a mapping or a `Scene`; one key set to a value (a deep
copy); the validated scene of a point.
"""

from __future__ import annotations

import copy
import os
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from vibra.pipeline.scene import Scene, SceneError, tomllib

__all__ = ["override", "scene_at", "scene_table", "strip_none"]


def override(data: Mapping[str, Any], key: str, value: Any, source: str) -> dict[str, Any]:
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


def scene_at(data: Mapping[str, Any], source: str, values: Mapping[str, Any]) -> tuple[Scene, dict[str, Any]]:
    """The validated scene with `values` set, and the table it was built from."""
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


def scene_table(target: Any) -> tuple[dict[str, Any], str]:
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
