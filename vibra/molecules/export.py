"""Molecules out to the tools chemists use: ASE `VibrationsData`, Molden normal-mode files,
trajectories animating a mode, phonopy force constants.

Chemical symbols: a `System` holds masses, not elements. The writers take ``symbols=``; without
it they use ``system.symbols`` when the `System` has that field, else each mass is named by the
isotope table (`ISOTOPE_MASSES`: 2.0141 amu is H, 17.9992 amu is O) or, failing that, by the
element of nearest standard atomic mass (`symbols_from_masses`).

Every file is written with `vibra._core.filesystem.atomic_write` (a temporary file in the same folder, then
`os.replace`), so a reader never sees half a file, and under its one rule (`vibra._core.filesystem.check_target`):
the path must be a regular file (replaced) or a new name; a folder, device, FIFO, socket or
symbolic link, or an input of the run (`vibra._core.filesystem.protected_inputs`), is refused with
`vibra._core.filesystem.TargetRefused` (an `OSError`) before anything is written.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import constants

from vibra._core import validate as _validate
from vibra._core.filesystem import atomic_write
from vibra.modes import Modes
from vibra.molecules.analysis import VibrationalAnalysis
from vibra._core.elements import symbols_from_masses
from vibra.molecules.isotopes import ISOTOPE_MASSES
from vibra.system import System, Vibrating

if TYPE_CHECKING:
    from ase import Atoms
    from ase.vibrations import VibrationsData

__all__ = ["BOHR_ANGSTROM", "MOLDEN_ZERO_RTOL", "system_atoms", "to_vibrations_data", "write_molden",
           "write_mode_trajectory", "write_force_constants"]

#: The bohr radius in Angstrom (CODATA 2018, scipy.constants): Molden coordinates are in bohr.
BOHR_ANGSTROM = constants.physical_constants["Bohr radius"][0] / constants.angstrom

#: With `Modes` (not a `VibrationalAnalysis`), modes with |omega| <= MOLDEN_ZERO_RTOL * max|omega|
#: count as rigid-body motions and are not written (the default of `vibra.spectra`).
MOLDEN_ZERO_RTOL = 1e-4

#: A mass within this many amu of a table isotope is named by that isotope's element.
_ISOTOPE_MATCH_AMU = 1e-6


def _molecular(system: Any, name: str = "system") -> System:
    if not isinstance(system, Vibrating):
        raise TypeError(f"{name} must be a vibra System, got {type(system).__name__}")
    if system.is_generalized:
        raise TypeError(f"{name} is in generalised coordinates; export needs a molecule (3-D sites)")
    if system.units.name != "ASE":
        raise ValueError(f"{name}.units is {system.units.name!r}; export needs a molecule in units 'ASE' "
                         "(amu, Angstrom, eV)")
    if system.dim != 3:
        raise ValueError(f"{name} has {system.dim}-D sites; export needs a molecule in 3-D")
    return system


def _symbols(system: System, symbols: Sequence[str] | None) -> tuple[str, ...]:
    from ase.data import atomic_numbers

    if symbols is None:
        symbols = system.symbols
    if symbols is None:
        masses = np.asarray(system.masses)
        nearest = symbols_from_masses(masses)
        table = {label: mass for label, mass in ISOTOPE_MASSES.items() if label[0].isdigit()}
        names = []
        for mass, guess in zip(masses, nearest):
            label = next((key for key, value in table.items() if abs(value - mass) <= _ISOTOPE_MATCH_AMU), None)
            names.append(guess if label is None else label.lstrip("0123456789"))
        return tuple(names)
    if isinstance(symbols, str) or len(symbols) != system.n_sites:
        raise ValueError(f"symbols must name {system.n_sites} atoms (one str per site), got {symbols!r}")
    for i, symbol in enumerate(symbols):
        if not isinstance(symbol, str) or atomic_numbers.get(symbol, 0) == 0:
            raise ValueError(f"symbols[{i}] is {symbol!r}; expected a chemical symbol such as 'H', 'C' or 'O'")
    return tuple(symbols)


def system_atoms(system: System, *, symbols: Sequence[str] | None = None) -> Atoms:
    """The molecule as ASE `Atoms`: positions (Angstrom) and masses (amu) of `system`.

    Parameters
    ----------
    system : System
        A molecule: 3-D sites in ASE units.
    symbols : sequence of str, optional
        Chemical symbols (see the module docstring for the default).

    Examples
    --------
    >>> from vibra.molecules import h2o
    >>> atoms = system_atoms(h2o(isotopes=[None, "D", "D"]))
    >>> atoms.get_chemical_symbols(), atoms.get_masses().round(3).tolist()
    (['O', 'H', 'H'], [15.999, 2.014, 2.014])
    """
    from ase import Atoms as _Atoms

    system = _molecular(system)
    return _Atoms(symbols=list(_symbols(system, symbols)), positions=np.asarray(system.positions),
                  masses=np.asarray(system.masses))


def _free_sites(system: System) -> NDArray[np.intp]:
    frozen = np.asarray(system.frozen).reshape(system.n_sites, 3)
    partial = frozen.any(axis=1) & ~frozen.all(axis=1)
    if partial.any():
        i = int(np.argmax(partial))
        raise ValueError(f"site {i} has some but not all of its degrees of freedom frozen; export "
                         "needs whole atoms free or frozen")
    return np.flatnonzero(~frozen.all(axis=1))


def _modes_of(system: System, modes: Any, name: str) -> tuple[Modes, NDArray[np.bool_] | None]:
    rigid = None
    if isinstance(modes, VibrationalAnalysis):
        modes, rigid = modes.modes, np.asarray(modes.rigid)
    if not isinstance(modes, Modes):
        raise TypeError(f"{name} must be a vibra Modes or a VibrationalAnalysis, got {type(modes).__name__}")
    if modes.shapes is None:
        raise ValueError(f"{name} has no shapes (computed with vectors=False)")
    if modes.n_dof != system.n_dof:
        raise ValueError(f"{name} has {modes.n_dof} degrees of freedom but the system has {system.n_dof}; "
                         "pass the modes of this system")
    return modes, rigid


def to_vibrations_data(system: System, modes_or_analysis: Modes | VibrationalAnalysis | None = None, *,
                       symbols: Sequence[str] | None = None) -> VibrationsData:
    """ASE `VibrationsData` of a molecule (its Hessian, atoms and masses).

    Without modes the Hessian is ``system.hessian()``, so `from_vibrations_data` gives back the
    same K, positions and masses. With a complete set of modes (all n_dof of them, e.g. a
    `VibrationalAnalysis`, whose rigid-body modes are exactly zero) the Hessian is rebuilt from
    them, K = M^1/2 D diag(omega |omega|) D^T M^1/2: ASE then reports exactly the analysis'
    frequencies, translations and rotations at zero. Frozen atoms are left out of the data's
    ``indices``.

    Parameters
    ----------
    system : System
        A molecule: 3-D sites in ASE units.
    modes_or_analysis : Modes or VibrationalAnalysis, optional
        All n_dof modes of `system`.
    symbols : sequence of str, optional
        Chemical symbols (see the module docstring for the default).

    Raises
    ------
    TypeError
        Not a System of sites, or modes of the wrong kind.
    ValueError
        Not a 3-D molecule in ASE units; modes of another system or not all of them; an atom
        partly frozen.

    Examples
    --------
    >>> from vibra.molecules import co2, from_vibrations_data
    >>> data = to_vibrations_data(co2())
    >>> data.get_atoms().get_chemical_symbols()
    ['O', 'C', 'O']
    >>> bool(abs(from_vibrations_data(data).hessian() - co2().hessian()).max() == 0.0)
    True
    """
    from ase.vibrations import VibrationsData as _VibrationsData

    system = _molecular(system)
    atoms = system_atoms(system, symbols=symbols)
    indices = _free_sites(system)
    if modes_or_analysis is None:
        hessian = system.hessian().toarray()
    else:
        modes, _ = _modes_of(system, modes_or_analysis, "modes_or_analysis")
        if modes.n_modes != system.n_dof:
            raise ValueError(f"modes_or_analysis holds {modes.n_modes} of the {system.n_dof} modes; the Hessian "
                             "is rebuilt only from all of them")
        root = np.sqrt(system.mass_matrix())
        d = np.asarray(modes.vectors)
        omega = np.asarray(modes.omega)
        hessian = root[:, None] * ((d * (omega * np.abs(omega))) @ d.T) * root[None, :]
        hessian = (hessian + hessian.T) / 2.0
    return _VibrationsData.from_2d(atoms, hessian, indices=indices.tolist())


def _written_modes(system: System, modes: Modes, rigid: NDArray[np.bool_] | None) -> NDArray[np.intp]:
    if rigid is not None:
        return np.flatnonzero(~rigid)
    return np.flatnonzero(~modes.zero_modes(MOLDEN_ZERO_RTOL))


def write_molden(path: str | os.PathLike[str], system: System,
                 analysis_or_modes: VibrationalAnalysis | Modes, *,
                 symbols: Sequence[str] | None = None, intensities: ArrayLike | None = None) -> Path:
    """Write the vibrations of a molecule as a Molden normal-mode file (Avogadro, Jmol, Molden).

    Sections, as the Molden format defines them (www.theochem.ru.nl/molden/molden_format.html):
    ``[Molden Format]``; ``[FREQ]`` one wavenumber per vibration in cm^-1, ascending, an
    imaginary one as a negative number; ``[INT]`` (optional in the format) one IR intensity per
    vibration, only when `intensities` is given (vibra.molecules computes none: pass
    ``vibra.spectra.ir_spectrum(system, analysis, ...).intensities_km_per_mol()``), placed
    after ``[FREQ]`` as Open Babel's reader requires; ``[FR-COORD]`` one line
    ``symbol x y z`` per atom in bohr; ``[FR-NORM-COORD]`` a line ``vibration k`` (k from 1)
    then one ``dx dy dz`` line per atom: the Cartesian displacement M^-1/2 d_k scaled to unit
    length (dimensionless).

    Rigid-body modes are not written: those the analysis matched to translations and
    rotations, or with plain `Modes` those with |omega| <= `MOLDEN_ZERO_RTOL` max|omega|.

    Parameters
    ----------
    path : path-like
        File to create or replace (``.molden`` by convention); its folder is created.
    system : System
        A molecule: 3-D sites in ASE units (no frozen atoms).
    analysis_or_modes : VibrationalAnalysis or Modes
        The modes of `system`.
    symbols : sequence of str, optional
        Chemical symbols (see the module docstring for the default).
    intensities : (n_vibrations,) array_like, optional
        IR intensities of the written vibrations, in km/mol (>= 0).

    Returns
    -------
    Path
        `path`.

    Raises
    ------
    TypeError
        Not a System of sites, or modes of the wrong kind.
    ValueError
        Not a 3-D molecule in ASE units; frozen atoms; modes of another system; intensities
        not one per written vibration or negative.
    OSError
        `path` cannot be written (e.g. a file stands where its folder should be);
        `vibra._core.filesystem.TargetRefused` where it is not a regular file or a new name, or an input.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from vibra.molecules import h2o, vibrational_analysis
    >>> water = h2o()
    >>> path = write_molden(pathlib.Path(tempfile.mkdtemp()) / "h2o.molden", water, vibrational_analysis(water))
    >>> lines = path.read_text().splitlines()
    >>> lines[:2], round(float(lines[2])), lines[5]
    (['[Molden Format]', '[FREQ]'], 1595, '[FR-COORD]')
    """
    system = _molecular(system)
    if system.frozen.any():
        raise ValueError("system has frozen degrees of freedom; a Molden file describes free molecules")
    names = _symbols(system, symbols)
    modes, rigid = _modes_of(system, analysis_or_modes, "analysis_or_modes")
    columns = _written_modes(system, modes, rigid)
    if intensities is not None:
        values = _validate.real_array(intensities, "intensities", ndim=1)
        if values.shape[0] != len(columns):
            raise ValueError(f"intensities must give {len(columns)} values (one per written vibration), "
                             f"got {values.shape[0]}")
        _validate.nonnegative(values, "intensities", "intensity")
    wavenumbers = modes.wavenumbers_cm1()[columns]
    shapes = np.asarray(modes.shapes)[:, columns].T.reshape(len(columns), system.n_sites, 3)
    norms = np.sqrt(np.sum(shapes**2, axis=(1, 2)))
    lines = ["[Molden Format]", "[FREQ]"]
    lines += [f"{w:14.6f}" for w in wavenumbers]
    if intensities is not None:   # right after [FREQ], where Open Babel's reader (Avogadro 1) expects it
        lines.append("[INT]")
        lines += [f"{value:16.8f}" for value in values]
    lines.append("[FR-COORD]")
    bohr = np.asarray(system.positions) / BOHR_ANGSTROM
    lines += [f"{symbol:<2} {x:18.10f} {y:18.10f} {z:18.10f}" for symbol, (x, y, z) in zip(names, bohr)]
    lines.append("[FR-NORM-COORD]")
    for k, (shape, norm) in enumerate(zip(shapes, norms), start=1):
        lines.append(f"vibration {k:d}")
        lines += [f"{x:14.10f} {y:14.10f} {z:14.10f}" for x, y, z in shape / norm]
    text = "\n".join(lines) + "\n"
    return atomic_write(path, lambda temporary: temporary.write_text(text, encoding="ascii"))


def write_mode_trajectory(path: str | os.PathLike[str], system: System,
                          modes: VibrationalAnalysis | Modes, index: int, *, n_frames: int = 20,
                          amplitude: float = 0.3, symbols: Sequence[str] | None = None) -> Path:
    """Write one period of a mode's motion as an ASE trajectory (``.traj``) or extended XYZ.

    Frame f (0 <= f < n_frames) has positions x0 + amplitude sin(2 pi f / n_frames) u / max_i |u_i|,
    with u the Cartesian shape of the mode: the atom that moves most swings by `amplitude`
    Angstrom. Each frame's ``info`` holds ``mode_index`` and ``wavenumber_cm1``.

    Parameters
    ----------
    path : path-like
        ``*.traj`` (ASE trajectory) or ``*.xyz`` / ``*.extxyz`` (extended XYZ); folder created.
    system : System
        A molecule: 3-D sites in ASE units.
    modes : VibrationalAnalysis or Modes
        The modes of `system`.
    index : int
        With a `VibrationalAnalysis`, the vibration (0 = the lowest, rigid-body modes not
        counted); with `Modes`, the mode column.
    n_frames : int
        Frames per period (2 to 10000).
    amplitude : float
        Largest atomic displacement, in Angstrom (> 0).
    symbols : sequence of str, optional
        Chemical symbols (see the module docstring for the default).

    Raises
    ------
    TypeError
        Wrong kinds of objects; `index` not an int.
    ValueError
        Not a 3-D molecule in ASE units; `index` out of range (the range is given); an unknown
        suffix; `n_frames` or `amplitude` out of range.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from ase.io import read
    >>> from vibra.molecules import co2, vibrational_analysis
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "bend.xyz"
    >>> _ = write_mode_trajectory(path, co2(), vibrational_analysis(co2()), 0, n_frames=8)
    >>> len(read(path, ":"))
    8
    """
    from ase.io import write as _write

    system = _molecular(system)
    analysis = modes if isinstance(modes, VibrationalAnalysis) else None
    all_modes, _ = _modes_of(system, modes, "modes")
    if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
        raise TypeError(f"index must be an int, got {type(index).__name__}")
    columns = analysis.vibrations if analysis is not None else np.arange(all_modes.n_modes)
    what = "vibrations" if analysis is not None else "modes"
    if not 0 <= index < len(columns):
        raise ValueError(f"index is {index}; the {len(columns)} {what} are numbered 0 to {len(columns) - 1}")
    suffix = Path(path).suffix.lower()
    formats = {".traj": "traj", ".xyz": "extxyz", ".extxyz": "extxyz"}
    if suffix not in formats:
        raise ValueError(f"path ends in {suffix!r}; expected .traj (ASE trajectory), .xyz or .extxyz")
    frames = _validate.count(n_frames, "n_frames", low=2, high=10000)
    size = _validate.positive_scalar(amplitude, "amplitude", "displacement (Angstrom)")
    column = int(columns[index])
    shape = system.expand(np.asarray(all_modes.shapes)[:, column]).reshape(system.n_sites, 3)
    largest = float(np.linalg.norm(shape, axis=1).max())
    if largest == 0.0:
        raise ValueError(f"mode {column} does not move any atom")
    base = system_atoms(system, symbols=symbols)
    wavenumber = float(all_modes.wavenumbers_cm1()[column])
    images = []
    for f in range(frames):
        image = base.copy()
        image.set_positions(base.get_positions() + size * np.sin(2 * np.pi * f / frames) * shape / largest)
        image.info.update(mode_index=column, wavenumber_cm1=wavenumber)
        images.append(image)
    return atomic_write(path, lambda temporary: _write(temporary, images, format=formats[suffix]),
                         suffix=suffix)


def write_force_constants(path: str | os.PathLike[str], system: System) -> Path:
    """Write the Hessian as phonopy force constants (``FORCE_CONSTANTS`` format, eV/Angstrom^2).

    fc[i, j, a, b] = K[3 i + a, 3 j + b], written by phonopy's own
    ``phonopy.file_IO.write_FORCE_CONSTANTS`` (full n_atoms x n_atoms form), readable with
    ``phonopy.file_IO.parse_FORCE_CONSTANTS`` or as the FORCE_CONSTANTS of a 1x1x1 supercell.

    Raises
    ------
    TypeError, ValueError
        Not a 3-D molecule in ASE units, or frozen degrees of freedom.
    OSError
        `path` cannot be written.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from phonopy.file_IO import parse_FORCE_CONSTANTS
    >>> from vibra.molecules import co2
    >>> path = write_force_constants(pathlib.Path(tempfile.mkdtemp()) / "FORCE_CONSTANTS", co2())
    >>> parse_FORCE_CONSTANTS(str(path)).shape
    (3, 3, 3, 3)
    """
    from phonopy.file_IO import write_FORCE_CONSTANTS

    system = _molecular(system)
    if system.frozen.any():
        raise ValueError("system has frozen degrees of freedom; force constants need every atom free")
    n = system.n_sites
    fc = system.hessian().toarray().reshape(n, 3, n, 3).transpose(0, 2, 1, 3).copy()
    return atomic_write(path, lambda temporary: write_FORCE_CONSTANTS(fc, filename=str(temporary)))
