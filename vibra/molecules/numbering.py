"""Herzberg's numbering of a molecule's vibrations: nu1, nu2, ... by species, then by decreasing frequency.

G. Herzberg, *Molecular Spectra and Molecular Structure II: Infrared and Raman Spectra of
Polyatomic Molecules* (1945), and R. S. Mulliken, J. Chem. Phys. 23, 1997 (1955), number the
fundamentals of a molecule species by species, in the order the character table lists the
species (totally symmetric first), and within a species by decreasing frequency; a degenerate
set counts once. Shimanouchi's tables (`vibra.molecules.experimental`) use this numbering.

- The species in the order of the character table (`CharacterTable.labels`: C2v A1, A2, B1,
  B2; Td A1, A2, E, T1, T2), a kind's g and u (' and '') species together, g (') first, as
  Herzberg's tables list them: D2h Ag, Au, B1g, B1u, ...; D6h A1g, A1u, A2g, A2u, ...; D3h A1',
  A1'', A2', ...; linear molecules Sigma_g+, Sigma_u+, Pi_g, Pi_u (acetylene: nu1, nu2
  Sigma_g+, nu3 Sigma_u+, nu4 Pi_g, nu5 Pi_u).
- A linear triatomic keeps the older convention in which the bend is nu2 (CO2: nu1 Sigma_g+,
  nu2 Pi_u, nu3 Sigma_u+; HCN: nu1, nu3 Sigma+ by decreasing frequency, nu2 Pi), also when a
  1-D model lacks the bend.
- The labels B1, B2 (C2v) and B1, B2, B3 (D2h) depend on the choice of axes (`symmetry.py`'s
  standard frame); Shimanouchi puts a planar C2v molecule in the xz plane (H2O's nu3 is his
  b1, our B2), so where a molecule has both B1 and B2 species their numbers follow our labels.
- A molecule without symmetry (C1) has one species: its vibrations are numbered by decreasing
  frequency alone.

>>> herzberg_numbers(("A1", "A2", "B1", "B2"), ["A1", "A1", "B2"], [1595.0, 3657.0, 3756.0])
(2, 1, 3)
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["herzberg_numbers", "DEGENERACY_RTOL"]

#: Members of a degenerate set agree to this fraction of the largest |wavenumber| (the scene's
#: modes and the vibrational analysis that labelled them agree to 1e-4: `molecule_symmetry`).
DEGENERACY_RTOL = 1e-4

def _degeneracy(label: str) -> int:
    """Dimension of a species from its Mulliken label (E, Pi, Delta, Phi: 2; T: 3; G: 4; H: 5)."""
    if label.startswith(("Pi", "Delta", "Phi")):
        return 2
    return {"E": 2, "T": 3, "G": 4, "H": 5}.get(label[:1], 1)


def _core(label: str) -> tuple[str, int]:
    """A label without its parity to inversion or sigma_h, and that parity (0: g or ', 1: u or '')."""
    if "_g" in label or "_u" in label:
        return label.replace("_g", "").replace("_u", ""), int("_u" in label)
    if label.endswith("''"):
        return label[:-2], 1
    if label.endswith("'"):
        return label[:-1], 0
    if len(label) > 1 and label[-1] in "gu":
        return label[:-1], int(label[-1] == "u")
    return label, 0


def _species_key(label: str, order: Sequence[str]) -> tuple[int, int]:
    """Herzberg's order: the species of the table by kind (A1, A2, B1, ...), g before u and ' before ''
    within a kind (D2h: Ag, Au, B1g, B1u, ...; D3h: A1', A1'', A2', ...; D_inf_h: Sigma_g+, Sigma_u+, Pi_g, ...)."""
    cores = list(dict.fromkeys(_core(known)[0] for known in order))
    core, parity = _core(label)
    return (cores.index(core) if core in cores else len(cores)), parity


def herzberg_numbers(species_order: Sequence[str], species: Sequence[str], wavenumbers: ArrayLike, *,
                     linear: bool = False, n_atoms: int | None = None) -> tuple[int, ...]:
    """Herzberg's number of each vibration (1 for nu1), 0 for a mode without species (rigid).

    Parameters
    ----------
    species_order : sequence of str
        The species of the point group in the order of its character table
        (`PointGroup.table.labels`); ``("A",)`` for C1.
    species : (n_modes,) sequence of str
        Each mode's Mulliken label (`VibrationalAnalysis.species`, `mode_species`), ``""`` for a
        rigid-body mode.
    wavenumbers : (n_modes,) array_like
        Signed wavenumbers (any one unit; an imaginary mode negative, so numbered last).
    linear : bool
        The molecule is linear (for the triatomic convention).
    n_atoms : int, optional
        Number of atoms; a linear triatomic (3) has its bend as nu2.

    Returns
    -------
    tuple of int
        Per mode its number; the members of a degenerate set (same species, wavenumbers within
        `DEGENERACY_RTOL` of the largest, at most the species' dimension of them) share one.

    Raises
    ------
    ValueError
        `species` and `wavenumbers` differ in length.
    """
    values = np.asarray(wavenumbers, dtype=float).ravel()
    if len(species) != len(values):
        raise ValueError(f"species has {len(species)} labels but wavenumbers has {len(values)} values; "
                         "one label per mode is needed")
    tolerance = DEGENERACY_RTOL * float(np.abs(values).max(initial=0.0))
    sets: list[tuple[str, list[int]]] = []
    for label in sorted({s for s in species if s}, key=lambda s: _species_key(s, species_order)):
        members = sorted((i for i, s in enumerate(species) if s == label), key=lambda i: -values[i])
        size = _degeneracy(label)
        for i in members:
            last = sets[-1][1] if sets and sets[-1][0] == label else None
            if last is not None and len(last) < size and abs(values[i] - values[last[0]]) <= tolerance:
                last.append(i)
            else:
                sets.append((label, [i]))
    if linear and n_atoms == 3:  # the bend is nu2; the stretches nu1 and nu3
        bends = [s for s in sets if s[0].startswith("Pi")]
        stretches = [s for s in sets if not s[0].startswith("Pi")]
        numbered = list(zip((1, 3, *range(4, 4 + len(stretches))), stretches)) + [(2, s) for s in bends]
    else:
        numbered = list(enumerate(sets, start=1))
    numbers = [0] * len(values)
    for number, (_, members) in numbered:
        for i in members:
            numbers[i] = number
    return tuple(numbers)
