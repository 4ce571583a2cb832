"""Ahead-of-time copies of the compiled kernels: the first call of a process without loading numba.

A process that runs a compiled kernel (`vibra.solvers.compiled`) first imports numba and loads its
typing context: 0.4-0.7 s on the development machine, more than the whole solve of a 2,000-site
ring (issue 45). The kernels declared ``aot=True`` are therefore also compiled ahead of time, by
numba's own compiler (`numba.pycc`), into one extension module per machine and version: the same
LLVM code of the same Python source, with the same options (no fast-math, numpy's error model,
the host CPU), so the same bits; `tests/solvers/test_aot.py` compares every export with numba's
dispatcher on random inputs. Importing it costs milliseconds and no numba.

- **Where**: ``$VIBRA_CACHE_DIR`` or ``~/.cache/vibra`` (``$XDG_CACHE_HOME/vibra``), under
  ``aot/<key>/``, where `key` hashes the sources of `vibra.solvers` (what the kernels and their
  callees are), numba's and Python's versions and this CPU's model and features (a copy built for
  one node of a cluster is never loaded on another kind). Linux only (elsewhere the kernels run
  through numba as before).
- **When**: ``python -m vibra.solvers.aot`` builds it in the foreground (~5 s a kernel); and the
  first process that loads numba for a kernel starts that build in the background, once
  (a lock file), at low priority, so later processes find it. ``VIBRA_AOT=0`` turns both the
  build and the use off. A build writes to a temporary folder and renames it into place: a
  reader sees a whole module or none.
- **Which signatures**: the ones a small workload (`_exercise`: the solves that run each declared
  kernel) dispatched, each exported under its own name with its argument types; a call runs the
  ahead-of-time copy only when its arguments match one of those exactly (`matches`), else numba.
"""

from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from types import ModuleType
from typing import Any, Callable, Sequence

__all__ = ["enabled", "cache_dir", "key", "load", "build", "start_background_build", "matches", "KERNEL_MODULES",
           "MODULE_NAME"]

#: The modules whose kernels may be declared ``aot=True`` (imported by `build`; their kernels are
#: then in `vibra.solvers.compiled.AOT_KERNELS`).
KERNEL_MODULES = (
    "vibra.solvers.accurate.count_kernels",
    "vibra.solvers.accurate.ring.pencil_counts",
    "vibra.solvers.accurate.chain.triplets",
)

#: The extension module's name (its file: ``<MODULE_NAME><the interpreter's suffix>``).
MODULE_NAME = "vibra_kernels"

#: A lock older than this (s) is a build that died: the next process may start one.
STALE_LOCK_S = 900.0

_SOLVERS = Path(__file__).resolve().parent
_STATE: dict[str, Any] = {}
_LOCK = threading.Lock()


def enabled() -> bool:
    """Whether ahead-of-time kernels are built and used here: Linux, and ``VIBRA_AOT`` not ``0``."""
    return sys.platform.startswith("linux") and os.environ.get("VIBRA_AOT", "1") != "0"


def cache_dir() -> Path:
    """``$VIBRA_CACHE_DIR``, else ``$XDG_CACHE_HOME/vibra``, else ``~/.cache/vibra``."""
    if os.environ.get("VIBRA_CACHE_DIR"):
        return Path(os.environ["VIBRA_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "vibra"


def _cpu() -> str:
    """This CPU's model and feature flags (Linux's /proc/cpuinfo), or what `platform` says."""
    try:
        text = Path("/proc/cpuinfo").read_text(encoding="utf-8", errors="replace")
    except OSError:
        return platform.machine() + platform.processor()
    lines = text.splitlines()
    wanted = ("model name", "flags", "Features", "CPU part", "CPU implementer")
    first = [line for line in lines if line.split(":")[0].strip() in wanted]
    return platform.machine() + "\n" + "\n".join(sorted(set(first)))


def _numba_version() -> str:
    from importlib import metadata

    try:
        return metadata.version("numba")
    except metadata.PackageNotFoundError:
        return "none"


def key() -> str:
    """What the copy was built from: the sources of `vibra.solvers`, numba's and Python's versions and
    this CPU (16 hex digits); a copy under another key is never loaded."""
    if "key" not in _STATE:
        digest = hashlib.sha256()
        for path in sorted(_SOLVERS.rglob("*.py")):
            digest.update(path.relative_to(_SOLVERS).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
        digest.update(f"{_numba_version()}\0{sys.version}\0{_cpu()}".encode())
        _STATE["key"] = digest.hexdigest()[:16]
    return str(_STATE["key"])


def _folder() -> Path:
    return cache_dir() / "aot" / key()


def _suffix() -> str:
    return importlib.machinery.EXTENSION_SUFFIXES[0]


def load() -> tuple[ModuleType | None, dict[str, list[dict[str, Any]]]]:
    """The built module for this key and its manifest (kernel -> exports), or (None, {}) (once per process)."""
    with _LOCK:
        if "module" not in _STATE:
            _STATE["module"], _STATE["exports"] = None, {}
            if enabled():
                folder = _folder()
                library, manifest = folder / (MODULE_NAME + _suffix()), folder / "manifest.json"
                if library.exists() and manifest.exists():
                    try:
                        exports = json.loads(manifest.read_text(encoding="utf-8"))["kernels"]
                        spec = importlib.util.spec_from_file_location(MODULE_NAME, library)
                        assert spec is not None and spec.loader is not None
                        module = importlib.util.module_from_spec(spec)
                        spec.loader.exec_module(module)
                        _STATE["module"], _STATE["exports"] = module, exports
                    except (OSError, ImportError, ValueError, KeyError, AssertionError):
                        pass  # a damaged copy: numba runs the kernels, as without one
        return _STATE["module"], _STATE["exports"]


def matches(spec: Sequence[Sequence[Any]], args: Sequence[Any]) -> bool:
    """Whether `args` are exactly the types an export was compiled for (the export converts
    nothing safely: an int64 array passed for float64 would be read as float64)."""
    import numpy as np

    if len(spec) != len(args):
        return False
    for want, value in zip(spec, args):
        if want[0] == "array":
            if not (isinstance(value, np.ndarray) and value.dtype.str == want[1] and value.ndim == want[2]
                    and (want[3] != "C" or value.flags.c_contiguous)):
                return False
        elif want[0] == "float":
            if not isinstance(value, (float, np.floating)) or isinstance(value, np.float32):
                return False
        elif want[0] == "int":
            if not isinstance(value, (int, np.integer)) or isinstance(value, (bool, np.bool_)):
                return False
        elif want[0] == "bool":
            if not isinstance(value, (bool, np.bool_)):
                return False
        else:
            return False
    return True


# ----------------------------------------------------------------- building

def _exercise() -> None:
    """Solves that run every ``aot=True`` kernel with the argument types real calls pass."""
    import numpy as np

    from vibra import System

    def chain(n: int, spread: float, ring: bool = False) -> System:
        rng = np.random.default_rng(0)
        bonds = np.c_[np.arange(n - 1), np.arange(1, n)]
        if ring:
            bonds = np.r_[bonds, [[n - 1, 0]]]
        span = np.log10(spread)
        masses, springs = 10.0 ** rng.uniform(-span, span, n), 10.0 ** rng.uniform(-span, span, len(bonds))
        return System.from_springs(np.arange(n, dtype=float), masses, bonds, springs)

    for system, n_modes, vectors in ((chain(10_000, 1.0), 20, True),    # Sturm counts of the spring form
                                     (chain(2_000, 10.0), None, False),  # the triplets' certificates
                                     (chain(2_000, 1.0, ring=True), None, False)):  # a ring's pencil counts
        system.modes(n_modes, accuracy="high", vectors=vectors)


def _argument(t: Any) -> list[Any]:
    from numba.core import types
    from numba.np.numpy_support import as_dtype

    if isinstance(t, types.Array):
        return ["array", as_dtype(t.dtype).str, int(t.ndim), t.layout]
    if isinstance(t, types.Boolean):
        return ["bool"]
    if isinstance(t, types.Integer):
        return ["int"]
    if isinstance(t, types.Float) and t.bitwidth == 64:
        return ["float"]
    raise TypeError(f"no ahead-of-time export for an argument of type {t}")


def build(folder: Path | None = None, *, quiet: bool = True) -> Path:
    """Compile every ``aot=True`` kernel ahead of time into `folder` (default: this key's place in
    `cache_dir`), through a temporary folder renamed into place; returns the folder."""
    import numba
    import numba.pycc.compiler as pycc_compiler
    from numba.pycc import CC

    from vibra.solvers import compiled

    target = _folder() if folder is None else Path(folder)
    for name in KERNEL_MODULES:
        importlib.import_module(name)
    kernels = [(kernel.py_func.__module__, kernel.py_func.__name__, kernel) for kernel in compiled.AOT_KERNELS]
    with _LOCK:
        _STATE["started"] = True  # this is the build: the workload starts no other
    _exercise()
    options = {"error_model": "numpy", "fastmath": False}  # the kernels' own (`kernel_jit`)
    for _, name, kernel in kernels:
        bad = {k: v for k, v in options.items() if kernel.options.get(k, v) != v}
        if bad:
            raise ValueError(f"{kernel!r} is declared aot=True with options {bad}; the export compiles with {options}")

    class _Flags(pycc_compiler.Flags):  # type: ignore[misc,name-defined]
        def __init__(self, *args: Any, **kwargs: Any) -> None:
            super().__init__(*args, **kwargs)
            self.error_model = "numpy"

    cc = CC(MODULE_NAME)
    cc.target_cpu = numba.core.config.CPU_NAME or "host"
    cc.verbose = not quiet
    manifest: dict[str, list[dict[str, Any]]] = {}
    for module_name, name, kernel in kernels:
        dispatcher = kernel.resolve()
        signatures = list(dispatcher.nopython_signatures)
        if not signatures:
            raise RuntimeError(f"{module_name}.{name} is declared aot=True but _exercise() never ran it")
        for i, signature in enumerate(signatures):
            symbol = f"{module_name.rsplit('.', 1)[-1]}__{name.strip('_')}__{i}"
            cc.export(symbol, signature)(kernel.py_func)
            manifest.setdefault(f"{module_name}.{name}", []).append(
                {"symbol": symbol, "args": [_argument(t) for t in signature.args]})
    target.parent.mkdir(parents=True, exist_ok=True)
    scratch = Path(tempfile.mkdtemp(prefix=".build-", dir=target.parent))
    try:
        cc.output_dir = str(scratch)
        saved, pycc_compiler.Flags = pycc_compiler.Flags, _Flags
        try:
            cc.compile()
        finally:
            pycc_compiler.Flags = saved
        (scratch / "manifest.json").write_text(json.dumps({"key": key(), "kernels": manifest}, indent=1),
                                               encoding="utf-8")
        if not (target / "manifest.json").exists():  # else another process built it meanwhile
            shutil.rmtree(target, ignore_errors=True)
            os.replace(scratch, target)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return target


def start_background_build() -> None:
    """Start `build` in a detached, low-priority process, once per key (a lock file beside the copy)."""
    with _LOCK:
        if _STATE.get("started") or not enabled():
            return
        _STATE["started"] = True
    folder = _folder()
    if (folder / "manifest.json").exists():
        return
    lock = folder.parent / f"{folder.name}.lock"
    try:
        folder.parent.mkdir(parents=True, exist_ok=True)
        if lock.exists() and time.time() - lock.stat().st_mtime > STALE_LOCK_S:
            lock.unlink(missing_ok=True)
        descriptor = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
    except OSError:
        return  # a build is running, or the cache is not writable: numba serves
    os.close(descriptor)
    preexec: Callable[[], None] | None = (lambda: os.nice(10)) if hasattr(os, "nice") else None
    try:
        subprocess.Popen([sys.executable, "-m", "vibra.solvers.aot", "--lock", str(lock)], stdin=subprocess.DEVNULL,
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True,
                         preexec_fn=preexec, close_fds=True)
    except OSError:
        lock.unlink(missing_ok=True)


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m vibra.solvers.aot [--verbose] [--lock FILE]``: build this key's copy (and remove the lock)."""
    args = list(sys.argv[1:] if argv is None else argv)
    lock = Path(args[args.index("--lock") + 1]) if "--lock" in args else None
    try:
        if not enabled():
            print("ahead-of-time kernels are off here (Linux only; VIBRA_AOT=0 turns them off)")
            return 0
        start = time.perf_counter()
        folder = build(quiet="--verbose" not in args)
        if lock is None:
            print(f"built {folder} in {time.perf_counter() - start:.1f} s")
        return 0
    finally:
        if lock is not None:
            lock.unlink(missing_ok=True)


if __name__ == "__main__":  # run as the module vibra.solvers.aot, whose state the kernels share
    from vibra.solvers.aot import main as _main

    sys.exit(_main())
