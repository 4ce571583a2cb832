"""vibra's cache folder, and values derived from its own sources kept there between processes.

`cache_dir` is the one place that says where vibra keeps files between processes (the
ahead-of-time kernels, `vibra.solvers.aot`; the derived values below). `remembered(name, derive)`
returns ``derive()``, computed once per version of vibra's sources and then read from
``<cache_dir>/derived/<source_key>.json``: for what is derived from vibra's own code but costs
imports to derive (the scene schema's builder signatures, which import numpy, scipy and the
builders: 0.4-1 s of a refused scene's 0.5-1.3 s, issue 45).

The key (`source_key`) is the SHA-256 of the bytes of every source file of the vibra package with
its name (`source_hash`, the report's skip key too) and Python's version: any edit, install or
upgrade changes it, whatever the files' times say, so a value derived from other sources is never
read. A process stores a value only when no source file changed after it imported vibra (a
notebook that imported a builder before it was edited would otherwise store the old signature
under the new key), and only when it survives JSON unchanged, type for type (tuples are kept as
lists and read back as tuples); any other value is derived in every process, as without a cache.
Nothing fails for want of a cache: no home folder, a read-only one, a damaged or foreign file,
a zipped install without source files all read as "not cached yet". Writing a key's file
removes the files of the other keys (each edit of vibra's sources would leave one behind).

>>> import os, tempfile
>>> folder = tempfile.TemporaryDirectory()
>>> saved, os.environ["VIBRA_CACHE_DIR"] = os.environ.get("VIBRA_CACHE_DIR"), folder.name
>>> forget_in_process(); remembered("example", lambda: {"n": (1, 2.5, "three")})
{'n': (1, 2.5, 'three')}
>>> forget_in_process(); remembered("example", lambda: 1 / 0)  # read back from the file, not derived
{'n': (1, 2.5, 'three')}
>>> os.environ.pop("VIBRA_CACHE_DIR") and saved and os.environ.update(VIBRA_CACHE_DIR=saved); forget_in_process()
>>> folder.cleanup()
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import sys
from pathlib import Path
from typing import Any, Callable

from vibra._core.filesystem import atomic_write_text

__all__ = ["cache_dir", "source_hash", "source_key", "remembered", "forget_in_process"]

_PACKAGE = Path(__file__).resolve().parents[1]

#: name -> value, for this process (loaded from the file on first use).
_MEMO: dict[str, Any] = {}
_LOADED: list[Path | None] = []


def cache_dir() -> Path | None:
    """``$VIBRA_CACHE_DIR``, else ``$XDG_CACHE_HOME/vibra``, else ``~/.cache/vibra``; None where
    that is not an absolute path (no home folder known: no cache rather than one in the working folder)."""
    if os.environ.get("VIBRA_CACHE_DIR"):
        path = Path(os.environ["VIBRA_CACHE_DIR"])
    else:
        path = Path(os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")) / "vibra"
    return path if path.is_absolute() else None


def _sources(package: Path) -> tuple[str, float]:
    """(SHA-256 of every ``.py`` file under `package`, its relative name and bytes, in sorted order;
    the newest modification time among them, s since the epoch); ("", 0.0) where there is none."""
    digest = hashlib.sha256()
    newest = 0.0
    found = False
    for file in sorted(package.rglob("*.py")):
        found = True
        digest.update(file.relative_to(package).as_posix().encode() + b"\0" + file.read_bytes() + b"\0")
        newest = max(newest, file.stat().st_mtime)
    return (digest.hexdigest() if found else ""), newest


@functools.cache
def source_hash() -> str:
    """SHA-256 of the bytes of every ``.py`` file of the vibra package, with its name (computed once
    per process, ~7 ms); "" where the package has no source files (a zipped or compiled install)."""
    return _sources(_PACKAGE)[0]


def source_key() -> str:
    """The cache's key for vibra's sources as they are on disk now: `_sources` of the package and
    Python's version, 24 hex digits; "" where the package has no source files (no cache)."""
    return _key(_sources(_PACKAGE)[0])


def _key(digest: str) -> str:
    return hashlib.sha256(f"{digest}\n{sys.version}".encode()).hexdigest()[:24] if digest else ""


def _file() -> Path | None:
    """The key's file, or None: no cache folder, no source files, or a source file changed since this
    process imported vibra (what it derives may come from the modules as they were)."""
    from vibra._core import IMPORTED_AT

    base = cache_dir()
    digest, newest = _sources(_PACKAGE)
    if base is None or not digest or newest >= IMPORTED_AT:
        return None
    return base / "derived" / f"{_key(digest)}.json"


def _read(path: Path | None) -> dict[str, Any]:
    if path is None:
        return {}
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def _tuples(value: Any) -> Any:
    """JSON's lists read back as tuples, at every depth."""
    if isinstance(value, list):
        return tuple(_tuples(item) for item in value)
    if isinstance(value, dict):
        return {key: _tuples(item) for key, item in value.items()}
    return value


def _same(a: Any, b: Any) -> bool:
    """Equal, type for type at every depth (1 is not 1.0, an enum member is not its value)."""
    if type(a) is not type(b):
        return False
    if isinstance(a, tuple):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same(a[key], b[key]) for key in a)
    return bool(a == b) or (isinstance(a, float) and a != a and b != b)


def _survives_json(value: Any) -> bool:
    try:
        return _same(_tuples(json.loads(json.dumps(value, allow_nan=True))), _tuples(value))
    except (TypeError, ValueError, RecursionError):
        return False


def remembered(name: str, derive: Callable[[], Any]) -> Any:
    """``derive()``, computed once per version of vibra's sources (`source_key`) and kept under `name`
    in the cache folder; lists and tuples read back as tuples. The value must depend on vibra's
    sources only (and be the same in every process that runs them)."""
    if not _LOADED:
        path = _file()
        _LOADED.append(path)
        _MEMO.update({key: _tuples(value) for key, value in _read(path).items()})
    if name in _MEMO:
        return _MEMO[name]
    value = derive()
    _MEMO[name] = _tuples(value)
    path = _LOADED[0]
    if path is not None and _survives_json(value):
        _store(path, name, value)
    return _MEMO[name]


def _store(path: Path, name: str, value: Any) -> None:
    """Add `name` to the key's file (what another process wrote since is kept), written atomically
    (`atomic_write_text`); the other keys' files go."""
    try:
        atomic_write_text(path, json.dumps({**_read(path), name: value}))
        for other in path.parent.glob("*.json"):
            if other != path:
                other.unlink(missing_ok=True)
    except OSError:
        pass  # a read-only or full cache: the value is derived again by the next process


def forget_in_process() -> None:
    """Drop what this process has read or derived (the next `remembered` reads the file again)."""
    _MEMO.clear()
    _LOADED.clear()
