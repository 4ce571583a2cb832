"""Typed force constants of the default valence force field: one small table, by element pair
and bond order (stretches), bend centre (bends), torsion axis (torsions) and planar centre
(out-of-plane terms), in eV/Angstrom^2 and eV/rad^2 (1 mdyn/Angstrom = 6.2415 eV/Angstrom^2,
1 mdyn Angstrom/rad^2 = 6.2415 eV/rad^2).

Where the numbers come from
---------------------------
The forms are the textbook ones of a simple (diagonal) valence force field: one constant per
internal coordinate, no interaction constants (E. B. Wilson, J. C. Decius and P. C. Cross,
*Molecular Vibrations*, McGraw-Hill 1955). Stretch constants grow as the bond shortens, as a
power law k ~ r^-6 in the spirit of Badger's rule (R. M. Badger, J. Chem. Phys. 2, 128 (1934));
bond orders follow from lengths by a Pauling-type bond-number rule r(n) = r(1) - 0.3 ln n
Angstrom (the 0.3 Angstrom chosen here). Torsion constants belong to the bond (axis) and are
shared by its dihedrals, as in DREIDING (S. L. Mayo, B. D. Olafson and W. A. Goddard III,
J. Phys. Chem. 94, 8897 (1990)).

The values are **fitted here**, not copied from a published force field: least squares on
log(frequency) against the gas-phase fundamentals of T. Shimanouchi, *Tables of Molecular
Vibrational Frequencies, Consolidated Volume I*, NSRDS-NBS 39 (1972), for 26 small molecules
of ASE's g2 collection, one or more prototypes per entry (CH4 for C-H, H2O for O-H, C2H6,
C6H6, C2H4 and C2H2 for the four C-C orders, CH3NH2 and HCN for C-N, CH3OH and H2CO for C-O,
CH3CHO for a methyl next to a double bond, ...: `FIT_SET`), computed vibrations paired with
observed ones by the assignment of least total |log ratio| (sorted order when the lists are
complete), with a weak pull of the stretch constants and Badger's exponent towards the usual
textbook values (C-H 4.9, O-H 7.7, C-C 4.5, C=C 9.5, C#C 15.7, C=O 12.3 mdyn/Angstrom, ...),
which keeps them chemical where a diagonal force field could trade a stretch for a bend.
Reference lengths are those of the prototype in ASE's g2 collection (MP2(full)/6-31G(d)
geometries), the geometries `vibra.molecules.molecule` uses. docs/molecules.md gives the
errors on the fit set and on 27 g2 molecules held out of the fit
(tests/molecules/test_experiment.py).

Kinds of atoms and pairs the table does not list get generic values: a stretch of
`GENERIC_STRETCH` at the sum of the covalent radii (Badger's rule around it), the bends,
linear bends and out-of-plane constant of carbon. They give every molecule a stable, complete
force field, not a calibrated one.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from numpy.typing import NDArray

__all__ = ["STRETCH", "BADGER_EXPONENT", "PAULING_LENGTH", "SAME_LENGTH", "GENERIC_STRETCH", "BEND", "GENERIC_BEND",
           "LINEAR_BEND", "GENERIC_LINEAR_BEND", "TORSION", "SATURATED_TORSION", "VALENCE", "OUT_OF_PLANE",
           "FIT_SET", "stretch_constants", "bend_constants", "linear_bend_constants", "torsion_constants",
           "out_of_plane_constants"]

#: The molecules of ASE's g2 collection whose observed fundamentals the constants were fitted to.
FIT_SET = ("CH4", "H2O", "NH3", "SH2", "PH3", "SiH4", "C2H6", "C2H4", "C2H2", "C6H6", "H3CNH2", "HCN",
           "CH3OH", "H2CO", "CO2", "CS2", "N2O", "SO2", "CF4", "CH3Cl", "NF3", "PF3", "SiF4", "SiCl4", "F2O",
           "CH3CHO")

#: (element, element) in alphabetical order -> ((bond order, reference length in Angstrom,
#: stretch constant in eV/Angstrom^2), ...) by increasing order; the prototype in the comment.
STRETCH: dict[tuple[str, str], tuple[tuple[float, float, float], ...]] = {
    ("C", "H"): ((1.0, 1.0897, 30.5),),                                        # CH4
    ("H", "O"): ((1.0, 0.9686, 47.9),),                                        # H2O
    ("H", "N"): ((1.0, 1.0168, 40.0),),                                        # NH3
    ("H", "S"): ((1.0, 1.3395, 24.9),),                                        # H2S
    ("H", "P"): ((1.0, 1.4144, 19.5),),                                        # PH3
    ("H", "Si"): ((1.0, 1.4829, 17.3),),                                       # SiH4
    ("C", "C"): ((1.0, 1.5244, 28.4), (1.5, 1.3952, 38.9), (2.0, 1.3350, 56.3),  # C2H6, C6H6, C2H4,
                 (3.0, 1.2162, 98.1)),                                         # C2H2
    ("C", "N"): ((1.0, 1.4640, 30.7), (3.0, 1.1762, 112.0)),                   # CH3NH2, HCN
    ("C", "O"): ((1.0, 1.4229, 32.3), (2.0, 1.2201, 76.8)),                    # CH3OH, H2CO
    ("C", "F"): ((1.0, 1.3292, 37.1),),                                        # CF4
    ("C", "Cl"): ((1.0, 1.7773, 21.2),),                                       # CH3Cl
    ("C", "S"): ((2.0, 1.5611, 47.1),),                                        # CS2
    ("N", "N"): ((2.0, 1.1711, 109.0),),                                       # N2O
    ("N", "O"): ((2.0, 1.1921, 70.8),),                                        # N2O
    ("O", "S"): ((2.0, 1.4767, 62.0),),                                        # SO2
    ("F", "N"): ((1.0, 1.3833, 25.7),),                                        # NF3
    ("F", "O"): ((1.0, 1.4230, 24.5),),                                        # F2O
    ("F", "P"): ((1.0, 1.5926, 33.1),),                                        # PF3
    ("F", "Si"): ((1.0, 1.5810, 41.7),),                                       # SiF4
    ("Cl", "Si"): ((1.0, 2.0254, 18.8),),                                      # SiCl4
}
#: Badger's rule: beyond a pair's tabulated lengths k = k_ref (r_ref / r)^BADGER_EXPONENT.
BADGER_EXPONENT = 6.07
#: Pauling's rule r(n) = r(1) - PAULING_LENGTH ln n (Angstrom) gives the bond order beyond a
#: pair's tabulated lengths (clipped to 1..3).
PAULING_LENGTH = 0.3
#: Bonds of one pair whose lengths agree within this many Angstrom share one constant.
SAME_LENGTH = 1e-3
#: A pair missing from `STRETCH`: this constant (eV/Angstrom^2) at the sum of the covalent radii.
GENERIC_STRETCH = 30.0

#: (centre element, its number of bonds, hydrogens among the two outer atoms) -> bend
#: constant, eV/rad^2. The number of bonds matters: the three angles of a planar centre are
#: redundant (they add up to 360 degrees), the six of a tetrahedral one less so.
BEND: dict[tuple[str, int, int], float] = {
    ("C", 4, 0): 9.63, ("C", 4, 1): 4.23, ("C", 4, 2): 3.20,                   # CF4, C2H6, CH4
    ("C", 3, 0): 6.76, ("C", 3, 1): 2.81, ("C", 3, 2): 2.21,                   # C6H6, C2H4, H2CO
    ("N", 3, 0): 11.8, ("N", 3, 1): 5.59, ("N", 3, 2): 3.38,                   # NF3, CH3NH2, NH3
    ("O", 2, 0): 8.69, ("O", 2, 1): 5.25, ("O", 2, 2): 4.09,                   # F2O, CH3OH, H2O
    ("S", 2, 0): 9.72, ("S", 2, 2): 4.29,                                      # SO2, H2S
    ("Si", 4, 0): 5.38, ("Si", 4, 2): 2.84,                                    # SiF4 and SiCl4, SiH4
    ("P", 3, 0): 8.84, ("P", 3, 2): 4.04,                                      # PF3, PH3
}
#: A centre missing from `BEND`, by hydrogens among the outer atoms: tetrahedral carbon's, eV/rad^2.
GENERIC_BEND: dict[int, float] = {0: 9.63, 1: 4.23, 2: 3.20}

#: (centre element, hydrogens among the two outer atoms) -> linear-bend constant, eV/rad^2.
LINEAR_BEND: dict[tuple[str, int], float] = {("C", 0): 4.20, ("C", 1): 1.47,   # CO2 and CS2, C2H2 and HCN
                                             ("N", 0): 4.22}                   # N2O
#: A linear centre missing from `LINEAR_BEND`: carbon's, eV/rad^2.
GENERIC_LINEAR_BEND: dict[int, float] = {0: 4.20, 1: 1.47, 2: 1.47}

#: Lowest bond order along a torsion axis -> torsion constant of the whole axis, eV/rad^2,
#: shared equally by its dihedrals; linear in the order between the points. CH3CHO (a single
#: bond next to a double one), C6H6, C2H4.
TORSION: tuple[tuple[float, float], ...] = ((1.0, 0.185), (1.5, 1.63), (2.0, 3.48))
#: The torsion constant of a single bond between two saturated atoms, eV/rad^2 (C2H6, CH3OH, CH3NH2).
SATURATED_TORSION = 0.325
#: Bonds of a saturated atom; an element not listed is never saturated.
VALENCE: dict[str, int] = {"C": 4, "Si": 4, "N": 3, "P": 3, "O": 2, "S": 2}

#: Out-of-plane constant of every planar three-bonded centre, eV/rad^2, shared by its
#: improper dihedrals (C2H4, H2CO, C6H6).
OUT_OF_PLANE = 3.89


def _pair(a: str, b: str) -> tuple[str, str]:
    return (a, b) if a <= b else (b, a)


def stretch_constants(symbols: Sequence[str], lengths: NDArray[np.float64], bonds: NDArray[np.intp]
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(stretch constants in eV/Angstrom^2, bond orders) of `bonds` with these lengths (Angstrom).

    Between two tabulated lengths of a pair, log k and the order are interpolated linearly in
    log r; beyond them k follows the power law of `BADGER_EXPONENT` and the order Pauling's
    rule (`PAULING_LENGTH`). Bonds of one pair within `SAME_LENGTH` of each other are typed at
    their mean length.
    """
    from ase.data import atomic_numbers, covalent_radii

    k = np.empty(len(bonds))
    order = np.empty(len(bonds))
    for t, ((i, j), r) in enumerate(zip(bonds, _shared_lengths(symbols, lengths, bonds))):
        points = STRETCH.get(_pair(symbols[i], symbols[j]))
        if points is None:
            reference = covalent_radii[atomic_numbers[symbols[i]]] + covalent_radii[atomic_numbers[symbols[j]]]
            points = ((1.0, float(reference), GENERIC_STRETCH),)
        if r >= points[0][1] or len(points) == 1 and r <= points[0][1]:
            end = points[0]
        elif r <= points[-1][1]:
            end = points[-1]
        else:
            s = next(s for s in range(len(points) - 1) if points[s + 1][1] <= r)
            (o_a, r_a, k_a), (o_b, r_b, k_b) = points[s], points[s + 1]
            f = np.log(r_a / r) / np.log(r_a / r_b)
            k[t] = np.exp((1 - f) * np.log(k_a) + f * np.log(k_b))
            order[t] = o_a + f * (o_b - o_a)
            continue
        k[t] = end[2] * (end[1] / r) ** BADGER_EXPONENT
        order[t] = min(max(end[0] * np.exp((end[1] - r) / PAULING_LENGTH), 1.0), 3.0)
    return k, order


def _shared_lengths(symbols: Sequence[str], lengths: NDArray[np.float64], bonds: NDArray[np.intp]
                    ) -> NDArray[np.float64]:
    """The lengths with each run of one pair's lengths that agree within `SAME_LENGTH` (gaps
    between neighbours in sorted order) replaced by the run's mean: bonds that a symmetry makes
    equal get equal constants even where the geometry's last digits differ."""
    shared = np.array(lengths, dtype=float)
    pairs = [_pair(symbols[i], symbols[j]) for i, j in bonds]
    for pair in set(pairs):
        members = np.array([t for t, p in enumerate(pairs) if p == pair])
        members = members[np.argsort(shared[members], kind="stable")]
        breaks = np.flatnonzero(np.diff(shared[members]) > SAME_LENGTH) + 1
        for run in np.split(members, breaks):
            shared[run] = shared[run].mean()
    return shared


def _hydrogens(symbols: Sequence[str], outer: NDArray[np.intp]) -> NDArray[np.intp]:
    return np.array([sum(symbols[a] == "H" for a in row) for row in outer], dtype=np.intp)


def bend_constants(symbols: Sequence[str], angles: NDArray[np.intp], n_bonds: NDArray[np.intp]
                   ) -> NDArray[np.float64]:
    """Bend constants (eV/rad^2) of the angles (i, j, k): by centre j, its number of bonds
    (`n_bonds`, per atom) and the hydrogens among i, k."""
    count = _hydrogens(symbols, angles[:, [0, 2]])
    return np.array([BEND.get((symbols[j], int(n_bonds[j]), h), GENERIC_BEND[h])
                     for (_, j, _), h in zip(angles, count)])


def linear_bend_constants(symbols: Sequence[str], linear: NDArray[np.intp]) -> NDArray[np.float64]:
    """Linear-bend constants (eV/rad^2): by centre and hydrogens among the two outer atoms."""
    count = _hydrogens(symbols, linear[:, [0, 2]])
    return np.array([LINEAR_BEND.get((symbols[j], h), GENERIC_LINEAR_BEND[h]) for (_, j, _), h in zip(linear, count)])


def torsion_constants(symbols: Sequence[str], n_bonds: NDArray[np.intp], torsion_axis: NDArray[np.intp],
                      axes: Sequence[Sequence[int]], order_of: dict[tuple[int, int], float]) -> NDArray[np.float64]:
    """Torsion constants (eV/rad^2): the axis constant, shared equally by the dihedrals about
    that axis. A single bond between two saturated atoms (`VALENCE`) takes `SATURATED_TORSION`;
    any other axis takes `TORSION` at the lowest bond order along it."""
    orders, values = np.array(TORSION).T
    per_axis = np.empty(len(axes))
    for a, axis in enumerate(axes):
        order = min(order_of[_key(p, q)] for p, q in zip(axis[:-1], axis[1:]))
        saturated = all(n_bonds[e] >= VALENCE.get(symbols[e], 99) for e in (axis[0], axis[-1]))
        per_axis[a] = SATURATED_TORSION if saturated and len(axis) == 2 else np.interp(order, orders, values)
    count = np.bincount(torsion_axis, minlength=len(axes))
    return per_axis[torsion_axis] / count[torsion_axis]


def _key(a: int, b: int) -> tuple[int, int]:
    return (a, b) if a < b else (b, a)


def out_of_plane_constants(centre_count: NDArray[np.intp]) -> NDArray[np.float64]:
    """Out-of-plane constants (eV/rad^2): `OUT_OF_PLANE`, shared equally by the impropers of a
    centre (`centre_count` of them for each improper)."""
    return OUT_OF_PLANE / np.asarray(centre_count, dtype=float)
