"""phonopy's files both ways: ``phonopy.yaml`` and ``FORCE_CONSTANTS``, through phonopy's own code.

- `write_phonopy` (``phonopy.yaml``, with or without the force constants) and
  `write_force_constants` (``FORCE_CONSTANTS``): phonopy's text (``Phonopy.to_phonopy_yaml``,
  ``phonopy.file_IO.get_FORCE_CONSTANTS_lines``) on the `to_phonopy` object, written atomically
  by `vibra._io`;
- `read_phonopy`: ``phonopy.load`` reads any phonopy yaml (and a ``FORCE_CONSTANTS`` file), then
  `Crystal.from_phonopy`, optionally with the sum rules imposed (`impose_sum_rules`).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from vibra._io import atomic_write_text
from vibra.crystals.crystal import Crystal
from vibra.crystals.phonopy_io import to_phonopy

__all__ = ["read_phonopy", "write_phonopy", "write_force_constants"]


def write_phonopy(crystal: Crystal, path: str | os.PathLike[str], *, force_constants: bool = True,
                  supercell: Sequence[int] | None = None) -> Path:
    """Write a crystal as ``phonopy.yaml``; with ``force_constants=True`` (default) the force constants too.

    phonopy's own writer builds the text (``Phonopy.to_phonopy_yaml``: the unit cell, the
    supercell and primitive matrices and, when asked, the full supercell force constants);
    vibra writes it atomically (`vibra._io`). ``phonopy.load(path)`` reads it back.

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


def read_phonopy(path: str | os.PathLike[str], *, force_constants: str | os.PathLike[str] | None = None,
                 symmetrize: bool = False, name: str | None = None) -> Any:
    """A `Crystal` from a ``phonopy.yaml`` (and a ``FORCE_CONSTANTS`` file), read by ``phonopy.load``.

    Parameters
    ----------
    path : path-like
        ``phonopy.yaml`` / ``phonopy_disp.yaml`` / ``phonopy_params.yaml``: the structure, the
        supercell and primitive matrices, and force constants or forces if it holds them.
    force_constants : path-like, optional
        A ``FORCE_CONSTANTS`` (text) or ``force_constants.hdf5`` file for that supercell;
        otherwise the force constants come from the yaml file (stored, or produced by phonopy
        from its displacements and forces).
    symmetrize : bool
        Impose the acoustic sum rule and the index symmetry (`impose_sum_rules`, vibra's own
        projection) before use. Off by default: the force constants are taken as they are.
    name : str, optional
        The crystal's name (default: the file's stem).

    Returns
    -------
    Crystal
        phonopy's primitive cell with its force constants, ASE units (see `from_phonopy`).

    Raises
    ------
    ValueError
        A file that is missing or that phonopy cannot read (the message names it), or that
        yields no force constants; the checks of `phonopy_terms`.
    """
    import phonopy

    source = Path(path)
    if not source.is_file():
        raise ValueError(f"{source}: no such phonopy yaml file")
    extra: dict[str, Any] = {}
    if force_constants is not None:
        fc_path = Path(force_constants)
        if not fc_path.is_file():
            raise ValueError(f"force_constants: {fc_path}: no such file")
        extra["force_constants_filename"] = str(fc_path)
    try:
        phonon = phonopy.load(str(source), is_compact_fc=False, symmetrize_fc=False, produce_fc=True,
                              log_level=0, **extra)
    except Exception as error:  # phonopy raises many kinds for a malformed file
        raise ValueError(f"{source}: phonopy could not read it ({type(error).__name__}: {error})") from None
    return Crystal.from_phonopy(phonon, name=name if name is not None else source.stem, symmetrize=symmetrize)
