"""A structure file's text, as `vibra.networks.from_pdb` reads it: plain or gzip-compressed, binary formats refused.

The PDB archive and most servers hand out structures compressed (``1abc.cif.gz``, ``pdb1abc.ent.gz``), and
ProDy's ``parsePDB`` reads them as they come; so does `structure_text`, by the file's first two bytes (gzip's
magic number, whatever the name), the format then named by the suffix under ``.gz``. What is not text (MMTF,
BinaryCIF, an archive, an image) is refused with its name rather than parsed as PDB and found to hold no atoms.
A compressed file is read in pieces and refused once its text passes `vibra.networks.pdb.MAX_FILE_BYTES`
(a small file that inflates without end is not read whole).
"""

from __future__ import annotations

import gzip
import zlib
from pathlib import Path

__all__ = ["MMCIF_SUFFIXES", "BINARY_SUFFIXES", "is_mmcif", "structure_text"]

#: Names read as mmCIF (under a ``.gz``); any other is read as PDB text (``.pdb``, ``.ent``, ...).
MMCIF_SUFFIXES = (".cif", ".mmcif")
#: Binary structure formats, refused by name: vibra reads PDB and mmCIF text.
BINARY_SUFFIXES = {".mmtf": "MMTF", ".bcif": "BinaryCIF"}

_GZIP_MAGIC = b"\x1f\x8b"
_PIECE = 1 << 20


def _format_name(file: Path) -> str:
    """The suffix that names the format: the one under ``.gz`` for a compressed name."""
    suffixes = [s.lower() for s in file.suffixes]
    if suffixes and suffixes[-1] == ".gz":
        suffixes.pop()
    return suffixes[-1] if suffixes else ""


def is_mmcif(file: Path) -> bool:
    """Whether `file` is read as mmCIF: its name ends in ``.cif`` or ``.mmcif``, with ``.gz`` or without."""
    return _format_name(file) in MMCIF_SUFFIXES


def structure_text(file: Path, limit: int) -> str:
    """The text of the structure file `file` (decompressed where gzip's magic number opens it), at most `limit`
    characters.

    Raises
    ------
    ValueError
        A binary format (MMTF, BinaryCIF, or bytes that are not text: a NUL in the first 64 KiB), a damaged or
        cut gzip stream, or a text of more than `limit` bytes once decompressed; the message names the file.
    """
    kind = BINARY_SUFFIXES.get(_format_name(file))
    if kind is not None:
        raise ValueError(f"{file}: {kind}, a binary format; from_pdb reads PDB or mmCIF text, plain or "
                         "gzip-compressed (.pdb, .cif, .pdb.gz, .cif.gz)")
    with open(file, "rb") as handle:
        compressed = handle.read(2) == _GZIP_MAGIC
    if compressed:
        pieces: list[bytes] = []
        size = 0
        try:
            with gzip.open(file, "rb") as stream:
                while piece := stream.read(_PIECE):
                    size += len(piece)
                    if size > limit:
                        raise ValueError(f"{file}: more than {limit} bytes once decompressed, the most that "
                                         "from_pdb reads")
                    pieces.append(piece)
        except (OSError, EOFError, zlib.error) as error:
            raise ValueError(f"{file}: a damaged or cut gzip file ({error})") from None
        data = b"".join(pieces)
    else:
        data = file.read_bytes()
    if b"\x00" in data[:65536]:
        raise ValueError(f"{file}: binary data, not a structure's text; from_pdb reads PDB or mmCIF text, plain "
                         "or gzip-compressed")
    return data.decode("latin-1").replace("\r\n", "\n").replace("\r", "\n")  # (as text mode reads CR and CRLF ends)
