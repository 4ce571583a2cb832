"""What every modes result shares (`Modes`, `QuadraticModes`): the path that computed it, a
length, indexing and slicing into a smaller result of the same type, a short repr, and a
round trip through a dict or a ``.npz`` file with a format version (ProDy's `Mode` /
`ModeSet` are the model: a result can be stored, reloaded and compared later).

Each result type names its per-mode fields and the axis along which they run
(`PER_MODE`); everything else is carried as it is.
"""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path
from typing import Any, ClassVar, TypeVar

import numpy as np

from vibra._io import atomic_write
from vibra.units import UnitSystem, unit_system

__all__ = ["ModesResult", "FORMAT_VERSION"]

#: The ``.npz`` format written by `ModesResult.save` (read back by `load` when it matches).
FORMAT_VERSION = 1

Result = TypeVar("Result", bound="ModesResult")


class ModesResult:
    """Mixin of the frozen modes dataclasses: `path`, ``len``, ``[...]``, `to_dict` / `from_dict`,
    `save` / `load`, and a short ``repr``.

    `PER_MODE` maps each per-mode field to its mode axis (0 for values, 1 for the columns of a
    vector array) and how many entries each mode has along it (a quadratic mode's two state
    vectors); `PATH_FIELD` names the field holding the path (``solver`` or ``method``).
    A slice keeps the whole-result figures as they are (a residual or an orthogonality is the
    largest over the modes computed, so it bounds the slice's too)."""

    PER_MODE: ClassVar[dict[str, tuple[int, int]]] = {}
    PATH_FIELD: ClassVar[str] = "solver"

    @property
    def path(self) -> str:
        """The solver path that computed this result (`vibra.solvers.registry`)."""
        return str(getattr(self, self.PATH_FIELD))

    def __len__(self) -> int:
        first = next(iter(self.PER_MODE))
        axis, width = self.PER_MODE[first]
        return int(np.shape(getattr(self, first))[axis]) // width

    def __getitem__(self: Result, index: Any) -> Result:
        """The modes at `index` (an int, a slice, an index array or a boolean mask), as a result
        of the same type: ``modes[6:]`` leaves out six rigid-body modes, ``modes[k]`` one mode."""
        if isinstance(index, (int, np.integer)):
            count = len(self)
            if not -count <= int(index) < count:
                raise IndexError(f"mode index {int(index)} is out of range for {count} modes")
            index = slice(int(index) % count, int(index) % count + 1)
        elif not isinstance(index, slice):
            index = np.asarray(index)
            if index.dtype == bool and index.shape != (len(self),):
                raise IndexError(f"a boolean mask must have {len(self)} entries, got shape {index.shape}")
            if index.dtype != bool and not np.issubdtype(index.dtype, np.integer):
                raise IndexError(f"modes are indexed by int, slice, int array or mask, got {index.dtype}")
        chosen = np.arange(len(self))[index]
        changes = {}
        for name, (axis, width) in self.PER_MODE.items():
            value = getattr(self, name)
            if value is not None:
                columns = (chosen[:, None] * width + np.arange(width)).ravel()
                changes[name] = np.take(value, columns, axis=axis)
        return dataclasses.replace(self, **changes)  # type: ignore[type-var]

    def __repr__(self) -> str:
        count = len(self)
        first = next(iter(self.PER_MODE))
        values = np.asarray(getattr(self, first))
        span = ""
        if count and np.isrealobj(values):
            span = f", {first} {values.min():.4g}..{values.max():.4g}"
        return f"{type(self).__name__}({count} modes{span}, path {self.path!r})"

    # --------------------------------------------------------------- storage
    def to_dict(self) -> dict[str, Any]:
        """Every field: arrays as arrays (copies), the units as their fields, `format` the version."""
        out: dict[str, Any] = {"format": FORMAT_VERSION, "type": type(self).__name__}
        for field in dataclasses.fields(self):  # type: ignore[arg-type]
            value = getattr(self, field.name)
            if isinstance(value, UnitSystem):
                value = dataclasses.asdict(value)
            elif isinstance(value, np.ndarray):
                value = value.copy()
            out[field.name] = value
        return out

    @classmethod
    def from_dict(cls: type[Result], data: dict[str, Any]) -> Result:
        """The result `to_dict` gave (unknown keys, a wrong type or another format refused)."""
        if not isinstance(data, dict):
            raise TypeError(f"data must be a dict from to_dict(), got {type(data).__name__}")
        if data.get("format") != FORMAT_VERSION:
            raise ValueError(f"data['format'] is {data.get('format')!r}; this vibra reads format {FORMAT_VERSION}")
        if data.get("type") != cls.__name__:
            raise ValueError(f"data['type'] is {data.get('type')!r}; expected {cls.__name__!r}")
        names = {field.name for field in dataclasses.fields(cls)}  # type: ignore[arg-type]
        unknown = sorted(set(data) - names - {"format", "type"})
        if unknown:
            raise ValueError(f"data has unknown keys {unknown}; {cls.__name__} has {sorted(names)}")
        values = {name: data[name] for name in names if name in data}
        if isinstance(values.get("units"), dict):
            values["units"] = _units(values["units"])
        return cls(**values)

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write this result to `path` (a ``.npz`` file: arrays, and the rest as JSON), atomically."""
        target = Path(path)
        if target.suffix != ".npz":
            raise ValueError(f"path must end in .npz, got {str(target)!r}")
        data = self.to_dict()
        arrays = {key: value for key, value in data.items() if isinstance(value, np.ndarray)}
        scalars = {key: value for key, value in data.items() if not isinstance(value, np.ndarray)}
        scalars = {key: (float(value) if isinstance(value, (np.floating, float)) else value)
                   for key, value in scalars.items()}

        def write(temporary: Path) -> None:
            with open(temporary, "wb") as stream:  # (a file object: np.savez adds no suffix)
                np.savez(stream, __scalars__=np.array(json.dumps(scalars, allow_nan=True)), **arrays)

        return atomic_write(target, write, suffix=".npz")

    @classmethod
    def load(cls: type[Result], path: str | os.PathLike[str]) -> Result:
        """The result `save` wrote to `path` (no pickled objects are read)."""
        with np.load(Path(path), allow_pickle=False) as stored:
            if "__scalars__" not in stored.files:
                raise ValueError(f"{path}: not a vibra result file (no __scalars__ entry)")
            data: dict[str, Any] = json.loads(str(stored["__scalars__"]))
            for key in stored.files:
                if key != "__scalars__":
                    data[key] = stored[key]
        return cls.from_dict(data)


def _units(fields: dict[str, Any]) -> UnitSystem:
    """The named unit system where the fields match one, else one built from them."""
    try:
        named = unit_system(str(fields.get("name")))
        if dataclasses.asdict(named) == fields:
            return named
    except (TypeError, ValueError):
        pass
    return UnitSystem(**fields)
