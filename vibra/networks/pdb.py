"""Structure files for elastic network models: `from_pdb` reads sites and B-factors (Biopython).

The reader behind `vibra.networks.from_pdb` (which re-exports `from_pdb`, `Structure` and
`MAX_FILE_BYTES`): the first model, the first alternate location of each residue, C-alpha
atoms of amino-acid residues (modified ones such as MSE included when peptide-linked) or
every atom.
"""

from __future__ import annotations

import io
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from vibra import _validate
from vibra._frozen import freeze_arrays

__all__ = ["Structure", "from_pdb", "MAX_FILE_BYTES", "PEPTIDE_BOND_MAX"]

MAX_FILE_BYTES = 512 * 2**20  #: largest structure file `from_pdb` reads, checked before reading
PEPTIDE_BOND_MAX = 2.0  #: longest C-N distance (Å) read as a peptide bond (1.33 Å in a chain)

_SELECTIONS = ("CA", "all")


@dataclass(frozen=True, eq=False)
class Structure:
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
        One ``"chain:RESNAMEnumber[icode]:atom"`` label per site, e.g. ``"A:MET1:CA"``.
    """

    path: str
    selection: str
    positions: NDArray[np.float64]
    b_factors: NDArray[np.float64]
    labels: tuple[str, ...]

    def __post_init__(self) -> None:
        freeze_arrays(self)

    @property
    def n_sites(self) -> int:
        """Number of sites selected."""
        return int(self.positions.shape[0])



def from_pdb(path: str | os.PathLike[str], selection: Literal["CA", "all"] = "CA") -> Structure:
    """Coordinates and B-factors of a PDB (or mmCIF: ``.cif``) file, read with Biopython.

    The first model is read, and of each residue with alternate locations the first
    conformation (``A``): its atoms and those without an altloc code, as ProDy does (atoms
    found only in another conformation are left out). Hydrogens are kept with ``"all"``.

    Parameters
    ----------
    path : str or os.PathLike
        A regular file of at most `MAX_FILE_BYTES` bytes, PDB format (mmCIF when its name
        ends in ``.cif`` or ``.mmcif``).
    selection : {"CA", "all"}
        ``"CA"``: the C-alpha atoms of amino-acid residues (standard or modified, such as
        MSE; a calcium ion named CA is not one); ``"all"``: every atom.

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
        Not a regular file, larger than `MAX_FILE_BYTES`, unreadable by the parser, an
        unknown selection, or nothing selected (no atoms, no C-alpha atoms); the message names
        the file.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike, got {type(path).__name__}")
    file = Path(path)
    _validate.choice(selection, "selection", _SELECTIONS)
    if not file.exists():
        raise FileNotFoundError(f"{file}: no such file")
    if not file.is_file():
        raise ValueError(f"{file}: not a regular file")
    size = file.stat().st_size
    if size > MAX_FILE_BYTES:
        raise ValueError(f"{file}: {size} bytes, more than the {MAX_FILE_BYTES} that from_pdb reads")
    atoms = _read_atoms(file, backbone=selection == "CA")
    if selection == "CA":
        atoms = [atom for atom in atoms if atom[1] == "CA" and atom[4]]
        if not atoms:
            raise ValueError(f"{file}: no C-alpha atoms (atoms named CA in amino-acid residues) in the first model")
    if not atoms:
        raise ValueError(f"{file}: no atoms in the first model")
    return Structure(
        path=str(file), selection=selection,
        positions=_decimal_float64(np.array([atom[2] for atom in atoms], dtype=np.float32)),
        b_factors=np.array([atom[3] for atom in atoms], dtype=float),
        labels=tuple(f"{atom[0]}:{atom[1]}" for atom in atoms),
    )


def _decimal_float64(values: NDArray[np.float32]) -> NDArray[np.float64]:
    """Biopython keeps coordinates in float32; its shortest repr gives back the file's decimals
    (PDB 8.3f: at most 7 significant digits) as float64."""
    return np.asarray(values.astype(str), dtype=np.float64)


#: Atoms a C-alpha selection needs: CA, and N and C to tell a peptide-linked HETATM (MSE).
_BACKBONE = frozenset({"N", "CA", "C"})


def _read_atoms(file: Path, *, backbone: bool = False) -> list[tuple[str, str, NDArray[np.float32], float, bool]]:
    """(residue label, atom name, xyz, B, in an amino acid) of each atom of model 0.

    `backbone`: a PDB file's ATOM/HETATM records of other atoms than N, CA and C are dropped
    before Biopython parses it (a C-alpha selection needs no more; 2.5 times fewer atoms to
    parse in a protein).
    """
    from Bio.PDB.MMCIFParser import MMCIFParser  # here only: `import vibra.networks` needs no Biopython
    from Bio.PDB.PDBParser import PDBParser
    from Bio.PDB.Polypeptide import is_aa

    cif = file.suffix.lower() in (".cif", ".mmcif")
    parser = MMCIFParser(QUIET=True) if cif else PDBParser(QUIET=True)
    source: Any = str(file)
    if backbone and not cif:
        with open(file, encoding="latin-1") as handle:
            lines = [line for line in handle
                     if not line.startswith(("ATOM", "HETATM")) or line[12:16].strip() in _BACKBONE]
        source = io.StringIO("".join(lines))
    try:
        structure = parser.get_structure(file.stem, source)
    except Exception as error:  # Biopython raises several types on malformed input
        raise ValueError(f"{file}: cannot be read as {'mmCIF' if cif else 'PDB'}: {error}") from None
    models = list(structure)
    atoms = []
    for chain in models[0] if models else []:
        residues = [_first_variant(residue) for residue in chain]
        for index, residue in enumerate(residues):
            hetero, number, insertion = residue.get_id()
            label = f"{chain.id}:{residue.get_resname()}{number}{insertion.strip()}"
            amino = bool(is_aa(residue, standard=False)) and (
                hetero == " " or _peptide_linked(residues, index))
            conformation = _first_altloc(residue)
            for atom in residue:
                if atom.is_disordered():
                    if conformation not in atom.disordered_get_id_list():
                        continue  # an atom of other conformations only (ProDy drops them too)
                    atom = atom.disordered_get(conformation)
                elif atom.get_altloc() not in (" ", conformation):
                    continue
                atoms.append((label, atom.get_id(), atom.coord, float(atom.get_bfactor()), amino))
    return atoms


def _first_altloc(residue: Any) -> str:
    """The first alternate-location code among a residue's atoms (" " if none)."""
    codes = [code for atom in residue for code in (
        atom.disordered_get_id_list() if atom.is_disordered() else [atom.get_altloc()]) if code != " "]
    return min(codes, default=" ")


def _first_variant(residue: Any) -> Any:
    """Of a residue with point mutations (one per alternate location), the one with the first altloc."""
    if residue.is_disordered() != 2:
        return residue
    return min(residue.disordered_get_list(), key=_first_altloc)


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
