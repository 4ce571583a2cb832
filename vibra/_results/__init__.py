"""What every result type shares (`Result`): a short one-line repr, ``len`` and indexing or
slicing along its natural axis into a smaller result of the same type, a round trip through
`to_dict` / `from_dict` and through a ``.npz`` file with a format version (`save` / `load`),
and `path`, how it was computed (ProDy's `Mode` / `ModeSet` are the model: a result can be
stored, reloaded and compared later).

A result type is a frozen dataclass that subclasses `Result` and declares:

- `STORED`: how each array field is stored (`Stored`: its shape in named sizes such as
  ``("n_dof", "n_modes")`` and its kind of number). The other fields (numbers, names, the
  units, tuples of them) are kept as JSON and checked against their annotations.
- `AXIS`: the named size along which ``len`` and slicing run (``"n_modes"``, ``"n_q"``,
  ``"n_t"``, ``"n_records"``, ...), and `NOUNS` to name it in the repr; every field whose
  declared shape has that size is sliced along it, and so is every tuple in `SIZED` with it.
- `PATH_FIELD` (the field that says how it was computed: ``solver``, ``method``,
  ``integrator``), or a `path` field or property of its own; `path` is the one name.
- `NESTED`: fields that are results themselves (stored as ``"field.entry"`` arrays).

A type whose stored form differs from its fields (a table of rows stored as columns) declares
`SCALARS` and overrides the hooks `_stored_fields` / `_from_stored`; `_sliced` adjusts fields
that index the axis (a band structure's segments), `_repr_parts` adds to the repr.

A result file is checked whole before use (`vibra._results.files`: headers first, never an
array, before any is read), and `from_dict` runs the same checks on a dict; every refusal is
one line naming the file (or ``data[...]``) and the entry.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import json
import os
import types
import typing
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, ClassVar, Sequence, TypeVar

import numpy as np

from vibra._core.frozen import Frozen, owned_arrays, short_repr, span
from vibra._core.filesystem import atomic_write
from vibra._results.files import (FORMAT_VERSION, MAX_JSON_DEPTH, MAX_LOAD_BYTES, MAX_SCALARS_BYTES, Dim, Layout,
                                  Stored, check_stored, check_version, read_result_file, sequence_lengths, short,
                                  stored)
from vibra.units import UnitSystem, unit_system

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from vibra._results.display import View
# (a `vibra.System` is typed Any here: vibra.system imports this package)

__all__ = ["Result", "ModesResult", "layout", "axis_arrays", "FORMAT_VERSION", "MAX_LOAD_BYTES",
           "MAX_SCALARS_BYTES", "MAX_JSON_DEPTH", "Dim", "Stored", "stored", "check_stored"]

R = TypeVar("R", bound="Result")


class Result(Frozen):
    """Base of the frozen result dataclasses: `path`, ``len``, ``[...]``, `to_dict` / `from_dict`,
    `save` / `load`, and a short ``repr`` (module docstring).

    A slice keeps the whole-result figures as they are (a residual or an error bound is the
    largest over what was computed, so it bounds the slice's too)."""

    STORED: ClassVar[dict[str, Stored]] = {}
    AXIS: ClassVar[str] = ""
    NOUNS: ClassVar[tuple[str, str]] = ("entry", "entries")
    SIZED: ClassVar[dict[str, str]] = {}
    NESTED: ClassVar[dict[str, type[Result]]] = {}
    PATH_FIELD: ClassVar[str] = ""
    PATH: ClassVar[str] = ""
    SCALARS: ClassVar[dict[str, Any] | None] = None

    @property
    def path(self) -> str:
        """How this result was computed: a solver path, a method, a model (a short name)."""
        return str(getattr(self, self.PATH_FIELD)) if self.PATH_FIELD else self.PATH

    # ------------------------------------------------------------------ the axis
    def __len__(self) -> int:
        """The size along `AXIS` (modes, q-points, temperatures, records, rows, ...)."""
        for name, (axis, width) in axis_arrays(type(self)).items():
            value = getattr(self, name)
            if value is not None:
                return int(np.shape(value)[axis]) // width
        for name in _sized_fields(type(self)):
            return len(getattr(self, name))
        raise TypeError(f"a {type(self).__name__} has no axis to measure")

    def __getitem__(self: R, index: int | slice | ArrayLike) -> R:
        """The entries at `index` along `AXIS` (an int, a slice, an index array or a boolean mask),
        as a result of the same type: ``modes[6:]`` leaves out six rigid-body modes, ``modes[k]``
        keeps one mode, ``bands[:50]`` the first 50 q-points."""
        count, (noun, nouns) = len(self), self.NOUNS
        if isinstance(index, (int, np.integer)):
            if not -count <= int(index) < count:
                raise IndexError(f"{noun} index {int(index)} is out of range for {count} {nouns}")
            index = slice(int(index) % count, int(index) % count + 1)
        elif not isinstance(index, slice):
            index = np.asarray(index)
            if index.dtype == bool and index.shape != (count,):
                raise IndexError(f"a boolean mask must have {count} entries, got shape {index.shape}")
            if index.dtype != bool and not np.issubdtype(index.dtype, np.integer):
                raise IndexError(f"{nouns} are indexed by int, slice, int array or mask, got {index.dtype}")
        chosen = np.arange(count)[index]
        changes: dict[str, Any] = {}
        for name, (axis, width) in axis_arrays(type(self)).items():
            value = getattr(self, name)
            if value is not None:
                columns = (chosen[:, None] * width + np.arange(width)).ravel()
                changes[name] = np.take(value, columns, axis=axis)
        for name in _sized_fields(type(self)):
            value = getattr(self, name)
            changes[name] = tuple(value[int(k)] for k in chosen)
        for name, part in self.NESTED.items():
            if part.AXIS == self.AXIS:
                changes[name] = getattr(self, name)[chosen]
        changes.update(self._sliced(chosen))
        return dataclasses.replace(self, **changes)  # type: ignore[type-var]

    def _sliced(self, chosen: np.ndarray[Any, Any]) -> dict[str, Any]:
        """Fields other than the axis's arrays that a slice at `chosen` changes (none by default)."""
        return {}

    # ------------------------------------------------------------------ repr
    def __repr__(self) -> str:
        units = getattr(self, "units", None)
        unit = f"{units.name} units" if isinstance(units, UnitSystem) else f"{units} units" if units else ""
        return short_repr(self, *self._repr_parts(), f"path {self.path!r}", unit)

    def _repr_parts(self) -> tuple[str, ...]:
        """What the repr says before the path and the units: the sizes first (`_size`), then
        spans and choices, never arrays."""
        return (self._size(),)

    def _size(self) -> str:
        """'12 modes': the size along the axis."""
        count = len(self)
        return f"{count} {self.NOUNS[count != 1]}"

    # ------------------------------------------------------------------ storage
    def to_dict(self) -> dict[str, Any]:
        """Every stored field: arrays as arrays (copies), the units as their fields, ``format`` the
        version and ``type`` the type's name."""
        return {"format": FORMAT_VERSION, "type": type(self).__name__, **self._stored_fields()}

    def _stored_fields(self) -> dict[str, Any]:
        """The stored form: each field as it is (a part in `NESTED` as its ``"name.entry"`` arrays)."""
        out: dict[str, Any] = {}
        for field in dataclasses.fields(self):  # type: ignore[arg-type]
            value = getattr(self, field.name)
            if field.name in self.NESTED:
                out.update({f"{field.name}.{key}": part for key, part in value._stored_fields().items()})
            elif isinstance(value, UnitSystem):
                out[field.name] = dataclasses.asdict(value)
            else:
                out[field.name] = value.copy() if isinstance(value, np.ndarray) else value
        return out

    @classmethod
    def from_dict(cls: type[R], data: dict[str, Any]) -> R:
        """The result `to_dict` gave, checked whole first (`check_stored`): the format version and
        type, no unknown or missing key, every field of its kind, and every array's shape
        consistent with the others (``omega`` of 3 values with 5 x 5 ``vectors`` is refused).

        Raises
        ------
        TypeError
            `data` is not a dict.
        ValueError
            What `check_stored` refuses, naming the key (``data['vectors'] has shape ...``).
        """
        if not isinstance(data, dict):
            raise TypeError(f"data must be a dict from to_dict(), got {type(data).__name__}")
        return _build(cls, data, lambda key: f"data[{key!r}]", owned=False)

    @classmethod
    def _from_stored(cls: type[R], values: dict[str, Any], where: Callable[[str], str]) -> R:
        """The result from its checked stored form (`where(key)` names a key in messages)."""
        return cls(**values)

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write this result to `path` (a ``.npz`` file: arrays, and the rest as JSON), atomically
        (`vibra._core.filesystem.atomic_write`: a regular file or a new name, never an input of the run)."""
        target = Path(path)
        if target.suffix != ".npz":
            raise ValueError(f"path must end in .npz, got {str(target)!r}")
        data = self.to_dict()
        arrays = {key: value for key, value in data.items() if isinstance(value, np.ndarray)}
        scalars = {key: _plain(value) for key, value in data.items() if not isinstance(value, np.ndarray)}

        def write(temporary: Path) -> None:
            with open(temporary, "wb") as stream:  # (a file object: np.savez adds no suffix)
                np.savez(stream, __scalars__=np.array(json.dumps(scalars, allow_nan=True)), **arrays)

        return atomic_write(target, write, suffix=".npz")

    @classmethod
    def load(cls: type[R], path: str | os.PathLike[str], *, max_bytes: int | None = None) -> R:
        """The result `save` wrote to `path`, checked whole before any array is read.

        The file is opened as a zip archive and its entries' ``.npy`` headers are read first:
        the format version and type, every entry a known field of numbers (never Python
        objects: nothing is unpickled), the declared shapes consistent with each other
        (`check_stored`) and with the bytes each entry holds, and their total within
        `max_bytes`. Only then are the arrays read.

        Parameters
        ----------
        path : path-like
            A ``.npz`` file written by `save`.
        max_bytes : int, optional
            Most bytes the arrays may declare together (default `MAX_LOAD_BYTES`, 2 GiB); a
            genuine larger result loads with a larger value.

        Raises
        ------
        FileNotFoundError
            No file at `path`.
        ValueError
            Anything else wrong with the file, in one line naming the file and the entry.
        """
        limit = MAX_LOAD_BYTES if max_bytes is None else max_bytes
        if isinstance(limit, bool) or not isinstance(limit, (int, np.integer)) or limit < 0:
            raise ValueError(f"max_bytes is {max_bytes!r}; expected a number of bytes >= 0")
        name = str(path)
        data = read_result_file(layout(cls), Path(path), int(limit))
        return _build(cls, data, lambda key: f"{name}: {key}", owned=True)


class ModesResult(Result):
    """`Result` of modes (`vibra.Modes`, `QuadraticModes`): ``len`` counts modes, the repr spans
    the first per-mode field."""

    AXIS: ClassVar[str] = "n_modes"
    NOUNS: ClassVar[tuple[str, str]] = ("mode", "modes")
    PATH_FIELD: ClassVar[str] = "solver"

    def _repr_parts(self) -> tuple[str, ...]:
        first = next(iter(axis_arrays(type(self))))
        values = np.asarray(getattr(self, first))
        return (self._size(), f"{first} {span(values)}" if values.size and np.isrealobj(values) else "")

    def show(self, system: Any, indices: Sequence[int] | None = None) -> View:
        """The interactive 3-D view of these modes on `system` (`vibra._results.display.system_view`):
        the report's viewer, a `View` that Jupyter shows as the cell's value (``_repr_html_``), offline
        (3Dmol.js, about 530 kB, inlined once per output), or `View.save` writes as a page.

        A `Modes` holds no positions, so the system it was computed from draws it. By default the
        non-zero modes are embedded, at most what `system_view` caps (the cell says what was left out).

        Parameters
        ----------
        system : System
            The system these modes belong to (a chain, molecule, network or any System with sites).
        indices : sequence of int, optional
            The modes to show (default: every mode that is not a zero mode).

        Examples
        --------
        >>> import vibra
        >>> chain = vibra.System.from_springs([0.0, 1.0, 2.0], 1.0, [[0, 1], [1, 2]], 1.0)
        >>> chain.modes().show(chain)
        View(2 modes of 'system')
        """
        from vibra._results.display import system_view

        return system_view(system, self, indices)


# ---------------------------------------------------------------------- the layout of a type
@functools.cache
def layout(cls: type[Result]) -> Layout:
    """How `cls` is stored (`vibra._results.files.Layout`): its arrays (its parts' as
    ``"name.entry"``), sized sequences, other fields with their types, and required entries."""
    parts = {f"{name}.{key}": spec for name, part in cls.NESTED.items() for key, spec in part.STORED.items()}
    arrays = {**cls.STORED, **parts}
    if cls.SCALARS is not None:
        scalars = dict(cls.SCALARS)
        required = {*scalars, *(key for key, spec in cls.STORED.items() if not spec.optional)}
    else:
        hints = typing.get_type_hints(cls)
        fields = [field for field in dataclasses.fields(cls) if field.name not in cls.NESTED]  # type: ignore[arg-type]
        scalars = {field.name: hints[field.name] for field in fields if field.name not in arrays}
        required = {field.name for field in fields
                    if field.default is dataclasses.MISSING and field.default_factory is dataclasses.MISSING}
    required |= {key for key, spec in parts.items() if not spec.optional}
    return Layout(cls.__name__, arrays, dict(cls.SIZED), scalars, frozenset(required))


@functools.cache
def axis_arrays(cls: type[Result]) -> dict[str, tuple[int, int]]:
    """Each array field of `cls` that runs along its `AXIS`: that axis's position in the field's shape,
    and how many entries each index has there (2 for a quadratic mode's pair of state vectors)."""
    fields = {field.name for field in dataclasses.fields(cls)}  # type: ignore[arg-type]
    out = {}
    for name, spec in cls.STORED.items():
        for axis, dim in enumerate(spec.shapes[0]):
            if name in fields and (dim == cls.AXIS or (isinstance(dim, tuple) and dim[0] == cls.AXIS)):
                out[name] = (axis, 1 if isinstance(dim, str) else dim[1])
    return out


@functools.cache
def _sized_fields(cls: type[Result]) -> tuple[str, ...]:
    """The tuple fields of `cls` whose length is the axis (`SIZED`)."""
    fields = {field.name for field in dataclasses.fields(cls)}  # type: ignore[arg-type]
    return tuple(name for name, size in cls.SIZED.items() if size == cls.AXIS and name in fields)


# ---------------------------------------------------------------------- building a result
def _plain(value: Any) -> Any:
    """`value` as JSON writes it: numpy numbers as Python numbers, tuples as lists."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (list, tuple)):
        return [_plain(item) for item in value]
    if isinstance(value, dict):
        return {key: _plain(item) for key, item in value.items()}
    return value


def _build(cls: type[R], data: dict[str, Any], where: Callable[[str], str], *, owned: bool) -> R:
    """The result of type `cls` from a dict of its stored form, checked whole first."""
    spec = layout(cls)
    check_version(spec.name, data, where)
    keys = [*spec.arrays, *spec.scalars]
    unknown = sorted(set(data) - set(keys) - {"format", "type"}, key=str)
    if unknown:
        raise ValueError(f"{where(str(unknown[0]))} is not a field of {cls.__name__} (unknown keys {unknown}); "
                         f"expected keys among {sorted(keys)}")
    missing = [key for key in keys if key in spec.required and key not in data]
    if missing:
        raise ValueError(f"{where(missing[0])} is missing; a {cls.__name__} needs {sorted(spec.required)}")
    values: dict[str, Any] = {}
    declared: dict[str, tuple[tuple[int, ...], np.dtype[Any]] | None] = {}
    for key in spec.arrays:
        if key not in data:
            continue
        value = data[key]
        if value is not None:
            if not isinstance(value, np.ndarray):
                try:
                    value = np.asarray(value, dtype=str if spec.arrays[key].kind == "text" else None)
                except (ValueError, TypeError):  # ragged lists
                    raise ValueError(f"{where(key)} is not an array of numbers ({type(value).__name__})") from None
            declared[key] = (value.shape, value.dtype)
        else:
            declared[key] = None
        values[key] = value
    check_stored(spec, declared, where, sequence_lengths(spec, data))
    for key, value in values.items():
        kind = spec.arrays[key].kind
        if value is None:
            continue
        if kind in ("real", "number") and value.dtype.kind in "iu" or kind == "complex" and value.dtype.kind != "c":
            value = value.astype(complex if kind == "complex" else float)  # (a hand-made dict)
        if spec.arrays[key].finite and not np.all(np.isfinite(value)):
            bad = tuple(int(i) for i in np.argwhere(~np.isfinite(value))[0])
            raise ValueError(f"{where(key)}[{', '.join(map(str, bad))}] is {value[bad]}; expected finite values")
        values[key] = value
    for key, hint in spec.scalars.items():
        if key in data:
            values[key] = _convert(data[key], hint, key, where)
    for name, part in cls.NESTED.items():  # a part's arrays become the part
        entries = {key.partition(".")[2]: values.pop(key) for key in list(values) if key.startswith(f"{name}.")}
        values[name] = part(**entries)
    with owned_arrays() if owned else contextlib.nullcontext():  # arrays just read: frozen without a copy
        return cls._from_stored(values, where)


_REFUSED = object()


def _convert(value: Any, hint: Any, key: str, where: Callable[[str], str]) -> Any:
    """`value` as the field `key` of type `hint` takes it: a number, a str, a bool, None, a
    UnitSystem, a Literal, or a tuple of these (from a JSON list)."""
    options = typing.get_args(hint) if typing.get_origin(hint) in (typing.Union, types.UnionType) else (hint,)
    for option in options:
        out = _convert_one(value, option, key, where)
        if out is not _REFUSED:
            return out
    names = " or ".join(_hint_name(option) for option in options)
    raise ValueError(f"{where(key)} is {short(value)} ({type(value).__name__}); expected {names}")


def _convert_one(value: Any, option: Any, key: str, where: Callable[[str], str]) -> Any:
    number = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))
    if option is type(None):
        return None if value is None else _REFUSED
    if option is float:
        return float(value) if number else _REFUSED
    if option is int:
        return int(value) if number and isinstance(value, (int, np.integer)) else _REFUSED
    if option is bool:
        return bool(value) if isinstance(value, (bool, np.bool_)) else _REFUSED
    if option is str:
        return value if isinstance(value, str) else _REFUSED
    if option is UnitSystem:
        if isinstance(value, dict):
            return _units(value, where(key))
        return value if isinstance(value, UnitSystem) else _REFUSED
    if typing.get_origin(option) is typing.Literal:
        return value if value in typing.get_args(option) and isinstance(value, str) else _REFUSED
    if typing.get_origin(option) is tuple:
        if not isinstance(value, (list, tuple)):
            return _REFUSED
        items = typing.get_args(option)
        if len(items) == 2 and items[1] is Ellipsis:
            items = (items[0],) * len(value)
        elif len(items) != len(value):
            return _REFUSED
        return tuple(_convert(item, hint, f"{key}[{i}]", where) for i, (item, hint) in enumerate(zip(value, items)))
    return value if isinstance(option, type) and isinstance(value, option) else _REFUSED


def _hint_name(option: Any) -> str:
    if option is type(None):
        return "None"
    if typing.get_origin(option) is typing.Literal:
        return " or ".join(map(repr, typing.get_args(option)))
    if typing.get_origin(option) is tuple:
        items = typing.get_args(option)
        return f"a list of {_hint_name(items[0])}" if items[1:] == (Ellipsis,) else f"a list of {len(items)} values"
    return getattr(option, "__name__", str(option))


def _units(fields: dict[str, Any], where: str) -> UnitSystem:
    """The named unit system where the fields match one, else one built from them."""
    names = [field.name for field in dataclasses.fields(UnitSystem)]
    if set(fields) != set(names):
        raise ValueError(f"{where} has keys {sorted(map(str, fields))}; expected {names}")
    try:
        named = unit_system(str(fields.get("name")))
        if dataclasses.asdict(named) == fields:
            return named
    except (TypeError, ValueError):
        pass
    try:
        return UnitSystem(**fields)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{where}: {error}") from None
