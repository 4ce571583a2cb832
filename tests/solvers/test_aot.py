"""The kernels' ahead-of-time copies (`vibra.solvers.aot`, issue 45 item 2): built by numba's own
compiler, they give numba's dispatcher's bits (truth: the same solves with the copies off,
`VIBRA_AOT=0`), and a fresh interpreter that finds one solves the small corpus inputs without
loading numba. No clock: what runs is read from `sys.modules`."""

from __future__ import annotations

import importlib
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from vibra.solvers import aot

ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="ahead-of-time kernels are built on Linux only")

#: The corpus's inputs whose first call loaded numba before (chain-1e4, chain-all-5000, ring-2000), then
#: two larger ones; each solve's arrays are saved, and whether numba was loaded after it.
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
    """The kernels the sources declare ``aot=True`` (read as text: the modules' names may be bound
    to numba's dispatchers by earlier tests)."""
    found = set()
    for name in aot.KERNEL_MODULES:
        text = Path(importlib.import_module(name).__file__ or "").read_text(encoding="utf-8")
        found |= {f"{name}.{function}" for function in re.findall(r"aot=True[^\n]*\n(?:@[^\n]*\n)*def (\w+)", text)}
    return found


@pytest.fixture(scope="module")
def cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A cache folder holding a copy built by ``python -m vibra.solvers.aot``."""
    folder = tmp_path_factory.mktemp("vibra-cache")
    env = dict(os.environ, VIBRA_CACHE_DIR=str(folder), VIBRA_AOT="1")
    subprocess.run([sys.executable, "-m", "vibra.solvers.aot"], check=True, cwd=ROOT, env=env, capture_output=True)
    return folder


def test_the_build_exports_every_declared_kernel_with_its_argument_types(cache: Path) -> None:
    (built,) = (cache / "aot").iterdir()  # one key, no scratch folder or lock left behind
    manifest = json.loads((built / "manifest.json").read_text(encoding="utf-8"))
    assert manifest["key"] == built.name
    assert set(manifest["kernels"]) == _declared() and len(_declared()) >= 3
    for exports in manifest["kernels"].values():
        for export in exports:
            assert export["args"] and all(arg[0] in ("array", "float", "int", "bool") for arg in export["args"])


def test_the_copies_give_numbas_bits_and_small_solves_load_no_numba(cache: Path, tmp_path: Path) -> None:
    runs = {}
    for setting in ("1", "0"):
        env = dict(os.environ, VIBRA_CACHE_DIR=str(cache), VIBRA_AOT=setting, OPENBLAS_NUM_THREADS="1")
        out = tmp_path / f"aot{setting}.npz"
        done = subprocess.run([sys.executable, "-c", SOLVES, str(out)], check=True, cwd=ROOT, env=env,
                              capture_output=True, text=True)
        runs[setting] = (done.stdout.split(), np.load(out))
    (paths, copies), (numba_paths, numba) = runs["1"], runs["0"]
    # the three small inputs ran the copies: no numba in the process after them
    assert paths[:3] == ["accurate-ritz", "accurate-bidiagonal", "accurate-ring"]
    assert all(path.endswith("+numba") for path in numba_paths)  # without copies each loads numba
    assert sorted(copies.files) == sorted(numba.files)
    for name in copies.files:
        assert np.array_equal(copies[name], numba[name]), name


def test_an_export_runs_only_on_its_exact_argument_types() -> None:
    """An export reads what it is given as the types it was built for: anything else goes to numba."""
    spec = [["array", "<f8", 1, "C"], ["array", "|b1", 1, "C"], ["float"], ["int"], ["bool"]]
    x, flags = np.ones(4), np.ones(4, dtype=bool)
    assert aot.matches(spec, (x, flags, 1.0, 3, True))
    assert aot.matches(spec, (x, flags, np.float64(1.0), np.int64(3), np.bool_(True)))
    for bad in ((x.astype(np.int64), flags, 1.0, 3, True),     # int64 read as float64 would be garbage
                (np.ones((4, 2))[:, 0], flags, 1.0, 3, True),  # not contiguous
                (x.astype(np.float32), flags, 1.0, 3, True),
                (x, flags, np.float32(1.0), 3, True),
                (x, flags, 1.0, 3.0, True), (x, flags, 1.0, True, True), (x, flags, 1.0, 3, 1),
                (x, flags, 1.0, 3)):
        assert not aot.matches(spec, bad)


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
    assert len(started) == 1 and started[0][1:4] == ["-m", "vibra.solvers.aot", "--lock"]
    lock = Path(started[0][4])
    assert lock.exists()
    monkeypatch.setattr(aot, "_STATE", {})  # another process, while that build runs: none
    aot.start_background_build()
    assert len(started) == 1
    old = time.time() - 2 * aot.STALE_LOCK_S  # a build that died long ago: the next process starts one
    os.utime(lock, (old, old))
    monkeypatch.setattr(aot, "_STATE", {})
    aot.start_background_build()
    assert len(started) == 2
    monkeypatch.setattr(aot, "_STATE", {})
    monkeypatch.setenv("VIBRA_AOT", "0")  # off: neither built nor used
    aot.start_background_build()
    assert len(started) == 2 and aot.load() == (None, {})
