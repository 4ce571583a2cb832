"""The kernels' ahead-of-time copies (`vibra.solvers.aot`, issue 45 item 2): built by numba's own
compiler, they give numba's dispatcher's bits (truth: the same solves with the copies off,
`VIBRA_AOT=0`), and a fresh interpreter that finds one solves the small corpus inputs without
loading numba. No clock: what runs is read from `sys.modules`."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from vibra.solvers import aot

ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="ahead-of-time kernels are built on Linux only")

#: A compiled spring-space product in both memory orders, the corpus's inputs whose first call loaded
#: numba before (chain-1e4, chain-all-5000, ring-2000), then two larger ones; each result's arrays are
#: saved, and whether numba was loaded after it.
SOLVES = """
import sys, numpy as np
from vibra import System
def chain(n, spread, ring=False):
    rng = np.random.default_rng(0)
    bonds = np.c_[np.arange(n - 1), np.arange(1, n)]
    if ring:
        bonds = np.r_[bonds, [[n - 1, 0]]]
    span = np.log10(spread)
    return System.from_springs(np.arange(n, dtype=float), 10.0 ** rng.uniform(-span, span, n), bonds,
                               10.0 ** rng.uniform(-span, span, len(bonds)))
arrays, loaded = {}, []
import scipy.sparse as sp
from vibra.solvers.accurate import products
rng = np.random.default_rng(2)  # 40 entries a row, 1.6e6 entries x 20 columns: over the compiled loops' threshold
B = sp.csr_matrix((rng.standard_normal(1_600_000), rng.integers(0, 40_000, 1_600_000), np.arange(0, 1_600_001, 40)),
                  shape=(40_000, 40_000))
V = rng.standard_normal((40_000, 20))
arrays["rows"], arrays["columns"] = products.times(B, V), products.times(B, np.asfortranarray(V))
loaded.append("products" + ("+numba" if "numba" in sys.modules else ""))
for i, (system, k, vectors) in enumerate(((chain(10_000, 1.0), 20, True), (chain(5_000, 10.0), None, False),
                                          (chain(2_000, 1.0, True), None, False), (chain(3_000, 100.0, True), None, False),
                                          (chain(20_000, 3.0), 15, True))):
    modes = system.modes(k, vectors=vectors)
    arrays[f"omega{i}"], arrays[f"error{i}"] = modes.omega, modes.omega_error
    if vectors:
        arrays[f"shapes{i}"] = modes.shapes
    loaded.append(modes.path + ("+numba" if "numba" in sys.modules else ""))
np.savez(sys.argv[1], **arrays)
print(" ".join(loaded))
"""


def _declared() -> set[str]:
    """The kernels declared ``aot=True`` anywhere in vibra (read as text: a module's names may be
    bound to numba's dispatchers by earlier tests, and a module missing from `aot.KERNEL_MODULES`
    would not be imported by the build)."""
    found = set()
    package = ROOT / "vibra"
    for path in package.rglob("*.py"):
        name = ".".join(path.relative_to(ROOT).with_suffix("").parts)
        text = path.read_text(encoding="utf-8")
        found |= {f"{name}.{function}" for function in re.findall(r"\baot=True\b[^\n]*\n(?:@[^\n]*\n)*def (\w+)", text)}
    return found


@pytest.fixture(scope="module")
def cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A cache folder holding a copy built by ``python -m vibra.solvers.aot_build``, run twice (the
    second replaces the first: a rebuild must work where a copy exists)."""
    folder = tmp_path_factory.mktemp("vibra-cache")
    env = dict(os.environ, VIBRA_CACHE_DIR=str(folder), VIBRA_AOT="1")
    for _ in range(2):
        subprocess.run([sys.executable, "-m", "vibra.solvers.aot_build"], check=True, cwd=ROOT, env=env,
                       capture_output=True)
    return folder


def test_the_build_exports_every_declared_kernel_with_its_argument_types(cache: Path) -> None:
    (built,) = (cache / "aot").iterdir()  # one key, no scratch folder, old copy or lock left behind
    manifest = json.loads((built / "manifest.json").read_text(encoding="utf-8"))
    assert manifest["key"] == built.name
    assert set(manifest["kernels"]) == _declared() and len(_declared()) == 5
    for exports in manifest["kernels"].values():
        for export in exports:
            assert export["args"] and all(arg[0] in ("array", "float64", "int64", "bool") for arg in export["args"])
    assert oct(built.stat().st_mode & 0o055) == oct(0o055 & ~_umask())  # readable by a shared cache's other users


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def test_a_damaged_copy_is_not_loaded(cache: Path, tmp_path: Path) -> None:
    """A truncated module would crash the process that imports it: its checksum keeps it out."""
    (built,) = (cache / "aot").iterdir()
    damaged = tmp_path / "aot" / built.name
    shutil.copytree(built, damaged)
    library = next(damaged.glob("vibra_kernels*"))
    library.write_bytes(library.read_bytes()[: 4096])
    code = ("import sys\nfrom vibra.solvers import aot\nmodule, exports = aot.load()\n"
            "print(module is None, exports == {}, 'vibra_kernels' in sys.modules)")
    env = dict(os.environ, VIBRA_CACHE_DIR=str(tmp_path), VIBRA_AOT="1")
    done = subprocess.run([sys.executable, "-c", code], check=True, cwd=ROOT, env=env, capture_output=True, text=True)
    assert done.stdout.split() == ["True", "True", "False"]


def test_the_copies_give_numbas_bits_and_small_solves_load_no_numba(cache: Path, tmp_path: Path) -> None:
    runs = {}
    for setting in ("1", "0"):
        env = dict(os.environ, VIBRA_CACHE_DIR=str(cache), VIBRA_AOT=setting, OPENBLAS_NUM_THREADS="1")
        out = tmp_path / f"aot{setting}.npz"
        done = subprocess.run([sys.executable, "-c", SOLVES, str(out)], check=True, cwd=ROOT, env=env,
                              capture_output=True, text=True)
        runs[setting] = (done.stdout.split(), np.load(out))
    (paths, copies), (numba_paths, numba) = runs["1"], runs["0"]
    # the products and the three small inputs ran the copies: no numba in the process after them
    assert paths[:4] == ["products", "accurate-ritz", "accurate-bidiagonal", "accurate-ring"]
    assert all(path.endswith("+numba") for path in numba_paths)  # without copies each loads numba
    assert sorted(copies.files) == sorted(numba.files)
    for name in copies.files:
        assert np.array_equal(copies[name], numba[name]), name


def test_an_export_runs_only_on_its_exact_argument_types() -> None:
    """An export reads what it is given as the types it was built for: anything else goes to numba."""
    spec = [["array", "<f8", 1, "C", False], ["array", "|b1", 1, "C", False], ["float64"], ["int64"], ["bool"]]
    x, flags = np.ones(4), np.ones(4, dtype=bool)
    frozen = x.copy()
    frozen.flags.writeable = False
    assert aot.matches(spec, (x, flags, 1.0, 3, True))
    assert aot.matches(spec, (x, flags, np.float64(1.0), np.int64(3), np.bool_(True)))
    for bad in ((x.astype(np.int64), flags, 1.0, 3, True),     # int64 read as float64 would be garbage
                (np.ones((4, 2))[:, 0], flags, 1.0, 3, True),  # not contiguous
                (x.astype(np.float32), flags, 1.0, 3, True), (frozen, flags, 1.0, 3, True),
                (x, flags, np.float32(1.0), 3, True), (x, flags, np.longdouble(1.0), 3, True),
                (x, flags, 1.0, np.int32(3), True), (x, flags, 1.0, 3.0, True), (x, flags, 1.0, True, True),
                (x, flags, 1.0, 3, 1), (x, flags, 1.0, 3)):
        assert not aot.matches(spec, bad)
    fortran = [["array", "<f8", 2, "F", False]]
    assert aot.matches(fortran, (np.asfortranarray(np.ones((3, 2))),))
    assert not aot.matches(fortran, (np.ones((3, 2)),))


def test_a_missing_copy_is_built_once_in_the_background(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    started: list[list[str]] = []

    class Recorder:
        def __init__(self, args: list[str], **options: object) -> None:
            assert options["start_new_session"] and options["stdout"] == subprocess.DEVNULL
            started.append(args)

    monkeypatch.setenv("VIBRA_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("VIBRA_AOT", "1")
    monkeypatch.setattr(aot.subprocess, "Popen", Recorder)
    monkeypatch.setattr(aot, "_STATE", {})
    aot.start_background_build()
    aot.start_background_build()  # once per process
    assert len(started) == 1 and started[0][1:5] == ["-m", "vibra.solvers.aot_build", "--background", "--lock"]
    lock = Path(started[0][5])
    assert lock.exists()
    monkeypatch.setattr(aot, "_STATE", {})  # another process, while that build runs: none
    aot.start_background_build()
    assert len(started) == 1
    old = time.time() - 2 * aot.STALE_LOCK_S  # a build that died long ago: the next process starts one
    os.utime(lock, (old, old))
    monkeypatch.setattr(aot, "_STATE", {})
    aot.start_background_build()
    assert len(started) == 2
    lock.unlink()
    failed = lock.with_name(lock.name.replace(".lock", ".failed"))
    failed.write_text("no C compiler")  # a build that failed: no process retries it
    monkeypatch.setattr(aot, "_STATE", {})
    aot.start_background_build()
    assert len(started) == 2
    failed.unlink()
    monkeypatch.setenv("VIBRA_AOT", "0")  # off: neither built nor used
    monkeypatch.setattr(aot, "_STATE", {})
    aot.start_background_build()
    assert len(started) == 2
    monkeypatch.setenv("HOME", "")  # no home folder known: no cache in the working folder
    monkeypatch.delenv("VIBRA_CACHE_DIR")
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    monkeypatch.setattr(os.path, "expanduser", lambda path: path)
    assert aot.cache_dir() is None


def test_a_failed_background_build_leaves_its_note_and_removes_its_lock(tmp_path: Path,
                                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    from vibra.solvers import aot_build

    def broken(*args: object, **kwargs: object) -> Path:
        raise RuntimeError("no C compiler here")

    monkeypatch.setenv("VIBRA_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("VIBRA_AOT", "1")
    monkeypatch.setattr(aot, "_STATE", {})
    monkeypatch.setattr(aot_build, "build", broken)
    monkeypatch.setattr(os, "nice", lambda increment: 0)
    lock = tmp_path / "lock"
    lock.write_text("")
    assert aot_build.main(["--background", "--lock", str(lock)]) == 1
    failed = aot.folder().with_name(aot.key() + ".failed")
    assert "no C compiler here" in failed.read_text(encoding="utf-8") and not lock.exists()
