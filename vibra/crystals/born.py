"""Born effective charges and dielectric tensors from files: phonopy's BORN, and a phonopy object's nac_params.

- `read_born`: a BORN file (an optional first line with the unit factor, eps_inf as 9 numbers,
  then one line of 9 numbers per symmetry-independent atom), checked line by line, then
  expanded to every atom of the crystal by phonopy's own ``parse_BORN``;
- `nac_from_phonopy`: ``phonon.nac_params`` as the arguments of `vibra.crystals.nac.non_analytic`.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, TypedDict

import numpy as np
from numpy.typing import NDArray

from vibra._core import validate as _validate
from vibra.crystals.mesh import species_numbers
from vibra.crystals.phonopy_io import to_ase_factors

if TYPE_CHECKING:
    from phonopy import Phonopy

    from vibra.crystals.force_constants import CrystalLike as Crystal  # the protocol: no import cycle

__all__ = ["BORN_MAX_BYTES", "read_born", "nac_from_phonopy"]


#: Largest BORN file read (they are a few lines).
BORN_MAX_BYTES = 1 << 20


def _phonopy_atoms(crystal: Crystal) -> Any:
    from phonopy.structure.atoms import PhonopyAtoms

    length, mass, _ = to_ase_factors(crystal, dimensionless=True)
    numbers = species_numbers(crystal)
    return PhonopyAtoms(cell=crystal.cell * length, scaled_positions=crystal.fractional, numbers=numbers,
                        masses=crystal.masses * mass)


def _numbers(path: Path, number: int, line: str, what: str) -> list[float]:
    tokens = line.split()
    if len(tokens) != 9:
        raise ValueError(f"{path}: line {number} has {len(tokens)} values; expected 9 numbers ({what})")
    try:
        return [float(token) for token in tokens]
    except ValueError:
        bad = next(t for t in tokens if not _is_number(t))
        raise ValueError(f"{path}: line {number}: {bad!r} is not a number ({what})") from None


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def read_born(path: str | Path, crystal: Crystal, *, symprec: float = 1e-5
              ) -> tuple[NDArray[np.float64], NDArray[np.float64], float | None]:
    """Born charges and eps_inf from a phonopy BORN file, expanded to every atom of the crystal.

    The format: line 1 the unit factor (or any text, e.g. a comment), line 2 the nine entries
    of eps_inf, then one line of nine numbers Z*[a][b] per symmetry-independent atom of the
    crystal, in phonopy's order. phonopy's own ``parse_BORN`` expands them to every atom with the
    crystal's space group.

    Parameters
    ----------
    path : str or Path
        The BORN file.
    crystal : Crystal
        Its cell and atoms (the primitive cell the file was written for).
    symprec : float
        Symmetry tolerance of the space-group search, in Angstrom (phonopy's; a dimensionless
        crystal's in its length unit).

    Returns
    -------
    born : (n_atoms, 3, 3) ndarray
        Z*, in e, as in the file (no sum rule imposed: `non_analytic` does).
    dielectric : (3, 3) ndarray
        eps_inf, dimensionless.
    factor : float or None
        The file's unit factor (e^2 / (4 pi eps0) in eV Angstrom), or None when line 1 holds none.

    Raises
    ------
    ValueError
        Not a readable text file of at most BORN_MAX_BYTES; a line that is not 9 numbers; fewer
        or more charge lines than the crystal's symmetry-independent atoms; G_cutoff or Lambda
        on line 1 (vibra uses phonopy's defaults).
    """
    from phonopy.file_IO import parse_BORN
    from phonopy.structure.symmetry import Symmetry

    source = Path(path)
    symprec = _validate.positive_scalar(symprec, "symprec")
    if not source.is_file():
        raise ValueError(f"{source}: no such file (a phonopy BORN file)")
    if source.stat().st_size > BORN_MAX_BYTES:
        raise ValueError(f"{source}: {source.stat().st_size} bytes; a BORN file holds a few lines "
                         f"(at most {BORN_MAX_BYTES} bytes read)")
    try:
        lines = source.read_text(encoding="utf-8").splitlines()
    except UnicodeDecodeError as error:
        raise ValueError(f"{source}: byte {error.start} is not UTF-8 text; a BORN file is text") from None
    first = lines[0].split() if lines else []
    if not first:
        raise ValueError(f"{source}: line 1 is empty; expected the unit factor (or a comment)")
    factor = float(first[0]) if _is_number(first[0]) else None
    if factor is not None and len(first) > 1 and _is_number(first[1]):
        raise ValueError(f"{source}: line 1 sets G_cutoff{' and Lambda' if len(first) > 2 else ''} after the "
                         "factor; vibra uses phonopy's defaults: remove them")
    if len(lines) < 2:
        raise ValueError(f"{source}: the file ends after line 1; expected eps_inf (9 numbers) on line 2")
    _numbers(source, 2, lines[1], "eps_inf")
    atoms = _phonopy_atoms(crystal)
    independent = [int(i) for i in Symmetry(atoms, symprec=symprec).get_independent_atoms()]
    for count, atom in enumerate(independent):
        number = 3 + count
        if number > len(lines) or not lines[number - 1].split():
            raise ValueError(f"{source}: line {number}: the charges end after {count} atom(s); crystal "
                             f"{crystal.name!r} has {len(independent)} symmetry-independent atoms "
                             f"({independent}), one line of 9 numbers each")
        _numbers(source, number, lines[number - 1], f"Z* of atom {atom}")
    extra = [k for k in range(2 + len(independent), len(lines)) if lines[k].split()]
    if extra:
        raise ValueError(f"{source}: line {extra[0] + 1}: more charge lines than the {len(independent)} "
                         f"symmetry-independent atoms of crystal {crystal.name!r} ({independent})")
    params = parse_BORN(atoms, symprec=symprec, filename=str(source))
    return (np.asarray(params["born"], dtype=float), np.asarray(params["dielectric"], dtype=float), factor)


class NacArguments(TypedDict):
    """`nac_from_phonopy`'s answer: the keyword arguments of `non_analytic` it fills."""

    born: NDArray[np.float64]          # (n_atoms, 3, 3) Z*, in e
    dielectric: NDArray[np.float64]    # (3, 3) eps_inf
    factor: float                      # phonopy's unit factor, in eV Angstrom
    method: str                        # "gonze" or "wang"


def nac_from_phonopy(phonon: Phonopy) -> NacArguments:
    """phonon.nac_params as `non_analytic`'s arguments: born, dielectric, factor and method.

    The charges and eps_inf are those set on phonon (phonopy averages them over the space
    group and imposes the sum rule only when it builds its dynamical matrix); the factor is
    phonopy's (eV Angstrom), the method ``"gonze"`` unless set (phonopy's default).

    Raises
    ------
    TypeError
        phonon not a phonopy.Phonopy.
    ValueError
        No nac_params; G_cutoff or Lambda set in them (vibra uses phonopy's defaults).
    """
    from phonopy import Phonopy

    if not isinstance(phonon, Phonopy):
        raise TypeError(f"phonon must be a phonopy.Phonopy, got {type(phonon).__name__}")
    params = phonon.nac_params
    if params is None:
        raise ValueError("phonon has no nac_params (set them, or load with born_filename=)")
    for key in ("G_cutoff", "Lambda"):
        if key in params:
            raise ValueError(f"phonon.nac_params sets {key!r}; vibra uses phonopy's defaults: remove it")
    if "factor" in params:
        factor = float(params["factor"])
    else:
        from phonopy.physical_units import get_physical_units
        units = get_physical_units()
        factor = float(units.Hartree * units.Bohr)
    return {"born": np.array(params["born"], dtype=float), "dielectric": np.array(params["dielectric"], dtype=float),
            "factor": factor, "method": str(params.get("method", "gonze"))}
