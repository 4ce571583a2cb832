"""What every modes result shares (`Modes`, `QuadraticModes`): the path that computed it, a
length, indexing and slicing into a smaller result of the same type, a short repr, and a
round trip through a dict or a ``.npz`` file with a format version (ProDy's `Mode` /
`ModeSet` are the model: a result can be stored, reloaded and compared later).

Each result type declares how its arrays are stored (`STORED`: per field, its shape in named
sizes such as ``("n_dof", "n_modes")`` and its kind of number); the per-mode fields and their
mode axis (`PER_MODE`) follow from it, and everything else is carried as it is.

**A result file is checked whole before use** (`ModesResult.load`, one mechanism for every
result type): the ``.npy`` headers of the archive's entries are read first (never an array),
and the format version, the type, each entry's kind of number (never Python objects: nothing
is unpickled), the declared shapes against each other (`check_stored`) and against the bytes
each entry holds, and their total against `MAX_LOAD_BYTES` (``load(path, max_bytes=...)``
raises it) are checked before any array is read. Every refusal is one line naming the file
and the entry: ``modes.npz: vectors has shape (5, 5); expected (n_dof, n_modes) with
n_modes = 3 as in omega``. `from_dict` runs the same checks on a dict.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import json
import math
import os
import stat
import types
import typing
import zipfile
import zlib
from pathlib import Path
from typing import Any, Callable, ClassVar, Literal, TypeVar, Union

import numpy as np

from vibra._frozen import owned_arrays
from vibra._io import atomic_write, describe_kind
from vibra.units import UnitSystem, unit_system

__all__ = ["ModesResult", "FORMAT_VERSION", "MAX_LOAD_BYTES", "MAX_SCALARS_BYTES", "Stored", "stored",
           "check_stored"]

#: The ``.npz`` format written by `ModesResult.save` (read back by `load` when it matches).
FORMAT_VERSION = 1

#: Most bytes the arrays of one result file may declare together before `load` reads any
#: (2 GiB: the vectors and shapes of a 10,000-dof result take 1.6 GB); raise it per call with
#: ``load(path, max_bytes=...)``.
MAX_LOAD_BYTES = 2 * 1024**3

#: Most bytes of a result file's JSON entry (its numbers and names other than arrays), in bytes.
MAX_SCALARS_BYTES = 1024**2
#: Deepest nesting of brackets the JSON part may have: vibra writes 3 levels; a hostile file of
#: 10^5 levels would overflow the C stack of json's scanner when the recursion limit is raised.
MAX_JSON_DEPTH = 32

#: A named size of a stored array (``"n_modes"``), that size times a factor (``("n_modes", 2)``),
#: or a fixed size (``2``).
Dim = Union[str, tuple[str, int], int]

#: The named size along which modes run (`PER_MODE` is derived from it).
MODES = "n_modes"

#: dtype kinds accepted for each kind of number.
_KINDS = {"real": "fiu", "complex": "cfiu", "bool": "b"}
_WORDS = {"real": "real numbers", "complex": "complex numbers", "bool": "booleans"}

Result = TypeVar("Result", bound="ModesResult")


@dataclasses.dataclass(frozen=True)
class Stored:
    """How one array field of a result is stored.

    Attributes
    ----------
    shapes : tuple of tuple of Dim
        The shapes it may have, in named sizes (the first that fits is taken).
    kind : {"real", "complex", "bool"}
        Its kind of number (integers are accepted as real numbers).
    optional : bool
        Whether it may be None.
    finite : bool
        Whether every value must be finite (checked after reading).
    """

    shapes: tuple[tuple[Dim, ...], ...]
    kind: Literal["real", "complex", "bool"]
    optional: bool = False
    finite: bool = False


def stored(*shapes: tuple[Dim, ...], kind: Literal["real", "complex", "bool"] = "real", optional: bool = False,
           finite: bool = False) -> Stored:
    """`Stored` with its shapes given one after the other: ``stored(("n_dof",), ("n_dof", "n_dof"))``."""
    return Stored(tuple(shapes), kind, optional, finite)


class ModesResult:
    """Mixin of the frozen modes dataclasses: `path`, ``len``, ``[...]``, `to_dict` / `from_dict`,
    `save` / `load`, and a short ``repr``.

    `STORED` maps each array field to how it is stored (`Stored`); `PER_MODE`, derived from it,
    maps each per-mode field to its mode axis (the position of ``n_modes``) and how many
    entries each mode has along it (a quadratic mode's two state vectors). `PATH_FIELD` names
    the field holding the path (``solver`` or ``method``). The first field of `STORED` gives
    the length. A slice keeps the whole-result figures as they are (a residual or an
    orthogonality is the largest over the modes computed, so it bounds the slice's too)."""

    STORED: ClassVar[dict[str, Stored]] = {}
    PER_MODE: ClassVar[dict[str, tuple[int, int]]] = {}
    PATH_FIELD: ClassVar[str] = "solver"

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        per_mode = {}
        for name, spec in cls.STORED.items():
            for axis, dim in enumerate(spec.shapes[0]):
                if dim == MODES or (isinstance(dim, tuple) and dim[0] == MODES):
                    per_mode[name] = (axis, 1 if isinstance(dim, str) else dim[1])
        cls.PER_MODE = per_mode

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

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write this result to `path` (a ``.npz`` file: arrays, and the rest as JSON), atomically
        (`vibra._io.atomic_write`: a regular file or a new name, never an input of the run)."""
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
    def load(cls: type[Result], path: str | os.PathLike[str], *, max_bytes: int | None = None) -> Result:
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
        data = _read_result_file(cls, Path(path), int(limit))
        return _build(cls, data, lambda key: f"{name}: {key}", owned=True)


def check_stored(cls: type[ModesResult], layouts: dict[str, tuple[tuple[int, ...], np.dtype[Any]] | None],
                 where: Callable[[str], str]) -> None:
    """Check the arrays of a stored `cls` from their shapes and dtypes alone (no value is read).

    `layouts` maps each array field present to ``(shape, dtype)`` (None for a field stored as
    None); `where(key)` names a key in messages. Each field must be of its kind (`Stored`),
    and each named size (``n_modes``, ``n_dof``) the same in every field that has it.

    Raises
    ------
    ValueError
        A field of the wrong kind or shape, in one line naming it and the field it disagrees with.
    """
    sizes: dict[str, tuple[int, str]] = {}  # name -> (size, the field that set it)
    for key, spec in cls.STORED.items():
        if key not in layouts:
            continue
        layout = layouts[key]
        if layout is None:
            if not spec.optional:
                raise ValueError(f"{where(key)} is None; expected a {_describe(spec.shapes[0])} array of "
                                 f"{_WORDS[spec.kind]}")
            continue
        shape, dtype = layout
        if dtype.kind not in _KINDS[spec.kind]:
            what = "Python objects (vibra stores numbers only: nothing is unpickled)" if dtype.hasobject else \
                f"{dtype} values"
            raise ValueError(f"{where(key)} holds {what}; expected {_WORDS[spec.kind]}")
        for pattern in spec.shapes:
            found = _match(pattern, shape, sizes)
            if found is not None:
                for size_name, size in found.items():
                    sizes.setdefault(size_name, (size, key))
                break
        else:
            known = {n: sizes[n] for pattern in spec.shapes for n in _names(pattern) if n in sizes}
            given = "; ".join(f"{n} = {size} as in {field}" for n, (size, field) in known.items())
            wanted = " or ".join(_describe(pattern) for pattern in spec.shapes)
            raise ValueError(f"{where(key)} has shape {tuple(shape)}; expected {wanted}"
                             + (f" with {given}" if given else ""))


def _names(pattern: tuple[Dim, ...]) -> list[str]:
    return [d if isinstance(d, str) else d[0] for d in pattern if not isinstance(d, int)]


def _describe(pattern: tuple[Dim, ...]) -> str:
    parts = [str(d) if isinstance(d, (str, int)) else f"{d[1]} {d[0]}" for d in pattern]
    return f"({parts[0]},)" if len(parts) == 1 else f"({', '.join(parts)})"


def _match(pattern: tuple[Dim, ...], shape: tuple[int, ...], sizes: dict[str, tuple[int, str]]
           ) -> dict[str, int] | None:
    """The named sizes `shape` gives under `pattern`, or None when it does not fit it or `sizes`."""
    if len(shape) != len(pattern):
        return None
    found: dict[str, int] = {}
    for dim, actual in zip(pattern, shape):
        if isinstance(dim, int):
            if actual != dim:
                return None
            continue
        name, factor = (dim, 1) if isinstance(dim, str) else dim
        if actual % factor:
            return None
        size = actual // factor
        known = found.get(name, sizes.get(name, (size, ""))[0])
        if known != size:
            return None
        found[name] = size
    return found


@functools.cache
def _scalar_fields(cls: type[ModesResult]) -> dict[str, Any]:
    """Each field not in `STORED` and the Python type its annotation names."""
    hints = typing.get_type_hints(cls)
    return {field.name: hints[field.name] for field in dataclasses.fields(cls)  # type: ignore[arg-type]
            if field.name not in cls.STORED}


def _check_scalar(key: str, value: Any, hint: Any, where: Callable[[str], str]) -> Any:
    """`value` as the field `key` of type `hint` takes it (a float, a str, None, a UnitSystem)."""
    options = typing.get_args(hint) if typing.get_origin(hint) in (typing.Union, types.UnionType) else (hint,)
    if value is None and type(None) in options:
        return None
    if float in options and isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool):
        return float(value)
    if str in options and isinstance(value, str):
        return value
    if UnitSystem in options:
        if isinstance(value, UnitSystem):
            return value
        if isinstance(value, dict):
            return _units(value, where(key))
    names = " or ".join("None" if option is type(None) else getattr(option, "__name__", str(option))
                        for option in options)
    raise ValueError(f"{where(key)} is {_short(value)} ({type(value).__name__}); expected {names}")


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _build(cls: type[Result], data: dict[str, Any], where: Callable[[str], str], *, owned: bool) -> Result:
    """The result of type `cls` from a dict of its fields, checked whole first."""
    _check_version(cls, data, where)
    fields = {field.name: field for field in dataclasses.fields(cls)}  # type: ignore[arg-type]
    unknown = sorted(set(data) - set(fields) - {"format", "type"}, key=str)
    if unknown:
        raise ValueError(f"{where(str(unknown[0]))} is not a field of {cls.__name__} (unknown keys {unknown}); "
                         f"expected keys among {sorted(fields)}")
    missing = [name for name, field in fields.items() if name not in data
               and field.default is dataclasses.MISSING and field.default_factory is dataclasses.MISSING]
    if missing:
        raise ValueError(f"{where(missing[0])} is missing; a {cls.__name__} needs {sorted(fields)}")
    values: dict[str, Any] = {}
    layouts: dict[str, tuple[tuple[int, ...], np.dtype[Any]] | None] = {}
    for key in cls.STORED:
        if key not in data:
            continue
        value = data[key]
        if value is not None:
            if not isinstance(value, np.ndarray):
                try:
                    value = np.asarray(value)
                except (ValueError, TypeError):  # ragged lists
                    raise ValueError(f"{where(key)} is not an array of numbers ({type(value).__name__})") from None
            layouts[key] = (value.shape, value.dtype)
        else:
            layouts[key] = None
        values[key] = value
    check_stored(cls, layouts, where)
    for key, value in values.items():
        spec = cls.STORED[key]
        if value is None:
            continue
        if value.dtype.kind in "iu" or (spec.kind == "complex" and value.dtype.kind != "c"):  # (a hand-made dict)
            value = value.astype(complex if spec.kind == "complex" else float)
        if spec.finite and not np.all(np.isfinite(value)):
            bad = tuple(int(i) for i in np.argwhere(~np.isfinite(value))[0])
            raise ValueError(f"{where(key)}[{', '.join(map(str, bad))}] is {value[bad]}; expected finite values")
        values[key] = value
    for key, hint in _scalar_fields(cls).items():
        if key in data:
            values[key] = _check_scalar(key, data[key], hint, where)
    with owned_arrays() if owned else contextlib.nullcontext():  # arrays just read: frozen without a copy
        return cls(**values)


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


def _check_version(cls: type[ModesResult], data: dict[str, Any], where: Callable[[str], str]) -> None:
    """The format version and the type of a stored result, before anything else is read."""
    version = data.get("format")
    if isinstance(version, bool) or version != FORMAT_VERSION:
        raise ValueError(f"{where('format')} is {_short(version)}; this vibra reads format {FORMAT_VERSION} "
                         "(what save() writes)")
    if data.get("type") != cls.__name__:
        raise ValueError(f"{where('type')} is {_short(data.get('type'))}; expected {cls.__name__!r}")


# ---------------------------------------------------------------------- result files
_SCALARS = "__scalars__"


class _Entry(typing.NamedTuple):
    """One ``.npy`` entry of a result file, from its header."""

    info: zipfile.ZipInfo
    shape: tuple[int, ...]
    dtype: np.dtype[Any]

    @property
    def bytes(self) -> int:
        return math.prod(self.shape) * self.dtype.itemsize


def _header(archive: zipfile.ZipFile, info: zipfile.ZipInfo, refuse: Callable[[str], ValueError]) -> _Entry:
    """The shape and dtype an entry declares, from its ``.npy`` header alone; the entry must hold
    exactly the bytes they declare (not truncated, not padded)."""
    readers = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}
    try:
        with archive.open(info) as stream:
            version = np.lib.format.read_magic(stream)
            if version in readers:
                shape, _, dtype = readers[version](stream)
                offset = stream.tell()
    except (zipfile.BadZipFile, zlib.error, OSError, NotImplementedError) as error:  # the archive itself
        raise refuse(f"cannot be read ({' '.join(str(error).split())[:120]}); the file is damaged") from None
    except (ValueError, EOFError) as error:  # what numpy says of the header
        raise refuse(f"has no readable .npy header ({' '.join(str(error).split())[:120]}); expected an array "
                     "written by save()") from None
    if version not in readers:
        raise refuse(f"is .npy version {version[0]}.{version[1]}; expected 1.0 or 2.0 (what save() writes)")
    if any(size < 0 for size in shape):
        raise refuse(f"declares the shape {shape}; expected sizes >= 0")
    if dtype.hasobject or dtype.fields is not None or dtype.kind not in "biufcU":
        what = "Python objects" if dtype.hasobject else f"values of type {dtype}"
        raise refuse(f"holds {what}; a vibra result file holds numbers only (nothing is unpickled)")
    entry = _Entry(info, tuple(shape), dtype)
    if offset + entry.bytes != info.file_size:
        raise refuse(f"declares {shape} {dtype} values ({entry.bytes:,} bytes) but holds "
                     f"{max(info.file_size - offset, 0):,} bytes; the file is truncated or altered")
    return entry


def _json_depth(text: str) -> int:
    """The deepest nesting of [ and { in a JSON text, strings left out (numpy over its bytes)."""
    import re

    bare = re.sub(r'"(?:\\.|[^"\\])*"', '""', text).encode("utf-8", "replace")
    codes = np.frombuffer(bare, dtype=np.uint8)
    steps = (np.isin(codes, (ord("["), ord("{"))).astype(np.int64) - np.isin(codes, (ord("]"), ord("}"))))
    return int(np.cumsum(steps).max()) if steps.size else 0


def _read_result_file(cls: type[ModesResult], path: Path, limit: int) -> dict[str, Any]:
    """The fields of the result file `path`: every header checked (`_header`, `check_stored`,
    the total against `limit` bytes) before any array is read."""
    name = str(path)
    expected = f"expected a .npz file written by {cls.__name__}.save()"

    def refuse(key: str) -> Callable[[str], ValueError]:
        return lambda why: ValueError(f"{name}: {key} {why}")

    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise FileNotFoundError(f"{name}: no such file; {expected}") from None
    except OSError as error:
        raise ValueError(f"{name}: cannot be read ({error.strerror or error}); {expected}") from None
    if not stat.S_ISREG(info.st_mode):
        raise ValueError(f"{name}: is {describe_kind(info.st_mode)}; {expected}")
    if info.st_size > limit + MAX_SCALARS_BYTES + 2**20:  # more than anything allowed, even stored plainly
        raise ValueError(f"{name}: is {info.st_size:,} bytes, more than max_bytes={limit:,} allows; load(path, "
                         "max_bytes=...) reads a larger genuine result")
    try:
        archive = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError, ValueError, EOFError) as error:
        raise ValueError(f"{name}: is not a .npz archive ({' '.join(str(error).split())[:120]}); "
                         f"{expected}") from None
    fields = [field.name for field in dataclasses.fields(cls)]  # type: ignore[arg-type]
    with archive:
        members = {member.filename: member for member in archive.infolist()}
        if f"{_SCALARS}.npy" not in members:
            raise ValueError(f"{name}: not a vibra result file (no {_SCALARS} entry); {expected}")
        head = _header(archive, members[f"{_SCALARS}.npy"], refuse(_SCALARS))
        if head.shape != () or head.dtype.kind != "U":
            raise refuse(_SCALARS)(f"holds {head.shape} {head.dtype} values; expected one JSON text")
        if head.bytes > MAX_SCALARS_BYTES:
            raise refuse(_SCALARS)(f"is {head.bytes:,} bytes; a vibra result keeps at most "
                                   f"{MAX_SCALARS_BYTES:,} there (MAX_SCALARS_BYTES)")
        text = str(_read(archive, head, refuse(_SCALARS)))
        depth = _json_depth(text)
        if depth > MAX_JSON_DEPTH:  # json's C scanner recurses per level: a deep text can overflow the C stack
            raise refuse(_SCALARS)(f"is not JSON vibra writes (nested {depth} levels deep; at most {MAX_JSON_DEPTH})")
        try:
            data = json.loads(text)
        except (ValueError, RecursionError) as error:
            raise refuse(_SCALARS)(f"is not JSON ({' '.join(str(error).split())[:80]})") from None
        if not isinstance(data, dict):
            raise refuse(_SCALARS)(f"holds a JSON {type(data).__name__}; expected a JSON object")
        def where(key: str) -> str:
            return f"{name}: {key}"

        _check_version(cls, data, where)  # before any other entry is looked at
        entries: dict[str, zipfile.ZipInfo] = {}
        for member in archive.infolist():
            key = member.filename.removesuffix(".npy")
            if key not in cls.STORED and key != _SCALARS:
                if key in fields:
                    raise refuse(key)(f"is stored as an array; {cls.__name__} keeps it with the other "
                                      f"numbers ({_SCALARS})")
                raise ValueError(f"{name}: {member.filename!r} is not an entry of a {cls.__name__} file; "
                                 f"expected entries among {[*cls.STORED, _SCALARS]} (.npy)")
            if key in entries:
                raise refuse(key)("is stored twice; expected one entry per field")
            if member.flag_bits & 0x1:
                raise refuse(key)("is encrypted; expected an entry written by save()")
            entries[key] = member
        layouts: dict[str, tuple[tuple[int, ...], np.dtype[Any]] | None] = {}
        for key in cls.STORED:
            if key in data and key in entries:
                raise refuse(key)("is stored twice (an array and JSON); expected one of them")
            if key in data:
                if data[key] is not None:
                    raise refuse(key)(f"is {_short(data[key])} in JSON; expected an array entry (or null)")
                layouts[key] = None
        heads = {key: _header(archive, info, refuse(key)) for key, info in entries.items() if key != _SCALARS}
        total = sum(entry.bytes for entry in heads.values())
        if total > limit:
            key, largest = max(heads.items(), key=lambda item: item[1].bytes)
            raise refuse(key)(f"declares {largest.shape} {largest.dtype} values ({largest.bytes:,} bytes; "
                              f"{total:,} for every array), more than max_bytes={limit:,}; load(path, "
                              "max_bytes=...) reads a larger genuine result")
        layouts.update({key: (entry.shape, entry.dtype) for key, entry in heads.items()})
        check_stored(cls, layouts, where)  # every field's kind and shape, before any array is read
        for key, entry in heads.items():
            data[key] = _read(archive, entry, refuse(key))
    return data


def _read(archive: zipfile.ZipFile, entry: _Entry, refuse: Callable[[str], ValueError]) -> Any:
    """The array of an entry whose header was checked (`_header`); a damaged one is refused."""
    try:
        with archive.open(entry.info) as stream:
            return np.lib.format.read_array(stream, allow_pickle=False)
    except (ValueError, OSError, EOFError, zipfile.BadZipFile, zlib.error, NotImplementedError) as error:
        raise refuse(f"cannot be read ({' '.join(str(error).split())[:120]}); the file is damaged") from None
