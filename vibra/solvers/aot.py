"""Ahead-of-time copies of the compiled kernels: the first call of a process without loading numba.

A process that runs a compiled kernel (`vibra.solvers.compiled`) first imports numba and loads its
typing context: 0.4-0.7 s on the development machine, more than the whole solve of a 2,000-site
ring (issue 45). The kernels declared ``aot=True`` are therefore also compiled ahead of time, by
numba's own compiler (`numba.pycc`, `vibra.solvers.aot_build`), into one extension module per
machine and version: the same LLVM code of the same Python source, with the same options (no
fast-math, numpy's error model, the host CPU's name and features), so the same bits;
`tests/solvers/test_aot.py` compares them with numba's. Importing it costs milliseconds and no numba.

This module is what a process needs to use a copy (nothing here imports numba):

- **Where**: ``$VIBRA_CACHE_DIR`` or ``~/.cache/vibra`` (``$XDG_CACHE_HOME/vibra``), under
  ``aot/<key>/``, where `key` hashes the sources of `vibra.solvers` (what the kernels and their
  callees are), the versions of Python, numpy, numba and llvmlite, and this CPU's model and
  features (a copy built for one node of a cluster is never loaded on another kind). Linux only
  (elsewhere the kernels run through numba as before); no cache at all where the home folder is
  unknown.
- **When**: the first call of an ``aot=True`` kernel that finds no copy starts the build in a
  detached background process, once per key (a lock file; a build that fails leaves a
  ``<key>.failed`` note and is not retried); ``python -m vibra.solvers.aot_build`` builds it at once.
  ``VIBRA_AOT=0`` turns both the build and the use off.
- **Which calls**: a copy's every export names the argument types it was compiled for; a call
  runs it only when its arguments match one exactly (`matches`), else numba. `load` checks the
  module's checksum before importing it: a damaged file is not loaded.
"""

from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import json
import os
import platform
import subprocess
import sys
import threading
import time
from pathlib import Path
from types import ModuleType
from typing import Any, Sequence

from vibra._core.cache import cache_dir

__all__ = ["enabled", "cache_dir", "key", "folder", "library_name", "sha256", "load", "matches", "start_background_build",
           "mark_building", "KERNEL_MODULES", "MODULE_NAME", "STALE_LOCK_S"]

#: The modules that may declare kernels ``aot=True`` (`vibra.solvers.aot_build` imports them;
#: `tests/solvers/test_aot.py` checks that no other module of vibra declares one).
KERNEL_MODULES = (
    "vibra.solvers.accurate.count_kernels",
    "vibra.solvers.accurate.ring.pencil_counts",
    "vibra.solvers.accurate.chain.triplets",
    "vibra.solvers.accurate.products",
)

#: The extension module's name (its file: ``<MODULE_NAME><the interpreter's suffix>``).
MODULE_NAME = "vibra_kernels"

#: A lock older than this (s) is a build that died: the next process may start one.
STALE_LOCK_S = 900.0

_SOLVERS = Path(__file__).resolve().parent
_STATE: dict[str, Any] = {}
_LOCK = threading.Lock()


def enabled() -> bool:
    """Whether ahead-of-time kernels are built and used here: Linux, ``VIBRA_AOT`` not ``0``, a
    cache folder (`cache_dir`), and not inside a build (whose own kernels must run through numba)."""
    return (sys.platform.startswith("linux") and os.environ.get("VIBRA_AOT", "1") != "0"
            and not _STATE.get("building") and cache_dir() is not None)


def _cpu() -> str:
    """This CPU's model and feature flags (Linux's /proc/cpuinfo), or what `platform` says."""
    try:
        text = Path("/proc/cpuinfo").read_text(encoding="utf-8", errors="replace")
    except OSError:
        return platform.machine() + platform.processor()
    wanted = ("model name", "flags", "Features", "CPU part", "CPU implementer")
    lines = sorted({line for line in text.splitlines() if line.split(":")[0].strip() in wanted})
    return platform.machine() + "\n" + "\n".join(lines)


def _versions() -> str:
    from importlib import metadata

    found = []
    for name in ("numpy", "numba", "llvmlite"):
        try:
            found.append(f"{name} {metadata.version(name)}")
        except metadata.PackageNotFoundError:
            found.append(f"{name} none")
    return ", ".join(found)


def key() -> str:
    """What a copy is built from (16 hex digits): the sources of `vibra.solvers`, the versions of
    Python, numpy, numba and llvmlite, numba's CPU settings and this CPU; a copy under another key
    is never loaded."""
    if "key" not in _STATE:
        digest = hashlib.sha256()
        for path in sorted(_SOLVERS.rglob("*.py")):
            digest.update(path.relative_to(_SOLVERS).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
        settings = f"{os.environ.get('NUMBA_CPU_NAME', '')}\0{os.environ.get('NUMBA_CPU_FEATURES', '')}"
        digest.update(f"{sys.version}\0{_versions()}\0{settings}\0{_cpu()}".encode())
        _STATE["key"] = digest.hexdigest()[:16]
    return str(_STATE["key"])


def folder() -> Path:
    """Where this key's copy lives (`cache_dir` must not be None)."""
    base = cache_dir()
    assert base is not None
    return base / "aot" / key()


def library_name() -> str:
    return MODULE_NAME + importlib.machinery.EXTENSION_SUFFIXES[0]


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def load() -> tuple[ModuleType | None, dict[str, list[dict[str, Any]]]]:
    """The built module for this key and its manifest (kernel -> exports), or (None, {}) (once per process)."""
    with _LOCK:
        if "module" not in _STATE:
            _STATE["module"], _STATE["exports"] = None, {}
            if enabled():
                try:
                    where = folder()
                    library, manifest = where / library_name(), where / "manifest.json"
                    if library.exists() and manifest.exists():
                        content = json.loads(manifest.read_text(encoding="utf-8"))
                        if content.get("sha256") == sha256(library):  # a damaged file is never imported
                            spec = importlib.util.spec_from_file_location(MODULE_NAME, library)
                            if spec is not None and spec.loader is not None:
                                module = importlib.util.module_from_spec(spec)
                                spec.loader.exec_module(module)
                                _STATE["module"], _STATE["exports"] = module, content["kernels"]
                except (OSError, ImportError, ValueError, KeyError, TypeError):
                    pass  # unreadable, of another build, or damaged: numba runs the kernels, as without one
        return _STATE["module"], _STATE["exports"]


def matches(spec: Sequence[Sequence[Any]], args: Sequence[Any]) -> bool:
    """Whether `args` are exactly the types an export was compiled for (an export converts nothing
    safely: an int64 array passed for float64 would be read as float64). `spec`, per argument:
    ``["array", dtype.str, ndim, layout, readonly]``, ``["float64"]``, ``["int64"]`` or ``["bool"]``."""
    import numpy as np

    if len(spec) != len(args):
        return False
    for want, value in zip(spec, args):
        kind = want[0]
        if kind == "array":
            if not (isinstance(value, np.ndarray) and value.dtype.str == want[1] and value.ndim == want[2]):
                return False
            layout, readonly = want[3], bool(want[4])
            if (layout == "C" and not value.flags.c_contiguous) or (layout == "F" and not value.flags.f_contiguous):
                return False
            if readonly != (not value.flags.writeable):
                return False
        elif kind == "float64":
            if type(value) not in (float, np.float64):
                return False
        elif kind == "int64":
            if type(value) not in (int, np.int64):
                return False
        elif kind == "bool":
            if type(value) not in (bool, np.bool_):
                return False
        else:
            return False
    return True


def start_background_build() -> None:
    """Start the build (`vibra.solvers.aot_build`) in a detached process, once per key: not where a
    copy exists, a build runs (its lock, fresh), or one failed (its ``.failed`` note)."""
    with _LOCK:
        if _STATE.get("started") or not enabled():
            return
        _STATE["started"] = True
    try:
        where = folder()
        lock, failed = where.with_name(where.name + ".lock"), where.with_name(where.name + ".failed")
        if (where / "manifest.json").exists() or failed.exists():
            return
        where.parent.mkdir(parents=True, exist_ok=True)
        if lock.exists() and time.time() - lock.stat().st_mtime > STALE_LOCK_S:
            lock.unlink(missing_ok=True)
        descriptor = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        os.close(descriptor)
    except OSError:
        return  # a build is running, or the cache is not writable: numba serves
    try:
        subprocess.Popen([sys.executable, "-m", "vibra.solvers.aot_build", "--background", "--lock", str(lock)],
                         stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                         start_new_session=True, close_fds=True)
    except OSError:
        lock.unlink(missing_ok=True)


def mark_building() -> None:
    """This process is a build: its kernels run through numba, and it starts no other build."""
    with _LOCK:
        _STATE["building"] = True
        _STATE["started"] = True
        _STATE["module"], _STATE["exports"] = None, {}
