"""How a result is stored and checked before use: the declared shapes of its arrays (`Stored`,
`check_stored`) and the ``.npz`` result file read header first (`read_result_file`).

**A result file is checked whole before use**, one mechanism for every result type: the
``.npy`` headers of the archive's entries are read first (never an array), and the format
version, the type, each entry's kind of number (never Python objects: nothing is unpickled),
the declared shapes against each other (`check_stored`) and against the bytes each entry
holds, and their total against `MAX_LOAD_BYTES` (``load(path, max_bytes=...)`` raises it) are
checked before any array is read. Every refusal is one line naming the file and the entry:
``modes.npz: vectors has shape (5, 5); expected (n_dof, n_modes) with n_modes = 3 as in omega``.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import re
import stat
import typing
import zipfile
import zlib
from pathlib import Path
from typing import Any, Callable, Literal, Mapping, Union

import numpy as np

from vibra._core.filesystem import describe_kind

__all__ = ["FORMAT_VERSION", "MAX_LOAD_BYTES", "MAX_SCALARS_BYTES", "MAX_JSON_DEPTH", "Dim", "Stored", "stored",
           "Layout", "check_stored", "check_version", "read_result_file", "sequence_lengths", "short"]

#: The ``.npz`` format written by `Result.save` (read back by `load` when it matches).
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

Kind = Literal["real", "complex", "number", "int", "bool", "text"]
#: dtype kinds accepted for each kind of value.
_KINDS = {"real": "fiu", "complex": "cfiu", "number": "cfiu", "int": "iu", "bool": "b", "text": "U"}
_WORDS = {"real": "real numbers", "complex": "complex numbers", "number": "real or complex numbers",
          "int": "integers", "bool": "booleans", "text": "text (numpy unicode)"}


@dataclasses.dataclass(frozen=True)
class Stored:
    """How one array field of a result is stored.

    Attributes
    ----------
    shapes : tuple of tuple of Dim
        The shapes it may have, in named sizes (the first that fits is taken).
    kind : {"real", "complex", "number", "int", "bool", "text"}
        Its kind of value: "real" (integers are accepted and read as floats), "complex" (read
        as complex), "number" (real or complex, kept as stored), "int", "bool", or "text" (names,
        one per entry: a numpy unicode array, never Python objects).
    optional : bool
        Whether it may be None.
    finite : bool
        Whether every value must be finite (checked after reading).
    """

    shapes: tuple[tuple[Dim, ...], ...]
    kind: Kind
    optional: bool = False
    finite: bool = False


def stored(*shapes: tuple[Dim, ...], kind: Kind = "real", optional: bool = False, finite: bool = False) -> Stored:
    """`Stored` with its shapes given one after the other: ``stored(("n_dof",), ("n_dof", "n_dof"))``."""
    return Stored(tuple(shapes), kind, optional, finite)


class Layout(typing.NamedTuple):
    """How one result type is stored (`vibra._results.layout` derives it from the type).

    Attributes
    ----------
    name : str
        The type's name (the ``type`` entry of a stored result).
    arrays : dict of str to Stored
        The array entries.
    sized : dict of str to str
        Sequence entries (kept with the other numbers, as JSON lists) whose length is a named size.
    scalars : dict of str to type
        The other entries and the Python type each must have.
    required : frozenset of str
        The entries a stored result must have.
    """

    name: str
    arrays: dict[str, Stored]
    sized: dict[str, str]
    scalars: dict[str, Any]
    required: frozenset[str]


def check_stored(layout: Layout, declared: dict[str, tuple[tuple[int, ...], np.dtype[np.generic]] | None],
                 where: Callable[[str], str], lengths: dict[str, int] | None = None) -> None:
    """Check the arrays of a stored result from their shapes and dtypes alone (no value is read).

    `declared` maps each array entry present to ``(shape, dtype)`` (None for one stored as
    None), `lengths` each sized sequence present (`Layout.sized`) to its length; `where(key)`
    names a key in messages. Each array must be of its kind (`Stored`), and each named size
    (``n_modes``, ``n_dof``) the same in every entry that has it.

    Raises
    ------
    ValueError
        An entry of the wrong kind, shape or length, in one line naming it and the entry it
        disagrees with.
    """
    sizes: dict[str, tuple[int, str]] = {}  # name -> (size, the entry that set it)
    for key, spec in layout.arrays.items():
        if key not in declared:
            continue
        entry = declared[key]
        if entry is None:
            if not spec.optional:
                raise ValueError(f"{where(key)} is None; expected a {_describe(spec.shapes[0])} array of "
                                 f"{_WORDS[spec.kind]}")
            continue
        shape, dtype = entry
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
    for key, length in (lengths or {}).items():
        name = layout.sized[key]
        size, field = sizes.setdefault(name, (length, key))
        if size != length:
            raise ValueError(f"{where(key)} has {length} entries; expected {name} = {size} as in {field}")


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


def short(value: object) -> str:
    """repr(value), cut to 60 characters (for messages)."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def check_version(name: str, data: Mapping[str, object], where: Callable[[str], str]) -> None:
    """The format version and the type (`name`) of a stored result, before anything else is read."""
    version = data.get("format")
    if isinstance(version, bool) or version != FORMAT_VERSION:
        raise ValueError(f"{where('format')} is {short(version)}; this vibra reads format {FORMAT_VERSION} "
                         "(what save() writes)")
    if data.get("type") != name:
        raise ValueError(f"{where('type')} is {short(data.get('type'))}; expected {name!r}")


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
    bare = re.sub(r'"(?:\\.|[^"\\])*"', '""', text).encode("utf-8", "replace")
    codes = np.frombuffer(bare, dtype=np.uint8)
    steps = (np.isin(codes, (ord("["), ord("{"))).astype(np.int64) - np.isin(codes, (ord("]"), ord("}"))))
    return int(np.cumsum(steps).max()) if steps.size else 0


def read_result_file(layout: Layout, path: Path, limit: int) -> dict[str, Any]:
    """The entries of the result file `path` of the type `layout` describes: every header checked
    (`_header`, `check_stored`, the total against `limit` bytes) before any array is read."""
    name = str(path)
    expected = f"expected a .npz file written by {layout.name}.save()"

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

        check_version(layout.name, data, where)  # before any other entry is looked at
        entries: dict[str, zipfile.ZipInfo] = {}
        for member in archive.infolist():
            key = member.filename.removesuffix(".npy")
            if key not in layout.arrays and key != _SCALARS:
                if key in layout.scalars:
                    raise refuse(key)(f"is stored as an array; {layout.name} keeps it with the other "
                                      f"numbers ({_SCALARS})")
                raise ValueError(f"{name}: {member.filename!r} is not an entry of a {layout.name} file; "
                                 f"expected entries among {[*layout.arrays, _SCALARS]} (.npy)")
            if key in entries:
                raise refuse(key)("is stored twice; expected one entry per field")
            if member.flag_bits & 0x1:
                raise refuse(key)("is encrypted; expected an entry written by save()")
            entries[key] = member
        declared: dict[str, tuple[tuple[int, ...], np.dtype[Any]] | None] = {}
        for key in layout.arrays:
            if key in data and key in entries:
                raise refuse(key)("is stored twice (an array and JSON); expected one of them")
            if key in data:
                if data[key] is not None:
                    raise refuse(key)(f"is {short(data[key])} in JSON; expected an array entry (or null)")
                declared[key] = None
        heads = {key: _header(archive, info, refuse(key)) for key, info in entries.items() if key != _SCALARS}
        total = sum(entry.bytes for entry in heads.values())
        if total > limit:
            key, largest = max(heads.items(), key=lambda item: item[1].bytes)
            raise refuse(key)(f"declares {largest.shape} {largest.dtype} values ({largest.bytes:,} bytes; "
                              f"{total:,} for every array), more than max_bytes={limit:,}; load(path, "
                              "max_bytes=...) reads a larger genuine result")
        declared.update({key: (entry.shape, entry.dtype) for key, entry in heads.items()})
        check_stored(layout, declared, where, sequence_lengths(layout, data))  # before any array is read
        for key, entry in heads.items():
            data[key] = _read(archive, entry, refuse(key))
    return data


def sequence_lengths(layout: Layout, data: Mapping[str, object]) -> dict[str, int]:
    """The length of each sized sequence of `data` (`Layout.sized`) that is a list or tuple."""
    return {key: len(data[key]) for key in layout.sized if isinstance(data.get(key), (list, tuple))}


def _read(archive: zipfile.ZipFile, entry: _Entry, refuse: Callable[[str], ValueError]) -> Any:
    """The array of an entry whose header was checked (`_header`); a damaged one is refused."""
    try:
        with archive.open(entry.info) as stream:
            return np.lib.format.read_array(stream, allow_pickle=False)
    except (ValueError, OSError, EOFError, zipfile.BadZipFile, zlib.error, NotImplementedError) as error:
        raise refuse(f"cannot be read ({' '.join(str(error).split())[:120]}); the file is damaged") from None
