"""phonopy's files both ways: ``phonopy.yaml`` and ``FORCE_CONSTANTS``, through phonopy's own code.

- `write_phonopy` (``phonopy.yaml``, with or without the force constants) and
  `write_force_constants` (``FORCE_CONSTANTS``): phonopy's text (``Phonopy.to_phonopy_yaml``,
  ``phonopy.file_IO.get_FORCE_CONSTANTS_lines``) on the `to_phonopy` object, written atomically
  by `vibra._core.filesystem`;
- `read_phonopy`: a phonopy yaml (and a ``FORCE_CONSTANTS`` or ``FORCE_SETS`` file) through
  phonopy's readers, then `Crystal.from_phonopy`, optionally with the sum rules imposed
  (`impose_sum_rules`). Only the files named are read: ``phonopy.load`` would also read
  ``FORCE_SETS``, ``FORCE_CONSTANTS`` and ``BORN`` from the *current directory* when the yaml
  lacks them, so the same call would give another crystal in another folder;
- `check_phonopy_yaml`, `check_force_constants_file`, `check_force_sets_file`: each file is
  checked whole before any physics (issue 34): a yaml cut mid-file (a YAML error, a point
  without its mass, fewer supercell atoms or force-constant blocks than its own shape and
  matrices say, a displacement without all its forces), a ``FORCE_CONSTANTS`` with fewer blocks
  than its header says or a cut last block, a ``FORCE_SETS`` with fewer displacements or force
  lines than it announces; one line naming the file, the line and what is missing.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from vibra._core.filesystem import atomic_write_text
from vibra.crystals.born import read_born
from vibra.crystals.crystal import Crystal
from vibra.crystals.phonopy_io import check_symmetrize, to_phonopy

__all__ = ["read_phonopy", "write_phonopy", "write_force_constants", "check_phonopy_yaml",
           "check_force_constants_file", "check_force_sets_file", "PhonopyYamlSummary"]

_CUT = "the file looks cut"


def write_phonopy(crystal: Crystal, path: str | os.PathLike[str], *, force_constants: bool = True,
                  supercell: Sequence[int] | None = None) -> Path:
    """Write a crystal as ``phonopy.yaml``; with ``force_constants=True`` (default) the force constants too.

    phonopy's own writer builds the text (``Phonopy.to_phonopy_yaml``: the unit cell, the
    supercell and primitive matrices and, when asked, the full supercell force constants);
    vibra writes it atomically (`vibra._core.filesystem`). ``phonopy.load(path)`` reads it back.

    Parameters
    ----------
    crystal : Crystal
        With force constants, in ``SI`` or ``ASE`` units (written in phonopy's eV, Angstrom, amu).
    path : path-like
        The file to write (conventionally ``phonopy.yaml`` or ``phonopy_params.yaml``).
    force_constants : bool
        Include the force constants (else the structure alone; write them with
        `write_force_constants`).
    supercell : 3 ints, optional
        As for `to_phonopy`.

    Returns
    -------
    pathlib.Path
        The file written.
    """
    phonon = to_phonopy(crystal, supercell=supercell)
    text = str(phonon.to_phonopy_yaml(settings={"force_constants": bool(force_constants)}))
    return atomic_write_text(path, text)


def write_force_constants(crystal: Crystal, path: str | os.PathLike[str], *,
                          supercell: Sequence[int] | None = None) -> Path:
    """Write the crystal's full supercell force constants as a phonopy ``FORCE_CONSTANTS`` file.

    The text is phonopy's (``phonopy.file_IO.get_FORCE_CONSTANTS_lines``), eV / Angstrom^2 on
    the supercell of `to_phonopy` (`supercell`, or the smallest that holds every term); it
    carries no structure, so keep the ``phonopy.yaml`` of `write_phonopy` (written with
    ``force_constants=False``) beside it, or pass the structure to `read_phonopy`.
    """
    from phonopy.file_IO import get_FORCE_CONSTANTS_lines

    phonon = to_phonopy(crystal, supercell=supercell)
    lines = get_FORCE_CONSTANTS_lines(np.asarray(phonon.force_constants))
    return atomic_write_text(path, "\n".join(lines) + "\n")


@dataclass(frozen=True)
class PhonopyYamlSummary:
    """What `check_phonopy_yaml` found in a phonopy yaml.

    Attributes
    ----------
    n_supercell : int
        Atoms of the supercell (unit cell atoms times the supercell matrix's determinant).
    n_primitive : int
        Atoms of the primitive cell.
    force_constants : bool
        The file holds force constants.
    forces : bool
        Its displacements carry forces (phonopy can make force constants from them).
    born : bool
        It carries Born charges and eps_inf (phonopy's ``nac`` section, or the two keys at the top
        level as phonopy wrote them before 2.18): the crystal read from it is polar.
    """

    n_supercell: int
    n_primitive: int
    force_constants: bool
    forces: bool
    born: bool = False


def _file_text(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8")
    except UnicodeDecodeError as error:
        raise ValueError(f"{path}: byte {error.start} is not UTF-8 text; phonopy files are text") from None
    except OSError as error:
        raise ValueError(f"{path}: cannot be read ({error.strerror or error})") from None


def _yaml_line(text: str, key: str) -> int:
    """1-based line of the top-level `key:` in `text` (for messages)."""
    for number, line in enumerate(text.splitlines(), start=1):
        if line.startswith(f"{key}:"):
            return number
    return 1


def _cell_atoms(path: Path, text: str, data: dict[str, Any], key: str) -> int | None:
    """Atoms in the cell section `key` (None when absent), each point whole."""
    cell = data.get(key)
    if cell is None:
        return None
    line = _yaml_line(text, key)
    if not isinstance(cell, dict) or not isinstance(cell.get("lattice"), list) or len(cell["lattice"]) != 3 \
            or not isinstance(cell.get("points"), list):
        raise ValueError(f"{path}: line {line}: the {key} section lacks its lattice (3 vectors) or its points; {_CUT}")
    points = cell["points"]
    with_mass = sum(isinstance(point, dict) and "mass" in point for point in points)
    for index, point in enumerate(points, start=1):
        coordinates = point.get("coordinates") if isinstance(point, dict) else None
        if not isinstance(coordinates, list) or len(coordinates) != 3 or (with_mass and "mass" not in point):
            raise ValueError(f"{path}: line {line}: point {index} of {key} has no "
                             f"{'coordinates' if not isinstance(coordinates, list) or len(coordinates) != 3 else 'mass'}"
                             f" (the section holds {len(points)} points); {_CUT}")
    return len(points)


def _determinant(path: Path, text: str, data: dict[str, Any], key: str) -> float:
    matrix = data.get(key)
    if matrix is None:
        return 1.0
    try:
        array = np.array(matrix, dtype=float)
    except (TypeError, ValueError):
        array = np.zeros(0)
    if array.shape != (3, 3):
        raise ValueError(f"{path}: line {_yaml_line(text, key)}: {key} is not a 3 x 3 matrix; {_CUT}")
    return float(np.linalg.det(array))


def check_phonopy_yaml(path: str | os.PathLike[str]) -> PhonopyYamlSummary:
    """Check that a phonopy yaml is whole before phonopy reads it (module docstring).

    Returns
    -------
    PhonopyYamlSummary

    Raises
    ------
    ValueError
        One line naming the file (and the line): not YAML (cut mid-record), no unit cell, a
        point without coordinates or mass, fewer supercell or primitive atoms than the
        matrices give, fewer force-constant blocks than ``shape`` says, a displacement whose
        forces are not one per supercell atom.
    """
    import yaml

    source = Path(path)
    text = _file_text(source)
    safe = getattr(yaml, "CSafeLoader", yaml.SafeLoader)  # plain data only: never a loader that builds objects
    reader = safe(text)
    try:
        data = reader.get_single_data()
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f"line {mark.line + 1}: " if mark is not None else ""
        problem = getattr(error, "problem", None) or type(error).__name__
        raise ValueError(f"{source}: {where}not valid YAML ({problem}); {_CUT} or damaged") from None
    finally:
        reader.dispose()
    if not isinstance(data, dict) or not isinstance(data.get("unit_cell"), dict):
        raise ValueError(f"{source}: holds no unit_cell section; a phonopy yaml (phonopy.yaml, phonopy_disp.yaml) "
                         f"starts with its cells{'' if isinstance(data, dict) else ' (this is not a YAML mapping)'}")
    n_unit = _cell_atoms(source, text, data, "unit_cell")
    assert n_unit is not None  # unit_cell was checked to be there
    n_super = int(round(n_unit * abs(_determinant(source, text, data, "supercell_matrix"))))
    n_primitive = int(round(n_unit * abs(_determinant(source, text, data, "primitive_matrix"))))
    for key, expected in (("supercell", n_super), ("primitive_cell", n_primitive)):
        found = _cell_atoms(source, text, data, key)
        if found is not None and found != expected:
            raise ValueError(f"{source}: line {_yaml_line(text, key)}: the {key} section holds {found} points; "
                             f"the unit cell's {n_unit} atoms and the matrices give {expected}; {_CUT}")
    has_fc = "force_constants" in data
    if has_fc:
        block = data["force_constants"]
        line = _yaml_line(text, "force_constants")
        shape = block.get("shape") if isinstance(block, dict) else None
        elements = block.get("elements") if isinstance(block, dict) else None
        if not (isinstance(shape, list) and len(shape) == 2 and all(isinstance(n, int) and n > 0 for n in shape)):
            raise ValueError(f"{source}: line {line}: force_constants has no shape [n, m]; {_CUT}")
        blocks = len(elements) if isinstance(elements, list) else 0
        if blocks != shape[0] * shape[1]:
            raise ValueError(f"{source}: line {line}: force_constants has shape {shape} ({shape[0] * shape[1]} blocks) "
                             f"but holds {blocks}; {_CUT}")
        for index, element in enumerate(elements, start=1):
            if not (isinstance(element, list) and len(element) == 3
                    and all(isinstance(row, list) and len(row) == 3 for row in element)):
                raise ValueError(f"{source}: line {line}: force-constant block {index} of {blocks} is not 3 x 3; {_CUT}")
        if shape[1] != n_super:
            raise ValueError(f"{source}: line {line}: force_constants has shape {shape}; the supercell has {n_super} atoms")
    forces = _check_displacements(source, text, data, n_super)
    section = data.get("nac") if isinstance(data.get("nac"), dict) else data  # phonopy's _parse_nac
    born = "born_effective_charge" in section and "dielectric_constant" in section
    return PhonopyYamlSummary(n_supercell=n_super, n_primitive=n_primitive, force_constants=has_fc, forces=forces,
                              born=born)


def _check_displacements(source: Path, text: str, data: dict[str, Any], n_super: int) -> bool:
    """True when the displacements carry forces; each displacement with all its forces."""
    entries = data.get("displacements")
    if entries is None:
        return False
    line = _yaml_line(text, "displacements")
    if not isinstance(entries, list) or not entries:
        raise ValueError(f"{source}: line {line}: displacements is empty; {_CUT}")
    with_forces = 0
    for index, entry in enumerate(entries, start=1):
        if isinstance(entry, dict):  # type 1: one atom displaced
            whole = isinstance(entry.get("displacement"), list) and len(entry["displacement"]) == 3 and "atom" in entry
            forces = entry.get("forces")
        else:  # type 2: every atom, {displacement, force} per atom
            whole = isinstance(entry, list) and len(entry) == n_super
            forces = [item.get("force") for item in entry] if whole and all(isinstance(i, dict) for i in entry) else None
            if forces is not None and all(f is None for f in forces):
                forces = None
        if not whole:
            raise ValueError(f"{source}: line {line}: displacement {index} of {len(entries)} is incomplete; {_CUT}")
        if forces is not None:
            with_forces += 1
            if not (isinstance(forces, list) and len(forces) == n_super
                    and all(isinstance(f, list) and len(f) == 3 for f in forces)):
                count = len(forces) if isinstance(forces, list) else 0
                raise ValueError(f"{source}: line {line}: displacement {index} of {len(entries)} has {count} force rows; "
                                 f"the supercell has {n_super} atoms; {_CUT}")
    if 0 < with_forces < len(entries):
        raise ValueError(f"{source}: line {line}: {with_forces} of the {len(entries)} displacements carry forces; "
                         f"the others have none; {_CUT}")
    return with_forces > 0


def _ends_whole(source: Path, text: str, row_width: int | None = None) -> None:
    """A text file phonopy wrote ends with a line break; without one the last number may be cut.

    phonopy's own ``write_FORCE_CONSTANTS`` ends without one: its rows have one fixed width
    ("%22.15f" x 3), so `row_width` given, a last line of that width is whole (a cut number
    would shorten it)."""
    if text and not text.endswith("\n"):
        if row_width is not None and len(text.rsplit("\n", 1)[-1]) == row_width:
            return
        raise ValueError(f"{source}: line {text.count(chr(10)) + 1}: the last line has no line break, so its last "
                         f"number may be cut; {_CUT} (if it is whole, end it with a line break)")


def _numbers(line: str, count: int) -> list[float] | None:
    parts = line.split()
    if len(parts) != count:
        return None
    try:
        values = [float(x) for x in parts]
    except ValueError:
        return None
    return values if all(np.isfinite(values)) else None


def check_force_constants_file(path: str | os.PathLike[str], n_supercell: int | None = None) -> tuple[int, int]:
    """Check that a phonopy ``FORCE_CONSTANTS`` text file is whole; return its (n, m) blocks.

    The header (line 1) gives n m (or n: n x n); then n m blocks of 4 lines: "i j" and three
    rows of three numbers. `n_supercell`, when given, must be m.

    Raises
    ------
    ValueError
        One line naming the file and the line: a header that is not one or two positive
        integers, a block cut short or damaged, fewer (or more) blocks than the header says,
        m not the supercell's atom count.
    """
    source = Path(path)
    if source.suffix == ".hdf5":
        return (0, 0)  # binary: phonopy's reader checks its shape
    text = _file_text(source)
    lines = text.splitlines()
    header = lines[0].split() if lines else []
    if not 1 <= len(header) <= 2 or not all(x.isdigit() and int(x) > 0 for x in header):
        raise ValueError(f"{source}: line 1: is {(lines[0] if lines else '')[:40]!r}; a FORCE_CONSTANTS file starts "
                         "with its number of blocks, 'n m' (or 'n')")
    n, m = int(header[0]), int(header[-1])
    body = [(number, line) for number, line in enumerate(lines[1:], start=2) if line.strip()]
    expected = n * m
    whole = len(body) // 4
    firsts: list[tuple[int, int]] = []  # (atom i, line) of each row's first block
    for block in range(min(whole + 1, expected)):
        chunk = body[4 * block:4 * block + 4]
        if len(chunk) < 4:
            last = chunk[-1][0] if chunk else (body[-1][0] if body else 1)
            raise ValueError(f"{source}: line {last}: block {block + 1} of {expected} stops after {len(chunk)} of its "
                             f"4 lines; the header (line 1) announces {n} x {m} blocks; {_CUT}")
        number, pair = chunk[0]
        labels = _numbers(pair, 2)
        if labels is None:
            raise ValueError(f"{source}: line {number}: is {pair.strip()[:40]!r}; block {block + 1} starts with "
                             "its atom pair 'i j'")
        _check_pair(source, number, block, labels, n, m, firsts)
        for number, row in chunk[1:]:
            if _numbers(row, 3) is None:
                raise ValueError(f"{source}: line {number}: is {row.strip()[:60]!r}; a force-constant row reads 3 "
                                 f"numbers{'; ' + _CUT if number == body[-1][0] else ''}")
    if whole != expected or len(body) != 4 * expected:
        raise ValueError(f"{source}: line {body[-1][0] if body else 1}: the file holds {whole} whole blocks; the header "
                         f"(line 1) announces {n} x {m} = {expected}" + (f"; {_CUT}" if whole < expected else ""))
    widths = [len(line) for _, line in body[-8:-1] if len(line.split()) == 3]  # the force rows before the last
    _ends_whole(source, text, widths[-1] if widths and len(set(widths)) == 1 else None)
    if n_supercell is not None and m != n_supercell:
        raise ValueError(f"{source}: line 1: holds {n} x {m} blocks; the supercell of the yaml has {n_supercell} atoms")
    return n, m


def _check_pair(source: Path, number: int, block: int, labels: Any, n: int, m: int,
                firsts: list[tuple[int, int]]) -> None:
    """Block `block`'s atom pair "i j" against phonopy's order: row r = block // m of the n atoms
    (i = r + 1 for a full n x n set; for a compact one the supercell index of the r-th primitive
    atom, increasing), column j = block % m + 1. phonopy's reader takes the blocks in order and
    checks only the set of i, so a pair out of place would be read as another pair silently.
    `firsts`: (i, line) of each row's first block so far."""
    if any(x != int(x) for x in labels):
        raise ValueError(f"{source}: line {number}: block {block + 1} is the pair {' '.join(f'{x:g}' for x in labels)!r}; "
                         "an atom pair is two whole atom numbers 'i j'")
    i, j = (int(x) for x in labels)
    row, column = divmod(block, m)
    order = f"the blocks go in phonopy's order: i over the {n} atoms, j over the {m}"
    if column == 0:
        if (n == m and i != row + 1) or (firsts and i <= firsts[-1][0]) or not 1 <= i <= m:
            expected = f"{row + 1}" if n == m else f"above {firsts[-1][0]} (line {firsts[-1][1]})" if firsts else \
                f"in 1..{m}"
            raise ValueError(f"{source}: line {number}: block {block + 1} is the pair '{i} {j}'; its first atom should "
                             f"be {expected} ({order})")
        firsts.append((i, number))
    first, line = firsts[-1]
    if i != first or j != column + 1:
        raise ValueError(f"{source}: line {number}: block {block + 1} is the pair '{i} {j}'; phonopy's order puts "
                         f"'{first} {column + 1}' there (its row starts with atom {first} at line {line}; {order})")


def check_force_sets_file(path: str | os.PathLike[str], n_supercell: int | None = None) -> int:
    """Check that a phonopy ``FORCE_SETS`` file is whole; return its number of displacements.

    Type 1: the atom count, the number of displacements, then per displacement the displaced
    atom, its displacement (3 numbers) and one force row (3 numbers) per atom. Type 2: one row
    of 6 numbers (displacement, force) per atom and supercell, in whole supercells.

    Raises
    ------
    ValueError
        One line naming the file and the line: fewer displacements or force rows than the
        file announces (a cut file), a damaged row, an atom count that is not the supercell's.
    """
    source = Path(path)
    text = _file_text(source)
    rows = [(number, line.split("#")[0].strip()) for number, line in enumerate(text.splitlines(), start=1)]
    rows = [(number, line) for number, line in rows if line]
    if not rows:
        raise ValueError(f"{source}: line 1: the file is empty; a FORCE_SETS file holds displacements and forces")
    first = rows[0][1].split()
    if len(first) == 6:  # type 2
        for number, line in rows:
            if _numbers(line, 6) is None:
                raise ValueError(f"{source}: line {number}: is {line[:60]!r}; a type-2 FORCE_SETS row reads 6 numbers "
                                 f"(displacement, force){'; ' + _CUT if number == rows[-1][0] else ''}")
        _ends_whole(source, text)
        if n_supercell is not None and len(rows) % n_supercell:
            raise ValueError(f"{source}: line {rows[-1][0]}: {len(rows)} rows are not whole supercells of {n_supercell} "
                             f"atoms ({len(rows) // n_supercell} whole, {len(rows) % n_supercell} rows over); {_CUT}")
        return len(rows) // (n_supercell or len(rows))
    if len(rows) < 2 or _numbers(rows[0][1], 1) is None or _numbers(rows[1][1], 1) is None:
        raise ValueError(f"{source}: line {rows[0][0]}: a FORCE_SETS file starts with the number of atoms and the "
                         "number of displacements (one integer a line), or with type-2 rows of 6 numbers")
    n_atoms, n_displacements = int(rows[0][1]), int(rows[1][1])
    if n_supercell is not None and n_atoms != n_supercell:
        raise ValueError(f"{source}: line {rows[0][0]}: has forces on {n_atoms} atoms; the supercell of the yaml has "
                         f"{n_supercell}")
    per = 2 + n_atoms
    body = rows[2:]
    for k in range(n_displacements):
        chunk = body[per * k:per * (k + 1)]
        if len(chunk) < per:
            last = chunk[-1][0] if chunk else rows[-1][0]
            raise ValueError(f"{source}: line {last}: the file ends within displacement {k + 1} of {n_displacements} "
                             f"(line {rows[1][0]} announces them; {max(0, len(chunk) - 2)} of its {n_atoms} force rows "
                             f"read); {_CUT}")
        for offset, (number, line) in enumerate(chunk):
            count = 1 if offset == 0 else 3
            if _numbers(line, count) is None:
                what = ("the displaced atom's number" if offset == 0 else
                        "a displacement (3 numbers)" if offset == 1 else "a force row (3 numbers)")
                raise ValueError(f"{source}: line {number}: is {line[:60]!r}; expected {what}"
                                 f"{'; ' + _CUT if number == rows[-1][0] else ''}")
    if len(body) > per * n_displacements:
        raise ValueError(f"{source}: line {body[per * n_displacements][0]}: more lines follow the {n_displacements} "
                         f"displacements line {rows[1][0]} announces")
    _ends_whole(source, text)
    return n_displacements


def read_phonopy(path: str | os.PathLike[str], *, force_constants: str | os.PathLike[str] | None = None,
                 force_sets: str | os.PathLike[str] | None = None, symmetrize: bool | str | None = "auto",
                 primitive: str | None = None, born: str | os.PathLike[str] | None = None, nac: str | None = None,
                 name: str | None = None) -> Crystal:
    """A `Crystal` from a phonopy yaml (and a ``FORCE_CONSTANTS`` or ``FORCE_SETS`` file).

    Every file is checked whole first (`check_phonopy_yaml`, `check_force_constants_file`,
    `check_force_sets_file`), then read by phonopy's own readers (``PhonopyYaml``,
    ``parse_FORCE_CONSTANTS``, ``read_force_sets``); phonopy makes the force constants from
    forces. Only the files named here are read: unlike ``phonopy.load``, nothing is taken
    from the current directory (``FORCE_SETS``, ``FORCE_CONSTANTS``, ``BORN``).

    Parameters
    ----------
    path : path-like
        ``phonopy.yaml`` / ``phonopy_disp.yaml`` / ``phonopy_params.yaml``: the structure, the
        supercell and primitive matrices, and force constants or forces if it holds them.
    force_constants : path-like, optional
        A ``FORCE_CONSTANTS`` (text) or ``force_constants.hdf5`` file for that supercell.
    force_sets : path-like, optional
        A ``FORCE_SETS`` file (type 1 or 2) with the forces of that supercell's displacements.
        Without either file, the force constants come from the yaml (stored, or made from the
        forces of its displacements).
    symmetrize : "auto", "phonopy", True, "projection" or False
        ``"auto"`` (default): as ``phonopy.load`` (``symmetrize_fc=True``): force constants made
        from forces get phonopy's ``symmetrize_force_constants``, force constants read from a
        file are taken as they are. ``"phonopy"``: phonopy's symmetrisation in every case.
        True or ``"projection"``: the acoustic sum rule and the index symmetry imposed exactly
        (`impose_sum_rules`, vibra's own projection). False: as they are. Force constants that
        still break the index symmetry draw a `ForceConstantsWarning`; their D(q) is made
        Hermitian as phonopy does (`vibra.crystals.dynamical.assembly`).
    primitive : None or "auto"
        The primitive cell: None (default) takes the yaml's ``primitive_matrix``, or the unit
        cell itself when the yaml has none (an explicit matrix is always passed to phonopy, so
        the crystal is the cell the file describes); ``"auto"`` lets phonopy find a primitive
        cell by symmetry (what ``phonopy.load`` does for a yaml without ``primitive_matrix``).
    born : path-like, optional
        A phonopy ``BORN`` file: Born charges and eps_inf for the non-analytic (LO-TO)
        correction (`vibra.crystals.born.read_born`; its factor, or e^2 / (4 pi eps0) in eV
        Angstrom when it gives none). Without it, the yaml's own Born charges (phonopy's ``nac``
        section) are used when it has them; nothing else is read.
    nac : "gonze", "wang" or None
        The form of the correction (`Crystal.with_nac`); None: the yaml's, else Gonze-Lee
        (phonopy's default).
    name : str, optional
        The crystal's name (default: the file's stem).

    Returns
    -------
    Crystal
        phonopy's primitive cell with its force constants (and correction), ASE units (see
        `from_phonopy`).

    Raises
    ------
    ValueError
        A file that is missing, cut or damaged (the message names it and the line); both
        `force_constants` and `force_sets`; a BORN file that does not match the crystal (one line
        naming the file and the line); no force constants and no forces anywhere; a file
        phonopy cannot read; the checks of `phonopy_terms`.
    """
    source = Path(path)
    if not source.is_file():
        raise ValueError(f"{source}: no such phonopy yaml file")
    files: dict[str, Path] = {}
    for option, value in (("force_constants", force_constants), ("force_sets", force_sets)):
        if value is not None:
            files[option] = Path(value)
            if not files[option].is_file():
                raise ValueError(f"{option}: {files[option]}: no such file")
    if len(files) == 2:
        raise ValueError("give force_constants= or force_sets=, not both (phonopy would make the force constants "
                         "from the forces and drop the others)")
    summary = check_phonopy_yaml(source)
    if "force_constants" in files:
        check_force_constants_file(files["force_constants"], summary.n_supercell)
    elif "force_sets" in files:
        check_force_sets_file(files["force_sets"], summary.n_supercell)
    elif not (summary.force_constants or summary.forces):
        raise ValueError(f"{source}: holds no force constants and no forces; give the FORCE_CONSTANTS file "
                         "(force_constants=) or the FORCE_SETS file (force_sets=) of its supercell")
    how = check_symmetrize(None if symmetrize == "auto" else symmetrize)
    if primitive not in (None, "auto"):
        raise ValueError(f"primitive is {primitive!r}; expected None (the yaml's primitive matrix, or its unit cell) "
                         "or 'auto' (phonopy's primitive cell by symmetry)")
    if born is not None and not Path(born).is_file():
        raise ValueError(f"born: {Path(born)}: no such file")
    if nac not in (None, "gonze", "wang"):
        raise ValueError(f"nac is {nac!r}; expected 'gonze' (Gonze-Lee, phonopy's default), 'wang' or None")
    phonon, from_forces = _load(source, files, primitive)
    if symmetrize == "auto" and from_forces:
        how = "phonopy"
    crystal = Crystal.from_phonopy(phonon, name=name if name is not None else source.stem, symmetrize=how,
                                   nac=born is None)
    if born is not None:
        charges, dielectric, factor = read_born(born, crystal)
        crystal = crystal.with_nac(charges, dielectric, factor=factor, method=nac or "gonze", phonon=phonon)
    elif nac is not None and crystal.nac is None:
        raise ValueError(f"nac is {nac!r} but {source} has no Born charges (no nac section); give the BORN file "
                         "(born=) for the correction")
    elif nac is not None and crystal.nac is not None and crystal.nac.method != nac:
        crystal = crystal.with_nac(crystal.nac.born, crystal.nac.dielectric, factor=crystal.nac.factor, method=nac,
                                   phonon=phonon, sum_rule="keep")
    return crystal


def _load(source: Path, files: dict[str, Path], primitive: str | None) -> tuple[Any, bool]:
    """A `phonopy.Phonopy` with force constants from the (checked) files, and from nowhere else;
    True when phonopy made them from forces."""
    from phonopy import Phonopy
    from phonopy.file_IO import parse_FORCE_CONSTANTS, parse_FORCE_SETS, read_force_constants_hdf5
    from phonopy.harmonic.force_constants import compact_fc_to_full_fc
    from phonopy.interface.phonopy_yaml import PhonopyYaml

    current = source
    try:
        stored = PhonopyYaml().read(source)
        supercell_matrix = stored.supercell_matrix if stored.supercell_matrix is not None else np.eye(3, dtype=int)
        if primitive == "auto":
            matrix: Any = "auto"
        elif stored.primitive_matrix is not None:
            matrix = np.asarray(stored.primitive_matrix, dtype=float)
        else:
            matrix = np.eye(3)
        with warnings.catch_warnings():  # phonopy 4 warns that "auto" is its new default: asked for here
            warnings.simplefilter("ignore")
            phonon = Phonopy(stored.unitcell, supercell_matrix, primitive_matrix=matrix,
                             calculator=stored.calculator, log_level=0)
        if stored.nac_params is not None:  # the yaml's own Born charges (phonopy's nac section)
            phonon.nac_params = stored.nac_params
        fc = None
        from_forces = False
        if "force_constants" in files:
            current = files["force_constants"]
            p2s = phonon.primitive.p2s_map
            fc = (read_force_constants_hdf5(filename=current, p2s_map=p2s) if current.suffix == ".hdf5"
                  else parse_FORCE_CONSTANTS(filename=str(current), p2s_map=p2s))
        elif "force_sets" in files:
            current = files["force_sets"]
            phonon.dataset = parse_FORCE_SETS(natom=len(phonon.supercell), filename=str(current))  # stable since phonopy 2
            phonon.produce_force_constants()
            from_forces = True
        elif stored.force_constants is not None:
            fc = stored.force_constants
        else:
            phonon.dataset = stored.dataset
            phonon.produce_force_constants()
            from_forces = True
        if fc is not None:
            if fc.shape[0] != fc.shape[1]:
                fc = compact_fc_to_full_fc(phonon.primitive, fc)
            phonon.force_constants = fc
    except Exception as error:  # phonopy raises many kinds for a file it cannot use
        detail = " ".join(str(error).split())[:200]
        raise ValueError(f"{current}: phonopy could not read it ({type(error).__name__}: {detail})") from None
    return phonon, from_forces
