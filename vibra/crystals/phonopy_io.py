"""phonopy both ways: a `phonopy.Phonopy` from a crystal's force constants, and back.

phonopy keeps force constants on a supercell, Phi(p, s) from each atom p of the primitive
cell to every atom s of the supercell, and folds them into D(q) through the shortest vectors
between p and the images of s (split evenly over equidistant images: the multiplicity). Both
directions here follow that convention exactly:

- `to_phonopy`: each term (i, j, R) goes to every supercell copy of atom i and the image of j
  at L + R (mod the supercell). phonopy then gives our D(q) only if each term's vector is the
  unique shortest among its supercell images; the supercell is chosen (or checked) so, and a
  too small one is refused naming the size that is needed.
- `phonopy_terms`: each (p, s) block becomes one term per shortest vector, divided by the
  multiplicity, so that our D(q) is phonopy's.

Units: phonopy's default (VASP) units are eV/Angstrom^2, Angstrom and amu, i.e. vibra's ``ASE``
units; an ``SI`` crystal is converted on the way out (factors from scipy.constants). A crystal
from phonopy is in ``ASE`` units. Non-analytical corrections (``nac_params``) are carried by
`Crystal.from_phonopy` (`vibra.crystals.nac`).
"""

from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING, Any, Sequence, TypedDict

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import constants

from vibra.crystals.force_constants import ForceConstants, impose_sum_rules
from vibra.crystals.mesh import species_numbers

if TYPE_CHECKING:
    from phonopy import Phonopy

    from vibra.crystals.force_constants import CrystalLike as Crystal  # the protocol: no import cycle

__all__ = ["to_phonopy", "to_ase_factors", "phonopy_terms", "fold_force_constants", "SYMMETRIZE", "check_symmetrize", "symmetrized", "required_supercell", "MAX_SUPERCELL"]

#: Largest supercell edge (in cells) `to_phonopy` chooses by itself.
MAX_SUPERCELL = 12
#: The largest supercell, in atoms, `to_phonopy` builds: phonopy's full force constants take
#: 72 n^2 bytes, 1.2 GB at 4,096 atoms.
MAX_SUPERCELL_ATOMS = 4096
#: Another image must be longer than a term's own vector by this (relative) to count as farther;
#: phonopy's own test for equidistant images uses symprec = 1e-5 (in length units).
IMAGE_RTOL = 1e-4

_ELEMENT = re.compile(r"^[A-Z][a-z]?$")


def to_ase_factors(crystal: Crystal, *, dimensionless: bool = False) -> tuple[float, float, float]:
    """(length, mass, stiffness) factors from the crystal's units to phonopy's Angstrom, amu, eV/Angstrom^2.

    A dimensionless crystal is refused, or with ``dimensionless=True`` goes through as it is
    (factors 1: phonopy's arithmetic has no units).
    """
    name = crystal.units.name
    if name == "ASE" or (dimensionless and name == "dimensionless"):
        return 1.0, 1.0, 1.0
    if name == "SI":
        length = 1.0 / constants.angstrom
        stiffness = constants.angstrom ** 2 / constants.electron_volt
        return length, 1.0 / constants.atomic_mass, stiffness
    raise ValueError(f"crystal {crystal.name!r} is in {name} units; phonopy needs physical units "
                     "(build the crystal with units='SI' or 'ASE')")


def _images_unique(crystal: Crystal, size: NDArray[np.int64]) -> NDArray[np.bool_]:
    """(n_terms,) True where the term's vector is strictly the shortest of its supercell images."""
    fc = crystal.require_force_constants()
    frac = crystal.fractional
    d = fc.translations + frac[fc.second] - frac[fc.first]
    own = np.linalg.norm(d @ crystal.cell, axis=1)
    shifts = np.array([(a, b, c) for a in range(-2, 3) for b in range(-2, 3) for c in range(-2, 3)
                       if (a, b, c) != (0, 0, 0)], dtype=float)
    shifts = shifts[(shifts[:, ~np.array(crystal.periodic)] == 0).all(axis=1)]
    others = np.linalg.norm((d[:, None, :] + shifts * size) @ crystal.cell, axis=2).min(axis=1)
    return others > own * (1.0 + IMAGE_RTOL) + 1e-12


def required_supercell(crystal: Crystal, start: ArrayLike | None = None) -> NDArray[np.int64]:
    """(3,) the smallest diagonal supercell, from `start` up (periodic axes grown together), in
    which every force-constant term is its own unique shortest image."""
    size = np.ones(3, dtype=np.int64) if start is None else np.asarray(start, dtype=np.int64).copy()
    periodic = np.array(crystal.periodic)
    while not _images_unique(crystal, size).all():
        if size[periodic].max() >= MAX_SUPERCELL:
            raise ValueError(f"the force constants of {crystal.name!r} reach further than a "
                             f"{MAX_SUPERCELL}-cell supercell; give supercell= explicitly")
        size[periodic] += 1
    return size


def _check_supercell(crystal: Crystal, supercell: Any) -> NDArray[np.int64]:
    raw = np.asarray(supercell)
    if raw.shape == (3, 3):
        if np.count_nonzero(raw - np.diag(np.diag(raw))):
            raise ValueError("supercell must be diagonal here (3 integers); a general supercell matrix is not "
                             "supported by to_phonopy yet")
        raw = np.diag(raw)
    if raw.shape != (3,) or not np.issubdtype(raw.dtype, np.integer) or (raw < 1).any():
        raise ValueError(f"supercell must be 3 positive integers (cells along each lattice vector), got {supercell!r}")
    atoms = math.prod(int(n) for n in raw) * crystal.n_atoms  # Python integers: no wrap-around
    if atoms > MAX_SUPERCELL_ATOMS:
        raise ValueError(f"supercell {[int(n) for n in raw]} holds {atoms} atoms, over the limit {MAX_SUPERCELL_ATOMS} "
                         f"(phonopy's full force constants would take {72 * atoms ** 2 / 1e9:.3g} GB)")
    size = raw.astype(np.int64)
    for axis in range(3):
        if not crystal.periodic[axis] and size[axis] != 1:
            raise ValueError(f"supercell[{axis}] is {size[axis]} along a vacuum axis; it must be 1")
    if not _images_unique(crystal, size).all():
        needed = required_supercell(crystal, size)
        raise ValueError(f"supercell {size.tolist()} is too small for these force constants: some bonds would "
                         f"meet their own periodic images; it needs at least {needed.tolist()}")
    return size


def _species(crystal: Crystal) -> dict[str, Any]:
    pairs = list(zip(crystal.symbols, crystal.masses.tolist()))
    by_symbol: dict[str, set[float]] = {}
    for symbol, mass in pairs:
        by_symbol.setdefault(symbol, set()).add(mass)
    if all(_ELEMENT.match(s) for s in by_symbol) and all(len(m) == 1 for m in by_symbol.values()):
        from ase.data import chemical_symbols
        if all(s in chemical_symbols[1:] for s in by_symbol):
            return {"symbols": list(crystal.symbols)}
    return {"numbers": species_numbers(crystal)}


def to_phonopy(crystal: Crystal, *, supercell: Sequence[int] | None = None) -> Phonopy:
    """A `phonopy.Phonopy` holding this crystal's force constants (full, on a diagonal supercell).

    Parameters
    ----------
    crystal : Crystal
        With force constants, in ``SI`` or ``ASE`` units.
    supercell : 3 ints, optional
        Supercell along each lattice vector; by default the smallest in which every bond is
        its own unique shortest image (so that phonopy's D(q) is this crystal's).

    Returns
    -------
    phonopy.Phonopy
        Unit cell = primitive cell = the crystal's cell, in Angstrom / amu / eV units.

    Raises
    ------
    ValueError
        A dimensionless crystal; a supercell that is not 3 positive integers, not 1 along a
        vacuum axis, or too small for the force constants (the message names the size needed).
    """
    from phonopy import Phonopy  # at the edge: phonopy only when asked
    from phonopy.structure.atoms import PhonopyAtoms

    length, mass, stiffness = to_ase_factors(crystal)
    fc = crystal.require_force_constants()
    size = required_supercell(crystal) if supercell is None else _check_supercell(crystal, supercell)
    atoms = math.prod(int(n) for n in size) * crystal.n_atoms
    if atoms > MAX_SUPERCELL_ATOMS:  # the default supercell too (up to 12^3 cells)
        raise ValueError(f"the force constants of {crystal.name!r} need a supercell {[int(n) for n in size]} of {atoms} "
                         f"atoms, over the limit {MAX_SUPERCELL_ATOMS} (phonopy's full force constants would take "
                         f"{72 * atoms ** 2 / 1e9:.3g} GB)")
    cell = PhonopyAtoms(cell=crystal.cell * length, scaled_positions=crystal.fractional,
                        masses=crystal.masses * mass, **_species(crystal))
    phonon = Phonopy(cell, supercell_matrix=np.diag(size), primitive_matrix="P", log_level=0)
    sc = phonon.supercell
    unit_index = np.array([sc.u2u_map[s] for s in sc.s2u_map], dtype=np.intp)
    lattice_point = np.rint(sc.scaled_positions * size - crystal.fractional[unit_index]).astype(np.int64) % size
    lookup = np.empty((crystal.n_atoms, *size), dtype=np.intp)
    lookup[unit_index, lattice_point[:, 0], lattice_point[:, 1], lattice_point[:, 2]] = np.arange(len(sc))
    n_super = len(sc)
    full = np.zeros((n_super, n_super, 3, 3))
    points = np.stack(np.meshgrid(*[np.arange(s) for s in size], indexing="ij"), axis=-1).reshape(-1, 3)
    source = lookup[fc.first[:, None], points[None, :, 0], points[None, :, 1], points[None, :, 2]]
    target_point = (points[None, :, :] + fc.translations[:, None, :]) % size
    target = lookup[fc.second[:, None], target_point[..., 0], target_point[..., 1], target_point[..., 2]]
    np.add.at(full, (source.ravel(), target.ravel()),
              np.repeat(fc.blocks * stiffness, len(points), axis=0))
    phonon.force_constants = full
    return phonon


#: The ways `symmetrize=` imposes the sum rules on force constants (`symmetrized`).
SYMMETRIZE: tuple[str, ...] = ("phonopy", "projection")


def check_symmetrize(symmetrize: bool | str | None) -> str | None:
    """The symmetrisation asked: None (none), "phonopy" or "projection" (True)."""
    if symmetrize is None or symmetrize is False:
        return None
    if symmetrize is True:
        return "projection"
    if isinstance(symmetrize, str) and symmetrize in SYMMETRIZE:
        return symmetrize
    raise ValueError(f"symmetrize is {symmetrize!r}; expected False (force constants as they are), 'phonopy' "
                     "(phonopy's symmetrize_force_constants: translational sum rule, then index symmetry, as "
                     "phonopy.load does) or True / 'projection' (both rules exactly, vibra's impose_sum_rules)")


def symmetrized(phonon: Phonopy, fc: NDArray[np.float64], how: str | None) -> NDArray[np.float64]:
    """Supercell force constants `fc` of `phonon` with the sum rules imposed `how` (a new array; `phonon` untouched).

    ``"phonopy"``: phonopy's own ``symmetrize_force_constants`` (or its compact form), level 1:
    the translational sum rule, then the index symmetry, as ``phonopy.load(symmetrize_fc=True)``
    applies to force constants made from forces (the index symmetry then holds exactly, the sum
    rule nearly). ``"projection"``: `impose_sum_rules`, both rules to 1e-14 (full supercell form).
    """
    if how is None:
        return fc
    if how == "phonopy":
        from phonopy.harmonic.force_constants import (symmetrize_compact_force_constants,
                                                      symmetrize_force_constants)
        copy = np.array(fc, dtype="double", order="C")
        if copy.shape[0] == copy.shape[1]:
            symmetrize_force_constants(copy)
        else:
            symmetrize_compact_force_constants(copy, phonon.primitive)
        return copy
    if fc.shape[0] != fc.shape[1]:
        from phonopy.harmonic.force_constants import compact_fc_to_full_fc
        fc = np.asarray(compact_fc_to_full_fc(phonon.primitive, fc), dtype=float)
    projected, _ = impose_sum_rules(fc)
    return projected


class PhonopyTerms(TypedDict):
    """What `phonopy_terms` reads from a `phonopy.Phonopy`, in ASE units (eV, Angstrom, amu)."""

    cell: NDArray[np.float64]             # (3, 3) primitive cell, rows the lattice vectors
    fractional: NDArray[np.float64]       # (n_atoms, 3) fractional positions, wrapped into [0, 1)
    masses: NDArray[np.float64]           # (n_atoms,)
    symbols: tuple[str, ...]
    force_constants: ForceConstants


def phonopy_terms(phonon: Phonopy, *, symmetrize: bool | str | None = False) -> PhonopyTerms:
    """The primitive cell and force-constant terms of a `phonopy.Phonopy`, in ASE units.

    With ``symmetrize="phonopy"`` phonopy's own symmetrisation is applied first (as
    ``phonopy.load(symmetrize_fc=True)``), with ``symmetrize=True`` (or ``"projection"``) the
    acoustic sum rule and the index symmetry are imposed exactly
    (`vibra.crystals.force_constants.impose_sum_rules`, on the full supercell force constants;
    phonopy's compact form is expanded by ``compact_fc_to_full_fc``): see `symmetrized`. The
    phonopy object is not changed. Returns a dict with ``cell``, ``fractional`` (wrapped into [0, 1)), ``masses``, ``symbols``
    and ``force_constants`` (`ForceConstants`), for `Crystal.from_phonopy`.

    Raises
    ------
    TypeError
        `phonon` is not a phonopy.Phonopy.
    ValueError
        No force constants; units other than phonopy's default. (Non-analytical correction
        parameters are read by `Crystal.from_phonopy`, not here.)
    """
    from phonopy import Phonopy

    if not isinstance(phonon, Phonopy):
        raise TypeError(f"phonon must be a phonopy.Phonopy, got {type(phonon).__name__}")
    if phonon.force_constants is None:
        raise ValueError("phonon has no force constants; produce them first (phonon.produce_force_constants() "
                         "after setting forces, or phonon.force_constants = ...)")
    if phonon.calculator not in (None, "vasp"):
        raise ValueError(f"phonon uses the {phonon.calculator!r} calculator's units; vibra reads phonopy's "
                         "default units (eV/Angstrom^2, Angstrom, amu)")
    primitive = phonon.primitive
    fc = symmetrized(phonon, np.asarray(phonon.force_constants, dtype=float), check_symmetrize(symmetrize))
    frac = np.asarray(primitive.scaled_positions, dtype=float)
    frac = frac - np.floor(frac + 1e-12)
    terms = fold_force_constants(phonon, fc)
    return {"cell": np.asarray(primitive.cell, dtype=float), "fractional": frac,
            "masses": np.asarray(primitive.masses, dtype=float), "symbols": tuple(primitive.symbols),
            "force_constants": terms}


def fold_force_constants(phonon: Phonopy, force_constants: ArrayLike) -> ForceConstants:
    """phonopy's supercell force constants as vibra's terms Phi(i 0; j R), in phonopy's units.

    `force_constants` are full (n_s, n_s, 3, 3) or compact (n_p, n_s, 3, 3) on ``phonon``'s
    supercell (its own, or another set on the same supercell, such as the short-range part of a
    Gonze-Lee correction). Each (p, s) block becomes one term per shortest vector between p and
    the images of s, divided by their number (phonopy's multiplicity), so that the D(q) of the
    terms is phonopy's; primitive positions are wrapped into [0, 1) and the translations follow.
    Blocks that are exactly zero are dropped.
    """
    primitive = phonon.primitive
    fc = np.asarray(force_constants, dtype=float)
    p2s = np.asarray(primitive.p2s_map)
    s2p = np.asarray(primitive.s2p_map)
    p2p = primitive.p2p_map
    svecs, multi = primitive.get_smallest_vectors()
    n_p = len(p2s)
    n_s = fc.shape[1]
    rows = fc if fc.shape[0] == n_p else fc[p2s]
    frac = np.asarray(primitive.scaled_positions, dtype=float)
    shift = np.floor(frac + 1e-12)
    frac = frac - shift
    k, i = np.meshgrid(np.arange(n_s), np.arange(n_p), indexing="ij")
    k, i = k.ravel(), i.ravel()
    count = multi[k, i, 0]
    start = multi[k, i, 1]
    j = np.array([p2p[s] for s in s2p])[k]
    term = np.repeat(np.arange(len(k)), count)
    offset = np.arange(term.size) - np.repeat(np.cumsum(count) - count, count)
    vectors = np.asarray(svecs)[start[term] + offset]
    first, second = i[term], j[term]
    translations = np.rint(vectors - (frac[second] + shift[second] - frac[first] - shift[first]))
    translations = translations + shift[second] - shift[first]
    blocks = rows[first, k[term]] / count[term][:, None, None]
    keep = np.abs(blocks).max(axis=(1, 2)) > 0.0
    return ForceConstants(first=first[keep].astype(np.intp), second=second[keep].astype(np.intp),
                          translations=translations[keep].astype(np.int64), blocks=blocks[keep])
