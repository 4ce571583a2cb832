"""Hostile files (issue 44, items 5 and 6): result files checked whole before use, and one writing
rule for every writer.

Each table row is an input and what must come of it: a one-line refusal naming the file and
the field (never a bare BadZipFile, a "missing positional argument" or numpy's advice about
allow_pickle), or the correct result. Every case also checks that no file of the user's changed
(bytes, mtime and inode of everything in the folders involved).

Truth: the rules as documented in `vibra._core.filesystem` and `vibra._results` (and docs/scenes.md, "What vibra
may write"); a round trip is compared field by field with the result that was saved.
"""

from __future__ import annotations

import dataclasses
import io
import json
import os
import stat
import struct
import tracemalloc
import zipfile
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pytest

import vibra
from vibra import cli, networks
from vibra._core.filesystem import SYSTEM_TREES, TargetRefused, check_out_folder, check_target
from vibra._results import MAX_LOAD_BYTES
from vibra.modes import Modes
from vibra.solvers.structured.quadratic import QuadraticModes

ROOT = Path(__file__).resolve().parents[2]
PDB = ROOT / "networks" / "ubiquitin" / "1ubi.pdb"
CHAIN = 'kind = "chain"\n[system]\nbuilder = "linear_chain"\nn = 4\n[draw]\nspectrum = true\n'
DEFECT = ROOT / "chains" / "mass-defect.toml"


# ---------------------------------------------------------------------- helpers
def chain_modes() -> Modes:
    return vibra.chains.linear_chain(5, units="dimensionless").modes()


def charged() -> QuadraticModes:
    return vibra.System.generalized(np.eye(2), np.eye(2), G=[[0.0, -1.0], [1.0, 0.0]]).quadratic_modes()


def same(a: object, b: object) -> None:
    assert type(a) is type(b)
    for field in dataclasses.fields(a):  # type: ignore[arg-type]
        x, y = getattr(a, field.name), getattr(b, field.name)
        if isinstance(x, np.ndarray):
            np.testing.assert_array_equal(x, y)
            assert x.dtype == y.dtype
        else:
            assert x == y or (x != x and y != y), field.name


def tree(*roots: Path) -> dict[str, tuple[int, int, int, int, bytes]]:
    """Every entry below `roots` (links not followed): mode, size, mtime, inode and the bytes of files."""
    out = {}
    for root in roots:
        for folder, names, files in os.walk(root):
            for name in names + files:
                path = Path(folder) / name
                info = os.lstat(path)
                data = path.read_bytes() if stat.S_ISREG(info.st_mode) else b""
                is_dir = stat.S_ISDIR(info.st_mode)
                out[str(path)] = (info.st_mode, 0 if is_dir else info.st_size, 0 if is_dir else info.st_mtime_ns,
                                  info.st_ino, data)
    return out


def npy(array: Any = None, *, shape: tuple[int, ...] | None = None, descr: str = "<f8", data: bytes = b"") -> bytes:
    """The bytes of a .npy entry: `array` as numpy writes it, or a header declaring `shape` and
    `descr` followed by `data`."""
    stream = io.BytesIO()
    if array is not None:
        np.lib.format.write_array(stream, np.asarray(array), allow_pickle=True)
    else:
        np.lib.format.write_array_header_1_0(stream, {"descr": descr, "fortran_order": False, "shape": shape})
        stream.write(data)
    return stream.getvalue()


def npz(path: Path, entries: dict[str, bytes], *, declared: dict[str, int] | None = None) -> Path:
    """Write a zip of `entries` (name -> .npy bytes, stored); `declared` overrides the size the
    zip's directory gives for an entry (what a hostile file may claim)."""
    stream = io.BytesIO()
    with zipfile.ZipFile(stream, "w", zipfile.ZIP_STORED) as archive:
        for name, data in entries.items():
            archive.writestr(name, data)
    blob = bytearray(stream.getvalue())
    for name, size in (declared or {}).items():
        at = blob.rfind(b"PK\x01\x02", 0, blob.rfind(name.encode()))  # the entry's central directory record
        struct.pack_into("<I", blob, at + 24, size)  # its uncompressed size
    path.write_bytes(bytes(blob))
    return path


def stored(result: Any) -> dict[str, bytes]:
    """The entries `save` writes for `result` (arrays and the JSON of the rest)."""
    data = result.to_dict()
    scalars = {k: (float(v) if isinstance(v, float) else v) for k, v in data.items() if not isinstance(v, np.ndarray)}
    entries = {f"{k}.npy": npy(v) for k, v in data.items() if isinstance(v, np.ndarray)}
    return {"__scalars__.npy": npy(np.array(json.dumps(scalars))), **entries}


def with_scalars(result: Any, **changes: Any) -> dict[str, bytes]:
    data = result.to_dict()
    scalars = {k: (float(v) if isinstance(v, float) else v) for k, v in data.items() if not isinstance(v, np.ndarray)}
    scalars.update(changes)
    for key in [k for k, v in changes.items() if v is dataclasses.MISSING]:
        del scalars[key]
    return {**stored(result), "__scalars__.npy": npy(np.array(json.dumps(scalars)))}


def without(entries: dict[str, bytes], *names: str) -> dict[str, bytes]:
    return {k: v for k, v in entries.items() if k not in names}


# ---------------------------------------------------------------------- 5. result files checked whole
def _genuine(tmp: Path) -> Path:
    return chain_modes().save(tmp / "modes.npz")


def _truncated(tmp: Path) -> Path:
    data = _genuine(tmp).read_bytes()
    (tmp / "cut.npz").write_bytes(data[: len(data) // 2])
    return tmp / "cut.npz"


def _flipped(tmp: Path) -> Path:
    data = bytearray(_genuine(tmp).read_bytes())
    at = data.find(b"\x93NUMPY", data.find(b"omega.npy")) + 128 + 8  # inside omega's values (after its header)
    data[at:at + 8] = b"\xff" * 8
    (tmp / "flipped.npz").write_bytes(bytes(data))
    return tmp / "flipped.npz"


def _bomb(tmp: Path) -> Path:
    # a few hundred bytes whose directory and header declare 5e8 values (4 GB) for `vectors`
    header = npy(shape=(100_000_000, 5))
    return npz(tmp / "bomb.npz", {**stored(chain_modes()), "vectors.npy": header + b"\0" * 64},
               declared={"vectors.npy": len(header) + 4_000_000_000})


def _fifo(tmp: Path) -> Path:
    os.mkfifo(tmp / "pipe.npz")
    return tmp / "pipe.npz"


M = chain_modes  # (short in the table)

# (case, make the file in tmp, expected one-line fragment)
LOAD_CASES: list[tuple[str, Callable[[Path], Path], str]] = [
    ("text-not-zip", lambda t: (t / "a.npz", (t / "a.npz").write_text("hello"))[0], "is not a .npz archive"),
    ("empty-file", lambda t: (t / "a.npz", (t / "a.npz").write_bytes(b""))[0], "is not a .npz archive"),
    ("truncated-zip", _truncated, "is not a .npz archive"),
    ("flipped-bytes", _flipped, "omega cannot be read"),
    ("folder", lambda t: t, "is a folder"),
    ("fifo", _fifo, "is a FIFO"),
    ("missing-file", lambda t: t / "nowhere.npz", "no such file"),
    ("no-scalars", lambda t: npz(t / "a.npz", {"a.npy": npy(np.zeros(2))}), "not a vibra result file"),
    ("unknown-entry", lambda t: npz(t / "a.npz", {**stored(M()), "colour.npy": npy(np.zeros(2))}),
     "'colour.npy' is not an entry of a Modes file"),
    ("duplicate-entry", lambda t: npz(t / "a.npz", {**stored(M()), "omega": npy(np.zeros(5))}),
     "omega is stored twice"),
    ("scalar-as-array", lambda t: npz(t / "a.npz", {**stored(M()), "residual.npy": npy(np.zeros(2))}),
     "residual is stored as an array"),
    ("object-array", lambda t: npz(t / "a.npz", {**stored(M()), "omega.npy": npy(np.array([object()] * 5))}),
     "omega holds Python objects"),
    ("object-header", lambda t: npz(t / "a.npz", {**stored(M()), "omega.npy": npy(shape=(5,), descr="|O")}),
     "omega holds Python objects"),
    ("structured-dtype", lambda t: npz(t / "a.npz", {**stored(M()), "omega.npy": npy(np.zeros(5, "f8,f8"))}),
     "omega holds values of type"),
    ("complex-omega", lambda t: npz(t / "a.npz", {**stored(M()), "omega.npy": npy(np.zeros(5, complex))}),
     "omega holds complex128 values; expected real numbers"),
    ("text-omega", lambda t: npz(t / "a.npz", {**stored(M()), "omega.npy": npy(np.array(list("abcde")))}),
     "omega holds <U1 values; expected real numbers"),
    ("format-2", lambda t: npz(t / "a.npz", with_scalars(M(), format=2)),
     "format is 2; this vibra reads format 1"),
    ("format-missing", lambda t: npz(t / "a.npz", with_scalars(M(), format=dataclasses.MISSING)),
     "format is None; this vibra reads format 1"),
    ("format-true", lambda t: npz(t / "a.npz", with_scalars(M(), format=True)), "format is True"),
    ("other-type", lambda t: npz(t / "a.npz", with_scalars(M(), type="QuadraticModes")),
     "type is 'QuadraticModes'; expected 'Modes'"),
    ("missing-omega", lambda t: npz(t / "a.npz", without(stored(M()), "omega.npy")), "omega is missing"),
    ("missing-solver", lambda t: npz(t / "a.npz", with_scalars(M(), solver=dataclasses.MISSING)),
     "solver is missing"),
    ("omega-3-vectors-5x5", lambda t: npz(t / "a.npz", {**stored(M()), "omega.npy": npy(np.arange(3.0))}),
     "vectors has shape (5, 5); expected (n_dof, n_modes) with n_modes = 3 as in omega"),
    ("shapes-transposed", lambda t: npz(t / "a.npz", {**stored(M()), "shapes.npy": npy(np.zeros((5, 4)))}),
     "shapes has shape (5, 4); expected (n_dof, n_modes)"),
    ("mass-not-square", lambda t: npz(t / "a.npz", {**stored(M()), "mass.npy": npy(np.ones((5, 4)))}),
     "mass has shape (5, 4); expected (n_dof,) or (n_dof, n_dof) with n_dof = 5 as in vectors"),
    ("error-short", lambda t: npz(t / "a.npz", {**stored(M()), "omega_error.npy": npy(np.zeros(4))}),
     "omega_error has shape (4,); expected (n_modes,) with n_modes = 5 as in omega"),
    ("refined-floats", lambda t: npz(t / "a.npz", {**stored(M()), "refined.npy": npy(np.zeros(5))}),
     "refined holds float64 values; expected booleans"),
    ("vectors-null-and-entry", lambda t: npz(t / "a.npz", {**with_scalars(M(), vectors=None)}),
     "vectors is stored twice"),
    ("array-as-json", lambda t: npz(t / "a.npz", without(with_scalars(M(), refined=[True] * 5), "refined.npy")),
     "refined is [True, True, True, True, True] in JSON; expected an array entry"),
    ("omega-nan", lambda t: npz(t / "a.npz", {**stored(M()), "omega.npy": npy(np.array([0, np.nan, 1, 2, 3.0]))}),
     "omega[1] is nan; expected finite values"),
    ("residual-text", lambda t: npz(t / "a.npz", with_scalars(M(), residual="small")),
     "residual is 'small' (str); expected float"),
    ("solver-number", lambda t: npz(t / "a.npz", with_scalars(M(), solver=3)), "solver is 3 (int); expected str"),
    ("units-unknown-key", lambda t: npz(t / "a.npz", with_scalars(M(), units={"bogus": 1})),
     "units has keys ['bogus']; expected ['name', 'mass', 'length', 'energy', 'time_s']"),
    ("units-negative-time", lambda t: npz(t / "a.npz", with_scalars(M(), units={
        "name": "x", "mass": "kg", "length": "m", "energy": "J", "time_s": -1.0})), "units: time_s"),
    ("scalars-not-json", lambda t: npz(t / "a.npz", {**stored(M()), "__scalars__.npy": npy(np.array("{oops"))}),
     "__scalars__ is not JSON"),
    ("scalars-json-list", lambda t: npz(t / "a.npz", {**stored(M()), "__scalars__.npy": npy(np.array("[1, 2]"))}),
     "__scalars__ holds a JSON list; expected a JSON object"),
    ("scalars-numbers", lambda t: npz(t / "a.npz", {**stored(M()), "__scalars__.npy": npy(np.zeros(3))}),
     "__scalars__ holds (3,) float64 values; expected one JSON text"),
    ("scalars-huge", lambda t: npz(t / "a.npz", {**stored(M()), "__scalars__.npy": npy(shape=(), descr="<U100000000")},
                                   declared={"__scalars__.npy": 128 + 400_000_000}), "__scalars__ is 400,000,000 bytes"),
    ("scalars-cut", lambda t: npz(t / "a.npz", {**stored(M()), "__scalars__.npy": npy(shape=(), descr="<U100000000")}),
     "__scalars__ declares () <U100000000 values (400,000,000 bytes) but holds 0 bytes"),
    ("scalars-deep-json", lambda t: npz(t / "a.npz", {**stored(M()), "__scalars__.npy": npy(
        np.array("[" * 200_000))}), "__scalars__ is not JSON"),
    ("declares-6e8-holds-little", lambda t: npz(t / "a.npz", {**stored(M()), "omega.npy": npy(
        shape=(600_000_000,), data=b"\0" * 4_700_000)}), "omega declares (600000000,) float64 values"),
    ("declares-more-than-held", lambda t: npz(t / "a.npz", {**stored(M()), "omega.npy": npy(np.zeros(5))[:-8]}),
     "the file is truncated or altered"),
    ("padded-entry", lambda t: npz(t / "a.npz", {**stored(M()), "omega.npy": npy(np.zeros(5)) + b"\0" * 8}),
     "the file is truncated or altered"),
    ("negative-shape", lambda t: npz(t / "a.npz", {**stored(M()), "omega.npy": npy(shape=(-5,))}),
     "omega declares the shape (-5,)"),
    ("npy-version-3", lambda t: npz(t / "a.npz", {**stored(M()), "omega.npy": b"\x93NUMPY\x03\x00" + npy(
        np.zeros(5))[8:]}), "omega is .npy version 3.0"),
    ("not-npy", lambda t: npz(t / "a.npz", {**stored(M()), "omega.npy": b"just text, no header"}),
     "omega has no readable .npy header"),
    ("bomb-4-GB-declared", _bomb, "vectors declares (100000000, 5) float64 values (4,000,000,000 bytes"),
]


@pytest.mark.parametrize("case, make, fragment", LOAD_CASES, ids=[case[0] for case in LOAD_CASES])
def test_a_hostile_result_file_is_refused_in_one_line(case: str, make: Callable[[Path], Path], fragment: str,
                                                       tmp_path: Path) -> None:
    path = make(tmp_path)
    before = tree(tmp_path)
    tracemalloc.start()
    try:
        with pytest.raises((ValueError, FileNotFoundError)) as refused:
            Modes.load(path)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    message = str(refused.value)
    assert fragment in message, message
    assert "\n" not in message and message.startswith(f"{path}: "), message
    for advice in ("allow_pickle", "positional argument", "BadZipFile", "Traceback"):
        assert advice not in message
    assert peak < 64 * 2**20, f"{peak:,} bytes allocated to refuse {case}"  # nothing declared was allocated
    assert tree(tmp_path) == before  # loading changes nothing


QUADRATIC_CASES = [
    ("state-vectors-odd", {"state_vectors.npy": npy(np.zeros((4, 3), complex))},
     "state_vectors has shape (4, 3); expected (2 n_dof, 2 n_modes) with n_dof = 2 as in shapes; "
     "n_modes = 2 as in natural_frequency"),
    ("eigenvalues-triples", {"eigenvalues.npy": npy(np.zeros((2, 3), complex))},
     "eigenvalues has shape (2, 3); expected (n_modes, 2) with n_modes = 2 as in natural_frequency"),
    ("boolean-shapes", {"shapes.npy": npy(np.zeros((2, 2), bool))}, "shapes holds bool values; expected complex numbers"),
]


@pytest.mark.parametrize("case, entries, fragment", QUADRATIC_CASES, ids=[case[0] for case in QUADRATIC_CASES])
def test_every_result_type_is_checked_by_the_same_rule(case: str, entries: dict[str, bytes], fragment: str,
                                                        tmp_path: Path) -> None:
    path = npz(tmp_path / "q.npz", {**stored(charged()), **entries})
    with pytest.raises(ValueError) as refused:
        QuadraticModes.load(path)
    assert str(refused.value) == f"{path}: {fragment}"
    with pytest.raises(ValueError, match="type is 'Modes'; expected 'QuadraticModes'"):
        QuadraticModes.load(chain_modes().save(tmp_path / "m.npz"))


@pytest.mark.parametrize("make", [chain_modes, lambda: vibra.chains.linear_chain(5).modes(vectors=False),
                                  lambda: chain_modes()[1:], charged])
def test_genuine_results_load_exactly(make: Callable[[], Any], tmp_path: Path) -> None:
    result = make()
    same(type(result).load(result.save(tmp_path / "r.npz")), result)
    same(type(result).from_dict(result.to_dict()), result)
    loaded = type(result).load(tmp_path / "r.npz")
    assert not loaded.omega_error.flags.writeable and len(loaded) == len(result)
    assert [p.name for p in tmp_path.iterdir()] == ["r.npz"]


def test_a_compressed_archive_of_the_same_entries_loads(tmp_path: Path) -> None:
    modes = chain_modes()
    data = modes.to_dict()
    scalars = {k: v for k, v in data.items() if not isinstance(v, np.ndarray)}
    np.savez_compressed(tmp_path / "z.npz", __scalars__=np.array(json.dumps(scalars)),
                        **{k: v for k, v in data.items() if isinstance(v, np.ndarray)})
    same(Modes.load(tmp_path / "z.npz"), modes)


def test_the_size_limit_is_named_and_raised_per_call(tmp_path: Path) -> None:
    modes = chain_modes()
    path = modes.save(tmp_path / "m.npz")
    with pytest.raises(ValueError, match=r"more than max_bytes=100; load\(path, max_bytes=\.\.\.\) reads a larger"):
        Modes.load(path, max_bytes=100)
    same(Modes.load(path, max_bytes=10_000), modes)
    assert MAX_LOAD_BYTES == 2 * 1024**3
    with pytest.raises(ValueError, match="max_bytes is -1"):
        Modes.load(path, max_bytes=-1)


DICT_CASES = [
    ("omega-3", {"omega": np.arange(3.0)}, "data['vectors'] has shape (5, 5); expected (n_dof, n_modes) with "
                                           "n_modes = 3 as in omega"),
    ("vectors-none-ok-but-mass-bad", {"vectors": None, "shapes": None, "mass": np.ones((2, 3))},
     "data['mass'] has shape (2, 3); expected (n_dof,) or (n_dof, n_dof)"),
    ("omega-none", {"omega": None}, "data['omega'] is None; expected a (n_modes,) array of real numbers"),
    ("ragged", {"omega": [[1.0], [1.0, 2.0]]}, "data['omega'] is not an array of numbers"),
    ("unknown", {"colour": "red"}, "data['colour'] is not a field of Modes (unknown keys ['colour'])"),
    ("format", {"format": "1"}, "data['format'] is '1'; this vibra reads format 1"),
    ("units-str", {"units": "SI"}, "data['units'] is 'SI' (str); expected UnitSystem"),
]


@pytest.mark.parametrize("case, changes, fragment", DICT_CASES, ids=[case[0] for case in DICT_CASES])
def test_from_dict_runs_the_same_checks(case: str, changes: dict[str, Any], fragment: str) -> None:
    with pytest.raises(ValueError) as refused:
        Modes.from_dict({**chain_modes().to_dict(), **changes})
    assert fragment in str(refused.value) and "\n" not in str(refused.value), str(refused.value)


# ---------------------------------------------------------------------- 6. one writing rule
@pytest.fixture(scope="module")
def ubiquitin() -> tuple[Any, Modes]:
    structure = networks.from_pdb(PDB)
    return structure, networks.anm(structure.positions).modes(n_modes=12)


def _copy_pdb(tmp: Path) -> tuple[Any, Path]:
    (tmp / "protein.pdb").write_bytes(PDB.read_bytes())
    return networks.from_pdb(tmp / "protein.pdb"), tmp / "protein.pdb"


def _nmd_over_pdb(tmp: Path, modes: Modes) -> Callable[[], Any]:
    structure, pdb = _copy_pdb(tmp)
    return lambda: networks.write_nmd(pdb, modes, structure)


def _nmd_over_pdb_symlink(tmp: Path, modes: Modes) -> Callable[[], Any]:
    structure, pdb = _copy_pdb(tmp)
    (tmp / "link.nmd").symlink_to(pdb)
    return lambda: networks.write_nmd(tmp / "link.nmd", modes, structure)


def _nmd_over_pdb_hard_link(tmp: Path, modes: Modes) -> Callable[[], Any]:
    structure, pdb = _copy_pdb(tmp)
    os.link(pdb, tmp / "hard.nmd")
    return lambda: networks.write_nmd(tmp / "hard.nmd", modes, structure)


def _nmd_over_pdb_relative(tmp: Path, modes: Modes) -> Callable[[], Any]:
    structure, _ = _copy_pdb(tmp)

    def attempt() -> None:
        cwd = os.getcwd()
        os.chdir(tmp)
        try:
            networks.write_nmd("protein.pdb", modes, structure)
        finally:
            os.chdir(cwd)
    return attempt


def _save_in_etc_by_symlink(tmp: Path, modes: Modes) -> Callable[[], Any]:
    (tmp / "etc").symlink_to("/etc")
    return lambda: chain_modes().save(tmp / "etc" / "vibra-hostile-test.npz")


def _save_over_a_fifo(tmp: Path, modes: Modes) -> Callable[[], Any]:
    os.mkfifo(tmp / "p.npz")
    return lambda: chain_modes().save(tmp / "p.npz")


# (case, set up tmp with the network's modes -> the attempt, expected one-line fragment)
WRITER_CASES: list[tuple[str, Callable[[Path, Modes], Callable[[], Any]], str]] = [
    ("nmd-over-its-pdb", _nmd_over_pdb, "protein.pdb: is an input of this run"),
    ("nmd-over-a-symlink-to-its-pdb", _nmd_over_pdb_symlink, "link.nmd: is an input of this run"),
    ("nmd-over-a-hard-link-to-its-pdb", _nmd_over_pdb_hard_link, "hard.nmd: is an input of this run"),
    ("nmd-over-its-pdb-relative", _nmd_over_pdb_relative, "protein.pdb: is an input of this run"),
    ("save-into-etc-by-a-symlink", _save_in_etc_by_symlink, "is in the system folder /etc"),
    ("save-in-the-root-folder", lambda t, m: lambda: chain_modes().save("/vibra-hostile-test.npz"),
     "/vibra-hostile-test.npz: is in the root folder /"),
    ("save-below-usr", lambda t, m: lambda: chain_modes().save("/usr/vibra-hostile-test/x.npz"),
     "is in the system folder /usr"),
    ("save-a-new-home", lambda t, m: lambda: chain_modes().save("/home/vibra-hostile-test/x.npz"),
     "would be created in the system folder /home"),
    ("save-over-a-fifo", _save_over_a_fifo, "p.npz: is a FIFO"),
]


@pytest.mark.parametrize("case, setup, fragment", WRITER_CASES, ids=[case[0] for case in WRITER_CASES])
def test_a_library_writer_refuses_in_one_line(case: str, setup: Callable[[Path, Modes], Callable[[], Any]],
                                              fragment: str, tmp_path: Path, ubiquitin: tuple[Any, Modes]) -> None:
    attempt = setup(tmp_path, ubiquitin[1])
    before = tree(tmp_path)
    try:
        with pytest.raises(TargetRefused) as refused:
            attempt()
    finally:
        for stray in ("/vibra-hostile-test.npz", "/etc/vibra-hostile-test.npz"):  # (there only if the rule failed)
            Path(stray).unlink(missing_ok=True)
    message = str(refused.value)
    assert fragment in message and "\n" not in message, message
    assert tree(tmp_path) == before  # the PDB (or what stood there) unchanged, no temporary file left
    assert not Path("/usr/vibra-hostile-test").exists() and not Path("/home/vibra-hostile-test").exists()


def test_nmd_beside_its_pdb_is_written(tmp_path: Path, ubiquitin: tuple[Any, Modes]) -> None:
    structure, pdb = _copy_pdb(tmp_path)
    path = networks.write_nmd(tmp_path / "protein.nmd", ubiquitin[1], structure)
    assert path.read_text().startswith("name protein\n") and pdb.read_bytes() == PDB.read_bytes()


def run_cli(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = cli.main(list(args))
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _foreign(folder: Path) -> Path:
    """Someone's folder: files named like report's own, and a note."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "index.html").write_text("<p>my own page</p>")
    (folder / "summary.json").write_text('{"mine": true}')
    (folder / "notes.txt").write_text("do not touch")
    return folder


def _scene(tmp: Path) -> Path:
    (tmp / "scenes").mkdir(exist_ok=True)
    (tmp / "scenes" / "c.toml").write_text(CHAIN)
    return tmp / "scenes" / "c.toml"


def _out_symlink_to_foreign(tmp: Path) -> tuple[list[str], list[Path]]:
    foreign = _foreign(tmp / "mine")
    (tmp / "out").symlink_to(foreign)
    return ["report", str(_scene(tmp)), "--out", str(tmp / "out")], [foreign]


def _out_foreign(tmp: Path) -> tuple[list[str], list[Path]]:
    return ["report", str(_scene(tmp)), "--out", str(_foreign(tmp / "mine"))], [tmp / "mine"]


def _out_holds_only_a_hidden_file(tmp: Path) -> tuple[list[str], list[Path]]:
    (tmp / "mine").mkdir()
    (tmp / "mine" / ".git").write_text("gitdir: elsewhere")
    return ["report", str(_scene(tmp)), "--out", str(tmp / "mine")], [tmp / "mine"]


def _out_is_the_scene_folder(tmp: Path) -> tuple[list[str], list[Path]]:
    scene = _scene(tmp)
    return ["report", str(scene), "--out", str(scene.parent)], [scene.parent]


def _pages_symlink_out(tmp: Path) -> tuple[list[str], list[Path]]:
    foreign = _foreign(tmp / "mine")
    (tmp / "out" / ".vibra").mkdir(parents=True)  # a report folder...
    (tmp / "out" / "scenes").symlink_to(foreign)  # ...whose pages folder leads out of it
    return ["report", str(_scene(tmp)), "--out", str(tmp / "out"), "--force"], [foreign]


def _mark_symlink_out(tmp: Path) -> tuple[list[str], list[Path]]:
    foreign = _foreign(tmp / "mine")
    (tmp / "out").mkdir()
    (tmp / "out" / ".vibra").symlink_to(foreign)
    return ["report", str(_scene(tmp)), "--out", str(tmp / "out")], [foreign]


def _index_symlink_out(tmp: Path) -> tuple[list[str], list[Path]]:
    foreign = _foreign(tmp / "mine")
    (tmp / "out" / ".vibra").mkdir(parents=True)
    (tmp / "out" / "index.html").symlink_to(foreign / "index.html")
    return ["report", str(_scene(tmp)), "--out", str(tmp / "out")], [foreign]


def _own_folder_with(plant: Callable[[Path, Path], Any]) -> Callable[[Path], tuple[list[str], list[Path]]]:
    """A folder vibra wrote before, with `plant(out, foreign)` done in it."""
    def setup(tmp: Path) -> tuple[list[str], list[Path]]:
        foreign = _foreign(tmp / "mine")
        (tmp / "out" / ".vibra").mkdir(parents=True)
        for name in ("scenes", "assets"):
            (tmp / "out" / name).mkdir()
        plant(tmp / "out", foreign)
        return ["report", str(_scene(tmp)), "--out", str(tmp / "out"), "--force"], [foreign]
    return setup


def _system(folder: str, *extra: str) -> Callable[[Path], tuple[list[str], list[Path]]]:
    return lambda tmp: (["report", str(_scene(tmp)), "--out", folder, *extra], [])


def _symlink_to_etc(tmp: Path) -> tuple[list[str], list[Path]]:
    (tmp / "out").symlink_to("/etc")
    return ["report", str(_scene(tmp)), "--out", str(tmp / "out"), "--force"], []


def _new_folder_below_usr(tmp: Path) -> tuple[list[str], list[Path]]:
    (tmp / "usr").symlink_to("/usr")
    return ["report", str(_scene(tmp)), "--out", str(tmp / "usr" / "vibra-hostile-test"), "--force"], []


def _sweep_foreign(tmp: Path) -> tuple[list[str], list[Path]]:
    return ["sweep", str(DEFECT), "--vary", "system.defect_mass=0.2:0.8:2", "--out", str(_foreign(tmp / "mine")),
            "-q"], [tmp / "mine"]


def _sweep_root(tmp: Path) -> tuple[list[str], list[Path]]:
    return ["sweep", str(DEFECT), "--vary", "system.defect_mass=0.2:0.8:2", "--out", "/", "--force", "-q"], []


# (case, set up tmp -> (command line, folders that must not change), expected one-line fragment)
FOLDER_CASES: list[tuple[str, Callable[[Path], tuple[list[str], list[Path]]], str]] = [
    ("report-out-symlink-to-a-foreign-folder", _out_symlink_to_foreign,
     "(a symlink to {tmp}/mine) holds files vibra did not write ('index.html' and 2 more) and no .vibra/ mark"),
    ("report-out-a-foreign-folder", _out_foreign, "holds files vibra did not write"),
    ("report-out-a-folder-with-a-hidden-file", _out_holds_only_a_hidden_file, "holds files vibra did not write ('.git')"),
    ("report-out-the-scene-folder", _out_is_the_scene_folder, "holds files vibra did not write ('c.toml')"),
    ("report-pages-folder-is-a-symlink-out", _pages_symlink_out, "scenes is a symbolic link"),
    ("report-mark-is-a-symlink-out", _mark_symlink_out, ".vibra is a symbolic link"),
    ("report-index-is-a-symlink-out", _index_symlink_out, "index.html is a symbolic link"),
    ("report-lock-is-a-symlink-out", _own_folder_with(lambda out, mine: (out / ".vibra" / "lock").symlink_to(
        mine / "notes.txt")), ".vibra/lock: is a symbolic link (to {tmp}/mine/notes.txt)"),
    ("report-lock-is-a-hard-link", _own_folder_with(lambda out, mine: os.link(mine / "notes.txt", out / ".vibra" / "lock")),
     ".vibra/lock: is a file with 2 names (a hard link)"),
    ("report-asset-is-a-fifo", _own_folder_with(lambda out, mine: os.mkfifo(out / "assets" / "3Dmol-min.js")),
     "assets/3Dmol-min.js: is a FIFO"),
    ("report-page-is-a-symlink-out", _own_folder_with(lambda out, mine: (out / "scenes" / "c.html").symlink_to(
        mine / "index.html")), "scenes/c.html: is a symbolic link"),
    ("report-manifest-is-a-symlink-out", _own_folder_with(lambda out, mine: (out / ".vibra" / "c.json").symlink_to(
        mine / "summary.json")), ".vibra/c.json: is a symbolic link"),
    *[(f"report-out-{folder}-forced", _system(folder, "--force"), f"--out {folder}: is")  # (/bin may be /usr/bin)
      for folder in ("/", "/etc", "/usr", "/bin", "/proc", "/sys", "/dev", "/boot", "/var", "/home")],
    ("report-out-root-unforced", _system("/"), "--out /: is the root folder /; vibra never writes in system folders"),
    ("report-out-new-folder-in-root", _system("/vibra-hostile-test", "--force"),
     "would be created in the root folder /"),
    ("report-out-below-usr", _system("/usr/share/vibra-hostile-test", "--force"), "is in the system folder /usr"),
    ("report-out-symlink-to-etc", _symlink_to_etc, "is the system folder /etc ("),
    ("report-out-new-folder-through-a-symlink-to-usr", _new_folder_below_usr, "is in the system folder /usr"),
    ("sweep-out-a-foreign-folder", _sweep_foreign, "holds files vibra did not write"),
    ("sweep-out-root-forced", _sweep_root, "--out /: is the root folder /"),
]


@pytest.mark.parametrize("case, setup, fragment", FOLDER_CASES, ids=[case[0] for case in FOLDER_CASES])
def test_a_hostile_output_folder_is_refused_before_any_work(case: str, setup: Callable[[Path], Any], fragment: str,
                                                            tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    args, watched = setup(tmp_path)
    before = tree(tmp_path, *watched)
    systems = {folder: sorted(os.listdir(folder)) for folder in ("/", "/etc", "/usr")}
    code, out, err = run_cli(capsys, *args)
    assert code == 1, out + err
    assert err.count("\n") == 1 and fragment.format(tmp=tmp_path) in err, err
    assert "Traceback" not in out + err
    assert tree(tmp_path, *watched) == before  # nothing created, replaced or removed
    assert {folder: sorted(os.listdir(folder)) for folder in systems} == systems


def test_force_writes_into_a_foreign_folder_and_keeps_what_is_not_reports(tmp_path: Path,
                                                                          capsys: pytest.CaptureFixture[str]) -> None:
    foreign = _foreign(tmp_path / "mine")
    note = tree(foreign)[str(foreign / "notes.txt")]
    code, _, err = run_cli(capsys, "report", str(_scene(tmp_path)), "--out", str(foreign), "--force", "-q")
    assert code == 0, err
    assert (foreign / ".vibra").is_dir() and (foreign / "c_spectrum.png").is_file()
    assert tree(foreign)[str(foreign / "notes.txt")] == note
    code, _, err = run_cli(capsys, "report", str(_scene(tmp_path)), "--out", str(foreign), "-q")
    assert code == 0, err  # now vibra's own: no --force needed


@pytest.mark.parametrize("kind", ["new", "empty", "symlink-to-empty", "earlier-report"])
def test_new_empty_and_own_folders_are_written(kind: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene = _scene(tmp_path)
    out = tmp_path / "out"
    if kind == "empty":
        out.mkdir()
    elif kind == "symlink-to-empty":
        (tmp_path / "empty").mkdir()
        out.symlink_to(tmp_path / "empty")
    elif kind == "earlier-report":
        assert run_cli(capsys, "report", str(scene), "--out", str(out), "-q")[0] == 0
    code, _, err = run_cli(capsys, "report", str(scene), "--out", str(out), "-q")
    assert code == 0, err
    assert (out / ".vibra").is_dir() and (out / "index.html").is_file() and (out / "c_spectrum.png").is_file()


def test_sweep_claims_its_folder_and_force_writes_into_a_foreign_one(tmp_path: Path,
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    args = ["sweep", str(DEFECT), "--vary", "system.defect_mass=0.2:0.8:2", "-q"]
    out = tmp_path / "out"
    assert run_cli(capsys, *args, "--out", str(out))[0] == 0
    assert run_cli(capsys, *args, "--out", str(out))[0] == 0  # its own folder, again
    assert (out / ".vibra").is_dir() and (out / "mass-defect_sweep.csv").is_file()
    foreign = _foreign(tmp_path / "mine")
    note = tree(foreign)[str(foreign / "notes.txt")]
    code, _, err = run_cli(capsys, *args, "--out", str(foreign), "--force")
    assert code == 0, err
    assert (foreign / "mass-defect_sweep.csv").is_file() and tree(foreign)[str(foreign / "notes.txt")] == note


def test_a_symlink_in_the_work_folder_is_never_followed(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # .work/<this pid> planted as a link to someone's folder: report removes the link, never what it points to
    scene = _scene(tmp_path)
    foreign = _foreign(tmp_path / "mine")
    (foreign / "c").mkdir()
    (foreign / "c" / "keep.txt").write_text("mine")
    out = tmp_path / "out"
    (out / ".vibra").mkdir(parents=True)
    (out / ".work").mkdir()
    (out / ".work" / str(os.getpid())).symlink_to(foreign)
    before = tree(foreign)
    code, _, err = run_cli(capsys, "report", str(scene), "--out", str(out), "-q")
    assert code == 0, err
    assert tree(foreign) == before


def test_the_rules_are_one_place(tmp_path: Path) -> None:
    # the folder rule and the file rule answer alike for the same system folder, force or not
    for folder in SYSTEM_TREES:
        if os.path.isdir(folder):
            with pytest.raises(TargetRefused, match="system folder"):
                check_out_folder(folder, create=False)
            with pytest.raises(TargetRefused, match="system folder"):
                check_target(Path(folder) / "vibra-hostile-test.npz")
    assert check_out_folder(tmp_path / "new", create=False) == tmp_path / "new" and not (tmp_path / "new").exists()
