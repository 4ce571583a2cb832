"""Point groups of molecules and the symmetry species (Mulliken labels) of their vibrations.

Detection (`point_group`): an operation is a symmetry of the molecule when it moves every atom
to within `tolerance` (Angstrom, default 0.01) of an atom of the same kind (same element and
mass for ASE ``Atoms``, same mass for a `System`). Candidate axes and mirror normals come from
the principal axes of inertia, the atoms, the midpoints, differences and cross products of
pairs of like atoms and the centroids of triples of like atoms; every candidate C_n, mirror
plane, S_2n and the inversion is tested, and the Schoenflies flowchart names the group. A
molecule whose atoms all lie within `tolerance` of one line is linear (C_inf_v, or D_inf_h with
an inversion centre). The operations of the named group are then built exactly in the
standard frame and matched to the atoms (the permutation each induces).

Standard frame (the convention behind every label; axes in `PointGroup.axes`):

- z along the principal axis (the S_2n axis of D2d, S4, ...; any C2 of D2, D2h).
- Cnv (n >= 3): x in the vertical mirror plane holding the most atoms (ties: the most mass).
  C2v: the mirror plane holding the most atoms is yz (Mulliken's recommendation, J. Chem. Phys. 23, 1997 (1955)), so
  a planar C2v molecule lies in yz: H2O's bend and symmetric stretch are A1, its antisymmetric
  stretch B2.
- Dn, Dnh, Dnd (n >= 3) and D2d: x along the C2' axis through the most atoms (benzene: C2'
  through two carbons, so sigma_v holds atoms and sigma_d bisects bonds, as in Cotton).
- D2h and D2: a planar molecule has z perpendicular to its plane and x along the in-plane C2
  axis through the most atoms (C2H4: x along C=C), the convention of Herzberg and of the NIST
  CCCBDB and Shimanouchi tables; otherwise z is the C2 axis through the most atoms and x the next.
- Cs: the mirror plane is xy (species A', A'').
- Td, Oh, T, O, Th: x, y, z along the C2 (C4) axes; I, Ih: x, y, z along three perpendicular C2.
- C_inf_v and D_inf_h: z along the molecular axis; the finite subgroups C8v and D8h stand for
  the infinite groups (`character_tables.py`).

Species (`mode_species`): the Cartesian displacements of a set of degenerate vibrations span a
representation; operation R carries the displacement u_i of atom i to R u_i on atom pi_R(i).
Its characters are the traces over the set, reduced with the character table; a set that
reduces to one species of its own dimension gets that label for each of its modes. Otherwise
(an accidental degeneracy, or a degeneracy split by a distortion smaller than the tolerance)
each mode gets the species on which its projection is largest.

Why not a library: spglib finds space groups of crystals, not molecular point groups; pymatgen's
PointGroupAnalyzer would bring all of pymatgen; `pointgroup` returns only the symbol; libmsym's
last wheel is from 2020; molsym (numpy only) mixes one tolerance across distances, moments of
inertia and cosines, has no character table for the linear groups and no path to T, and names
D2h's species "A_1g". The detector here states its tolerance in Angstrom and builds the standard
frames that the labels depend on.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linear_sum_assignment

from vibra._core import validate as _validate
from vibra._core.frozen import Frozen
from vibra.molecules.character_tables import LINEAR_ORDER, CharacterTable, character_table, symmetry_number
from vibra.system import Vibrating

if TYPE_CHECKING:
    from ase import Atoms

    from vibra.system import System

__all__ = ["PointGroup", "point_group", "mode_species", "SYMMETRY_TOLERANCE", "symmetry_number"]

#: Default tolerance of `point_group`, in Angstrom.
SYMMETRY_TOLERANCE = 0.01
_ALIGNED = np.cos(np.radians(10.0))     # two directions closer than 10 degrees are one axis
_SIDE = np.sin(np.radians(10.0))        # a direction within 10 degrees of perpendicular is perpendicular
_MAX_ORDER = 12                         # highest C_n tested (rings up to 12 atoms)
_MAX_TRIPLE_ATOMS = 12                  # centroids of triples only for kinds with <= 12 atoms


@dataclass(frozen=True, eq=False)
class PointGroup(Frozen):
    """The point group of a molecule, its operations and character table.

    Attributes
    ----------
    name : str
        Schoenflies symbol in ASCII: ``"C1"``, ``"Cs"``, ``"C2v"``, ``"C3v"``, ``"D2h"``,
        ``"D6h"``, ``"Td"``, ``"Oh"``, ``"Ih"``, ``"Cinfv"``, ``"Dinfh"``, ...
    operations : (n_operations, 3, 3) ndarray
        Orthogonal matrices of the operations in the input's Cartesian frame, about `center`;
        the identity first. For C_inf_v and D_inf_h: those of C8v and D8h.
    permutations : (n_operations, n_atoms) ndarray of int
        Operation g moves atom i onto atom ``permutations[g, i]``.
    axes : (3, 3) ndarray
        Rows: the standard frame's x, y and z axes in the input frame (see the module notes).
    center : (3,) ndarray
        Centre of mass, in Angstrom.
    tolerance : float
        The detection tolerance, in Angstrom.
    deviation : float
        Largest distance between an atom moved by an operation and the like atom it lands on,
        in Angstrom (0 for an exactly symmetric geometry; up to a few `tolerance`).
    table : CharacterTable
        Characters, one column per operation, with IR and Raman activity per species.
    """

    name: str
    operations: NDArray[np.float64]
    permutations: NDArray[np.intp]
    axes: NDArray[np.float64]
    center: NDArray[np.float64]
    tolerance: float
    deviation: float
    table: CharacterTable

    @property
    def symmetry_number(self) -> int:
        """Rotational symmetry number sigma (see `symmetry_number`)."""
        return symmetry_number(self.name)

    @property
    def is_linear(self) -> bool:
        """True for C_inf_v and D_inf_h."""
        return self.name in ("Cinfv", "Dinfh")

    @property
    def n_operations(self) -> int:
        """Number of operations held (the order of a finite group; 16 or 32 for linear groups)."""
        return len(self.operations)

    @property
    def standard_operations(self) -> NDArray[np.float64]:
        """(n_operations, 3, 3) the operations in the standard frame, A R A^T with A = `axes`."""
        return np.einsum("ia,gab,jb->gij", self.axes, self.operations, self.axes)

    def displace(self, index: int, displacements: ArrayLike) -> NDArray[np.float64]:
        """Apply operation `index` to a displacement field: (R u)[pi(i)] = R u[i].

        Parameters
        ----------
        index : int
            Operation number.
        displacements : (3 n_atoms,) or (3 n_atoms, k) array_like
            Cartesian displacements, atom-major, in any length unit.

        Returns
        -------
        ndarray, the same shape: the transformed displacements.
        """
        u = np.asarray(displacements, dtype=float)
        n = self.permutations.shape[1]
        field = u.reshape(n, 3, -1)
        moved = np.empty_like(field)
        moved[self.permutations[index]] = np.einsum("ab,ibk->iak", self.operations[index], field)
        return moved.reshape(u.shape)


# ------------------------------------------------------------------------------------ input
def _structure(molecule: Any) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.intp]]:
    """Positions (n, 3), masses (n,) and an integer kind per atom."""
    if isinstance(molecule, Vibrating):
        if molecule.is_generalized or molecule.dim != 3:
            raise ValueError(f"point_group needs a 3-D system of sites; this one has dim={molecule.dim}"
                             f"{' (generalised coordinates)' if molecule.is_generalized else ''}")
        positions = np.asarray(molecule.positions, dtype=float)
        masses = np.asarray(molecule.masses, dtype=float)
        symbols = getattr(molecule, "symbols", None)          # a System that keeps its symbols
        if symbols is None or len(symbols) != len(masses):
            symbols = [""] * len(masses)
    elif hasattr(molecule, "get_positions") and hasattr(molecule, "get_masses"):
        positions = np.asarray(molecule.get_positions(), dtype=float)
        masses = np.asarray(molecule.get_masses(), dtype=float)
        symbols = list(molecule.get_chemical_symbols())
    else:
        raise TypeError(f"point_group takes an ase.Atoms or a vibra System, got {type(molecule).__name__}")
    if len(masses) < 2:
        raise ValueError(f"point_group needs two or more atoms, got {len(masses)}")
    _validate.finite(positions, "positions")
    _validate.positive(masses, "masses", "mass")
    keys = [f"{symbol}:{mass:.6g}" for symbol, mass in zip(symbols, masses)]
    _, kinds = np.unique(keys, return_inverse=True)
    return positions, masses, kinds.astype(np.intp)


# ------------------------------------------------------------------------------------ geometry
def _rotation(axis: NDArray[np.float64], angle: float) -> NDArray[np.float64]:
    a = axis / np.linalg.norm(axis)
    cross = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.cos(angle) * np.eye(3) + np.sin(angle) * cross + (1.0 - np.cos(angle)) * np.outer(a, a)


def _reflection(normal: NDArray[np.float64]) -> NDArray[np.float64]:
    a = normal / np.linalg.norm(normal)
    return np.eye(3) - 2.0 * np.outer(a, a)


def _match(x: NDArray[np.float64], kinds: NDArray[np.intp], operation: NDArray[np.float64],
           limit: float) -> tuple[NDArray[np.intp], float] | None:
    """The permutation `operation` induces on like atoms and its largest miss, or None past `limit`."""
    moved = x @ operation.T
    probe = int(np.argmax(np.einsum("ia,ia->i", x, x)))          # quick rejection on the outermost atom
    like = kinds == kinds[probe]
    if not np.linalg.norm(x[like] - moved[probe], axis=1).min() <= limit:
        return None
    distance = np.linalg.norm(moved[:, None, :] - x[None, :, :], axis=2)
    distance[kinds[:, None] != kinds[None, :]] = np.inf
    nearest = np.argmin(distance, axis=1)
    misses = distance[np.arange(len(x)), nearest]
    if not misses.max() <= limit:
        return None
    if len(np.unique(nearest)) != len(x):
        cost = np.where(np.isfinite(distance), distance, 1e9)
        _, nearest = linear_sum_assignment(cost)
        misses = distance[np.arange(len(x)), nearest]
        if not misses.max() <= limit:
            return None
    return nearest.astype(np.intp), float(misses.max())


def _candidate_directions(x: NDArray[np.float64], masses: NDArray[np.float64], kinds: NDArray[np.intp],
                          tolerance: float) -> list[NDArray[np.float64]]:
    vectors = list(_inertia_axes(x, masses).T) + list(x)
    for kind in np.unique(kinds):
        members = x[kinds == kind]
        i, j = np.triu_indices(len(members), 1)
        vectors += list(members[i] + members[j]) + list(members[i] - members[j])
        vectors += list(np.cross(members[i], members[j]))
        if len(members) <= _MAX_TRIPLE_ATOMS:
            for a in range(len(members)):
                for b in range(a + 1, len(members)):
                    for c in range(b + 1, len(members)):
                        vectors.append(members[a] + members[b] + members[c])
    directions: list[NDArray[np.float64]] = []
    seen: set[tuple[float, ...]] = set()
    scale = max(float(np.abs(x).max()), tolerance)
    for v in vectors:
        norm = float(np.linalg.norm(v))
        if norm < 1e-3 * scale:
            continue
        unit = v / norm
        unit = unit if unit[np.argmax(np.abs(unit))] > 0 else -unit
        key = tuple(np.round(unit, 3))
        if key not in seen:
            seen.add(key)
            directions.append(unit)
    return directions


def _merge(axes: list[tuple[NDArray[np.float64], int]]) -> list[tuple[NDArray[np.float64], int]]:
    """Axes closer than 10 degrees merged, keeping the highest order."""
    merged: list[tuple[NDArray[np.float64], int]] = []
    for axis, n in sorted(axes, key=lambda item: -item[1]):
        if not any(abs(float(axis @ other)) > _ALIGNED for other, _ in merged):
            merged.append((axis, n))
    return merged


def _perpendicular(z: NDArray[np.float64], hint: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    for v in ([] if hint is None else [hint]) + [np.eye(3)[int(np.argmin(np.abs(z)))]]:
        w = v - (v @ z) * z
        if np.linalg.norm(w) > 1e-6:
            return w / np.linalg.norm(w)
    raise RuntimeError("no direction perpendicular to the principal axis")


def _on_axis(x: NDArray[np.float64], masses: NDArray[np.float64], axis: NDArray[np.float64],
             tolerance: float) -> tuple[int, float]:
    off = np.linalg.norm(x - np.outer(x @ axis, axis), axis=1) <= tolerance
    return int(off.sum()), float(masses[off].sum())


def _in_plane(x: NDArray[np.float64], masses: NDArray[np.float64], normal: NDArray[np.float64],
              tolerance: float) -> tuple[int, float]:
    inside = np.abs(x @ normal) <= tolerance
    return int(inside.sum()), float(masses[inside].sum())


def _inertia_axes(x: NDArray[np.float64], masses: NDArray[np.float64]) -> NDArray[np.float64]:
    """(3, 3) principal axes of inertia as columns, smallest moment first."""
    r2 = np.einsum("ia,ia->i", x, x)
    inertia = np.einsum("i,iab->ab", masses, r2[:, None, None] * np.eye(3) - x[:, :, None] * x[:, None, :])
    return np.asarray(np.linalg.eigh(inertia)[1])


def _frame(z: NDArray[np.float64], x_hint: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rows x, y, z of a right-handed frame with z along `z` and x nearest `x_hint`."""
    z = z / np.linalg.norm(z)
    x = _perpendicular(z, x_hint)
    return np.array([x, np.cross(z, x), z])


def _best(items: list[NDArray[np.float64]], score: Any) -> NDArray[np.float64]:
    """The item with the highest score (atoms, then mass); the first one on a tie."""
    return max(items, key=score)


# ------------------------------------------------------------------------------------ flowchart
def _classify(x: NDArray[np.float64], masses: NDArray[np.float64], kinds: NDArray[np.intp],
              tolerance: float) -> tuple[str, list[NDArray[np.float64]]]:
    """Schoenflies symbol and the candidate standard frames (rows x, y, z)."""
    inertia = _inertia_axes(x, masses)
    line = inertia[:, 0]
    far = x[int(np.argmax(np.linalg.norm(x, axis=1)))]

    def symmetric(operation: NDArray[np.float64]) -> bool:
        return _match(x, kinds, operation, tolerance) is not None

    inversion = symmetric(-np.eye(3))
    if np.all(np.linalg.norm(x - np.outer(x @ line, line), axis=1) <= tolerance):
        return ("Dinfh" if inversion else "Cinfv"), [_frame(line, inertia[:, 1])]
    found: list[tuple[NDArray[np.float64], int]] = []
    mirrors: list[NDArray[np.float64]] = []
    for d in _candidate_directions(x, masses, kinds, tolerance):
        found += [(d, n) for n in range(2, _MAX_ORDER + 1) if symmetric(_rotation(d, 2 * np.pi / n))]
        if symmetric(_reflection(d)) and not any(abs(float(d @ m)) > _ALIGNED for m in mirrors):
            mirrors.append(d)
    axes = _merge(found)
    if sum(n >= 3 for _, n in axes) >= 2:
        # cubic or icosahedral: the axes of products of the rotations found add those (C5 of C60)
        # that no atom, pair or triple points along
        rotations = [_rotation(a, 2 * np.pi / n) for a, n in axes]
        extra = [_axis(r1 @ r2) for r1 in rotations for r2 in rotations]
        for d in extra:
            if not any(abs(float(d @ a)) > _ALIGNED for a, _ in axes):
                found += [(d, n) for n in range(2, _MAX_ORDER + 1) if symmetric(_rotation(d, 2 * np.pi / n))]
        axes = _merge(found)
    high = [(a, n) for a, n in axes if n >= 3]
    two_fold = [a for a, n in axes if n % 2 == 0]
    if len(high) >= 2:
        orders = {n for _, n in high}
        if 5 in orders:
            name, frame_axes = ("Ih" if inversion else "I"), [a for a, n in axes if n == 2]
        elif 4 in orders:
            name, frame_axes = ("Oh" if inversion else "O"), [a for a, n in axes if n == 4]
        else:
            name = "Th" if inversion else ("Td" if mirrors else "T")
            frame_axes = [a for a, n in axes if n == 2]
        z = frame_axes[0]
        x_axis = next((a for a in frame_axes if abs(float(a @ z)) < _SIDE), far)
        frame = _frame(z, x_axis)
        return name, [frame, frame[[1, 0, 2]] * np.array([[1.0], [-1.0], [1.0]])]
    if not axes:
        if mirrors:
            return "Cs", [_frame(mirrors[0], far)]
        return ("Ci" if inversion else "C1"), [_frame(inertia[:, 2], inertia[:, 0])]
    n = max(order for _, order in axes)
    principal = [a for a, order in axes if order == n]
    if n == 2 and len(principal) > 1:
        principal = [a for a in principal if symmetric(_improper(a, 4))] or principal
    z = principal[0]
    perpendicular = [a for a in two_fold if abs(float(a @ z)) < _SIDE]
    sigma_h = any(abs(float(m @ z)) > _ALIGNED for m in mirrors)
    vertical = [m for m in mirrors if abs(float(m @ z)) < _SIDE]

    def on_axis(a: NDArray[np.float64]) -> tuple[int, float]:
        return _on_axis(x, masses, a, tolerance)

    def in_plane(m: NDArray[np.float64]) -> tuple[int, float]:
        return _in_plane(x, masses, m, tolerance)

    if len(perpendicular) >= n:
        name = f"D{n}h" if sigma_h else (f"D{n}d" if vertical else f"D{n}")
        if n == 2 and name != "D2d":
            three = [z] + perpendicular[:2]
            planar = [a for a in three if np.all(np.abs(x @ a) <= tolerance)]
            if planar:
                rest = [a for a in three if a is not planar[0]]
                return name, [_frame(planar[0], _best(rest, on_axis))]
            ranked = sorted(three, key=on_axis, reverse=True)
            return name, [_frame(ranked[0], ranked[1])]
        return name, [_frame(z, _best(perpendicular, on_axis))]
    if sigma_h:
        return f"C{n}h", [_frame(z, far)]
    if vertical:
        plane = _best(vertical, in_plane)
        if n == 2:
            return "C2v", [_frame(z, plane)]
        return f"C{n}v", [_frame(z, np.cross(plane, z))]
    if symmetric(_improper(z, 2 * n)):
        return (f"S{2 * n}"), [_frame(z, far)]
    return f"C{n}", [_frame(z, far)]


def _axis(rotation: NDArray[np.float64]) -> NDArray[np.float64]:
    """Unit axis of a proper rotation (the eigenvector of eigenvalue 1)."""
    values, vectors = np.linalg.eig(rotation)
    return np.asarray(np.real(vectors[:, int(np.argmin(np.abs(values - 1.0)))]))


def _improper(axis: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    """S_n about `axis`: a rotation by 2 pi / n followed by the reflection through the plane normal to it."""
    return _reflection(axis) @ _rotation(axis, 2 * np.pi / n)


def _generators(name: str) -> list[NDArray[np.float64]]:
    """Generators of group `name` in the standard frame."""
    z = np.array([0.0, 0.0, 1.0])
    sigma_h, sigma_v, c2x = np.diag([1.0, 1.0, -1.0]), np.diag([1.0, -1.0, 1.0]), np.diag([1.0, -1.0, -1.0])
    c3 = _rotation(np.ones(3), 2 * np.pi / 3)
    tetrahedral = [np.diag([-1.0, -1.0, 1.0]), c2x, c3]
    fixed = {"C1": [np.eye(3)], "Cs": [sigma_h], "Ci": [-np.eye(3)], "T": tetrahedral,
             "Td": tetrahedral + [_reflection(np.array([1.0, -1.0, 0.0]))], "Th": tetrahedral + [-np.eye(3)],
             "O": [_rotation(z, np.pi / 2), c3], "Oh": [_rotation(z, np.pi / 2), c3, -np.eye(3)]}
    icosahedral = [np.diag([-1.0, -1.0, 1.0]), c3, _rotation(np.array([0.0, 1.0, (1 + np.sqrt(5)) / 2]), 2 * np.pi / 5)]
    fixed.update({"I": icosahedral, "Ih": icosahedral + [-np.eye(3)]})
    name = {"Cinfv": f"C{LINEAR_ORDER}v", "Dinfh": f"D{LINEAR_ORDER}h"}.get(name, name)
    if name in fixed:
        return fixed[name]
    n = int("".join(ch for ch in name if ch.isdigit()))
    suffix = name[1 + len(str(n)):]
    if name[0] == "S":
        return [_improper(z, n)]
    rotation = [_rotation(z, 2 * np.pi / n)]
    if name[0] == "C":
        return rotation + {"": [], "v": [sigma_v], "h": [sigma_h]}[suffix]
    angle = np.pi / (2 * n)
    sigma_d = _reflection(np.array([-np.sin(angle), np.cos(angle), 0.0]))
    return rotation + [c2x] + {"": [], "h": [sigma_h], "d": [sigma_d]}[suffix]


def _closure(generators: list[NDArray[np.float64]]) -> NDArray[np.float64]:
    """All products of the generators (the group), the identity first."""
    operations = [np.eye(3)]
    keys = {tuple(np.round(np.eye(3), 6).ravel())}
    index = 0
    while index < len(operations):
        for generator in generators:
            product = generator @ operations[index]
            key = tuple(np.round(product, 6).ravel() + 0.0)
            if key not in keys:
                keys.add(key)
                operations.append(product)
        index += 1
    return np.array(operations)


def point_group(atoms_or_system: Atoms | System, tolerance: float = SYMMETRY_TOLERANCE) -> PointGroup:
    """The point group of a molecule, from its geometry and the kinds of its atoms.

    An operation is a symmetry when it moves every atom to within `tolerance` of an atom of the
    same kind: the same element and mass for ASE ``Atoms`` (isotopes differ), the same mass for a
    `System`. The operations of the named group are then built exactly in the standard frame
    (module notes) and matched to the atoms; each must land every atom within 3 `tolerance` of a
    like atom.

    Parameters
    ----------
    atoms_or_system : ase.Atoms or System
        The molecule (positions in Angstrom, masses in amu); a System must be 3-D sites.
    tolerance : float
        Largest distance, in Angstrom, between an atom moved by a symmetry operation and a like
        atom (default 0.01). Loose values (0.1) find the symmetry of a slightly distorted
        geometry; it must stay well below the distances between atoms.

    Returns
    -------
    PointGroup

    Raises
    ------
    TypeError
        Not an ase.Atoms or a System; a non-numeric tolerance.
    ValueError
        `tolerance` <= 0 or not finite; fewer than two atoms; a System that is not 3-D sites.
    RuntimeError
        The geometry is too far from the group found for the ideal operations to match it
        (lower the tolerance).

    Examples
    --------
    >>> from vibra.molecules import co2, h2o
    >>> point_group(h2o()).name, point_group(co2()).name, point_group(co2()).symmetry_number
    ('C2v', 'Dinfh', 2)
    """
    positions, masses, kinds = _structure(atoms_or_system)
    tolerance = _validate.real_scalar(tolerance, "tolerance")
    if not tolerance > 0:
        raise ValueError(f"tolerance is {tolerance!r}; it must be a positive distance in Angstrom")
    center = masses @ positions / masses.sum()
    x = positions - center
    name, frames = _classify(x, masses, kinds, tolerance)
    standard = _closure(_generators(name))
    for frame in frames:
        operations = np.einsum("ai,gab,bj->gij", frame, standard, frame)
        matches = [_match(x, kinds, operation, 3 * tolerance) for operation in operations]
        if all(match is not None for match in matches):
            permutations = np.array([match[0] for match in matches if match is not None])
            deviation = max(match[1] for match in matches if match is not None)
            return PointGroup(name=name, operations=operations, permutations=permutations, axes=frame,
                              center=center, tolerance=tolerance, deviation=deviation,
                              table=character_table(name, standard))
    raise RuntimeError(f"the geometry is too far from {name} for the operations of {name} to map it onto "
                       f"itself within 3 x tolerance = {3 * tolerance:g} Angstrom; lower the tolerance")


# ------------------------------------------------------------------------------------ species
def mode_species(group: PointGroup, shapes: ArrayLike, omega: ArrayLike, *,
                 rtol: float = 1e-6) -> tuple[str, ...]:
    """Mulliken label of each mode from the characters of its shape under the group's operations.

    Parameters
    ----------
    group : PointGroup
        The molecule's point group (`point_group`).
    shapes : (3 n_atoms, n_modes) array_like
        Cartesian displacement vectors (atom-major), any normalisation.
    omega : (n_modes,) array_like
        Their angular frequencies (any unit); modes within ``rtol * max|omega|`` of each other
        form one degenerate set, whose characters are the traces over the set.
    rtol : float
        Relative tolerance of degeneracy.

    Returns
    -------
    tuple of str
        One label per mode, in the order given (a degenerate pair gives its label twice).

    Raises
    ------
    TypeError
        `group` is not a PointGroup.
    ValueError
        Shapes of the wrong size, or a length of `omega` that is not the number of modes.
    """
    if not isinstance(group, PointGroup):
        raise TypeError(f"group must be a PointGroup, got {type(group).__name__}")
    u = _validate.real_array(shapes, "shapes", ndim=2)
    w = _validate.real_array(omega, "omega", ndim=1)
    n_dof = 3 * group.permutations.shape[1]
    if u.shape[0] != n_dof:
        raise ValueError(f"shapes must have {n_dof} rows (3 per atom), got {u.shape[0]}")
    if w.shape[0] != u.shape[1]:
        raise ValueError(f"omega has {w.shape[0]} entries for {u.shape[1]} modes")
    rtol = _validate.real_scalar(rtol, "rtol")
    table = group.table
    labels = [""] * len(w)
    order = np.argsort(w, kind="stable")
    gap = rtol * (float(np.abs(w).max()) if len(w) else 0.0)
    start = 0
    for end in range(1, len(w) + 1):
        if end < len(w) and w[order[end]] - w[order[end - 1]] <= gap:
            continue
        members = order[start:end]
        start = end
        basis, _ = np.linalg.qr(u[:, members])
        counts = table.reduce([np.trace(basis.T @ group.displace(g, basis)) for g in range(group.n_operations)])
        nearest = np.rint(counts)
        if (np.allclose(counts, nearest, atol=0.1) and nearest.sum() == 1
                and table.dimensions[int(np.argmax(nearest))] == len(members)):
            for k in members:
                labels[k] = table.labels[int(np.argmax(nearest))]
            continue
        weights = np.array([table.dimensions * table.reduce([v @ group.displace(g, v) for g in range(group.n_operations)])
                            for v in (u[:, members] / np.linalg.norm(u[:, members], axis=0)).T])
        slots = np.repeat(np.arange(len(table.labels)), (np.maximum(nearest, 0) * table.dimensions).astype(int))
        if np.allclose(counts, nearest, atol=0.1) and len(slots) == len(members):
            # accidental degeneracy: as many modes of each species as the set holds, the modes
            # matched to species by their projections (largest total weight)
            rows, columns = linear_sum_assignment(-weights[:, slots])
            chosen = slots[columns[np.argsort(rows)]]
        else:
            chosen = np.argmax(weights, axis=1)     # not closed: a degeneracy split below the tolerance
        for k, species in zip(members, chosen):
            labels[k] = table.labels[int(species)]
    return tuple(labels)
