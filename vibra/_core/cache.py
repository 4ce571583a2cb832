"""vibra's cache folder, and values derived from its own sources kept there between processes.

`cache_dir` is the one place that says where vibra keeps files between processes (the
ahead-of-time kernels, `vibra.solvers.aot`; the derived values below). `remembered(name, derive)`
returns ``derive()``, computed once per version of vibra's sources and then read from
``<cache_dir>/derived/<source_key>.json``: for what is derived from vibra's own code but costs
imports to derive (the scene schema's builder signatures, which import numpy, scipy and the
builders: 0.4-1 s of a refused scene's 0.5-1.3 s, issue 45).

The key (`source_key`) hashes the name, size and modification time of every source file of the
vibra package, vibra's version and Python's: an edit, an install or an upgrade changes it, so a
value derived from other sources is never read. A value is kept only when it survives JSON
unchanged (tuples are kept as lists and read back as tuples); one that does not is derived in
every process, as without a cache. Nothing fails for want of a cache: no home folder, a
read-only one, a damaged or foreign file all read as "not cached yet".

>>> import os, tempfile
>>> saved, os.environ["VIBRA_CACHE_DIR"] = os.environ.get("VIBRA_CACHE_DIR"), tempfile.mkdtemp()
>>> forget_in_process(); remembered("example", lambda: {"n": (1, 2.5, "three")})
{'n': (1, 2.5, 'three')}
>>> forget_in_process(); remembered("example", lambda: 1 / 0)  # read back from the file, not derived
{'n': (1, 2.5, 'three')}
>>> os.environ.pop("VIBRA_CACHE_DIR") and saved and os.environ.update(VIBRA_CACHE_DIR=saved); forget_in_process()
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
import tempfile
from pathlib import Path
from typing import Any, Callable

__all__ = ["cache_dir", "source_key", "remembered", "forget_in_process"]

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


def source_key() -> str:
    """A hash of every ``.py`` file of the vibra package (relative name, size, modification time in ns),
    vibra's version and Python's: 24 hex digits. A few milliseconds (one stat per file)."""
    from vibra import __version__

    digest = hashlib.sha256(f"{__version__}\n{sys.version}\n".encode())
    for folder, subfolders, files in os.walk(_PACKAGE):
        subfolders[:] = sorted(name for name in subfolders if name != "__pycache__")
        for name in sorted(files):
            if name.endswith(".py"):
                path = os.path.join(folder, name)
                status = os.stat(path)
                digest.update(f"{os.path.relpath(path, _PACKAGE)}\0{status.st_size}\0{status.st_mtime_ns}\n".encode())
    return digest.hexdigest()[:24]


def _file() -> Path | None:
    base = cache_dir()
    return None if base is None else base / "derived" / f"{source_key()}.json"


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


def _survives_json(value: Any) -> bool:
    try:
        return _tuples(json.loads(json.dumps(value, allow_nan=True))) == _tuples(value)
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
    """Add `name` to the file (what another process wrote since is kept), replaced in one rename."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        data = {**_read(path), name: value}
        handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=".derived-", suffix=".json")
        try:
            with os.fdopen(handle, "w", encoding="utf-8") as stream:
                json.dump(data, stream)
            os.chmod(temporary, 0o644)
            os.replace(temporary, path)
        except BaseException:
            os.unlink(temporary)
            raise
    except OSError:
        pass  # a read-only or full cache: the value is derived again by the next process


def forget_in_process() -> None:
    """Drop what this process has read or derived (the next `remembered` reads the file again)."""
    _MEMO.clear()
    _LOADED.clear()
