"""`Crystal`: a unit cell, its atoms, and force constants between periodic images.

Conventions (fixed here, used by every module of `vibra.crystals`):

- ``cell`` (3, 3): rows are the lattice vectors a1, a2, a3, in the length unit of `units`.
  It must be right-handed (det > 0) unless the crystal is built with ``left_handed=True``.
- ``positions`` (n_atoms, 3): Cartesian, inside the cell (fractional coordinates in [0, 1));
  `Crystal.fractional` gives them in the basis of the lattice vectors.
- A lattice translation R is a triple of integers: the cell at R[0] a1 + R[1] a2 + R[2] a3.
- Force constants are the 3x3 blocks Phi(i 0; j R) = d^2 V / du_i(0) du_j(R), energy / length^2:
  the force on atom i of cell 0 is F_i = -sum_{j,R} Phi(i 0; j R) u_j(R). They are stored as
  `ForceConstants`, flat arrays of terms (i, j, R, block), so a spring model and phonopy's
  supercell force constants fit the same form. Self terms Phi(i 0; i 0) are terms like any other.
- 2-D and 1-D crystals are 3-D cells with vacuum axes (``periodic`` False along them): atoms
  move in three dimensions, the reciprocal lattice is 3-D, and no force constant may couple
  cells along a vacuum axis. This keeps one code path, and phonopy, seekpath and spglib (all
  3-D) take them as they are; the out-of-plane branches are what the model gives them (zero
  for central springs alone, the membrane branch with ``transverse`` stiffness).
"""

from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import Frozen, short_repr
import vibra.crystals.bands as bands
import vibra.crystals.dynamical as dynamical
import vibra.crystals.elastic as elastic
import vibra.crystals.mesh as mesh_module
import vibra.crystals.phonopy_io as phonopy_io
import vibra.crystals.supercell as supercell_modes
from vibra.crystals.born import nac_from_phonopy
from vibra.crystals.nac import NonAnalytic, Parts, non_analytic
import vibra.crystals.thermal as thermal
from vibra.crystals.dos import DensityOfStates, dos as density_of_states
from vibra.crystals.force_constants import (INDEX_SYMMETRY_RTOL, ForceConstants, ForceConstantsWarning, SpringModel,
                                            check_force_constants, index_asymmetry)
from vibra.units import UnitSystem, unit_system

if TYPE_CHECKING:
    from ase import Atoms
    from phonopy import Phonopy

__all__ = ["Crystal", "check_cell"]

#: Two atoms closer than this fraction of the shortest lattice vector overlap.
OVERLAP_RTOL = 1e-6
#: A fractional coordinate within this of 0 or 1 counts as on the cell's face (1 - tol wraps to 0).
FRACTIONAL_ATOL = 1e-10


@dataclass(frozen=True, eq=False)
class Crystal(Frozen):
    """A periodic crystal: a unit cell, atoms with masses, and (optionally) force constants.

    Build one with `Crystal.from_cell`, `Crystal.from_ase`, a builder of `vibra.crystals`
    (`fcc`, `diamond`, ...) or `vibra.crystals.from_phonopy`; add spring force constants with
    `vibra.crystals.springs`.

    Attributes
    ----------
    cell : (3, 3) ndarray
        Lattice vectors as rows, in the length unit of `units`.
    positions : (n_atoms, 3) ndarray
        Cartesian positions inside the cell, in the length unit.
    masses : (n_atoms,) ndarray
        Atomic masses, in the mass unit of `units`.
    symbols : tuple of str
        A label per atom (chemical symbol, or ``"X"``).
    units : UnitSystem
        Units of every quantity and of the results (angular frequencies in rad per time unit).
    periodic : tuple of 3 bool
        False along a vacuum axis (2-D and 1-D crystals).
    force_constants : ForceConstants or None
        Phi(i 0; j R), or None for a bare structure.
    springs : SpringModel or None
        The springs behind `force_constants` for a spring model, else None.
    name : str
        A short name used in reports.
    nac : NonAnalytic or None
        The non-analytic (LO-TO) correction of a polar crystal: Born charges, eps_inf and the
        Gonze-Lee or Wang form (`with_nac`, `vibra.crystals.nac`); None for none. It goes with the
        force constants: `with_force_constants` drops it.
    """

    cell: NDArray[np.float64]
    positions: NDArray[np.float64]
    masses: NDArray[np.float64]
    symbols: tuple[str, ...]
    units: UnitSystem
    periodic: tuple[bool, bool, bool] = (True, True, True)
    force_constants: ForceConstants | None = None
    springs: SpringModel | None = None
    name: str = "crystal"
    nac: NonAnalytic | None = None

    def __repr__(self) -> str:
        counts: dict[str, int] = {}
        for symbol in self.symbols:
            counts[symbol] = counts.get(symbol, 0) + 1
        formula = "".join(f"{s}{n if n > 1 else ''}" for s, n in counts.items())
        lengths = ", ".join(f"{x:.4g}" for x in np.linalg.norm(self.cell, axis=1))
        axes = "" if all(self.periodic) else f"periodic {tuple(self.periodic)}"
        if self.springs is not None:
            model = f"springs: {self.springs.first.size} bonds"
        elif self.force_constants is not None:
            model = f"force constants: {self.force_constants.n_terms} terms"
            asymmetry = self.index_asymmetry
            if asymmetry > INDEX_SYMMETRY_RTOL:
                model += f", index symmetry broken by {asymmetry:.2g}"
        else:
            model = "no force constants"
        polar = "" if self.nac is None else f"LO-TO by {'Gonze-Lee' if self.nac.method == 'gonze' else 'Wang'}"
        return short_repr(self, repr(self.name), f"{self.n_atoms} atom{'s' if self.n_atoms > 1 else ''} ({formula})", f"|a_i| {lengths} {self.units.length}",
                          axes, model, polar, f"{self.units.name} units")

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_cell(
        cls,
        cell: ArrayLike,
        positions: ArrayLike,
        masses: ArrayLike,
        *,
        fractional: bool = False,
        symbols: Sequence[str] | None = None,
        periodic: Sequence[bool] = (True, True, True),
        units: str | UnitSystem = "SI",
        left_handed: bool = False,
        wrap: bool = False,
        name: str = "crystal",
    ) -> Crystal:
        """A crystal from its lattice vectors and atoms (no force constants yet).

        Parameters
        ----------
        cell : (3, 3) array_like
            Lattice vectors as rows, in the length unit of `units`.
        positions : (n_atoms, 3) array_like
            Atomic positions: Cartesian (length unit), or fractional with ``fractional=True``.
        masses : (n_atoms,) array_like or float
            Atomic masses, in the mass unit of `units`.
        fractional : bool
            `positions` are in the basis of the lattice vectors.
        symbols : sequence of str, optional
            A label per atom (default ``"X"``).
        periodic : 3 bools
            False for a vacuum axis (a 2-D or 1-D crystal).
        units : str or UnitSystem
            ``"SI"`` (default), ``"ASE"`` (eV, Angstrom, amu) or ``"dimensionless"``.
        left_handed : bool
            Accept a cell with det < 0 (refused by default: usually lattice vectors out of order).
        wrap : bool
            Wrap positions outside the cell into it (refused by default: a position outside
            the cell usually means Cartesian coordinates passed as fractional, or the reverse).
        name : str
            Name used in reports.

        Raises
        ------
        ValueError
            A cell that is singular, or left-handed without ``left_handed=True``; positions
            outside the cell (without ``wrap=True``); two atoms at the same place (across the
            periodic images); non-positive masses; wrong shapes.
        """
        name = _validate.text(name, "name")
        units = unit_system(units)
        lattice = check_cell(cell, left_handed=left_handed)
        points = _validate.real_array(positions, "positions", ndim=2)
        if points.shape[1] != 3 or points.shape[0] == 0:
            raise ValueError(f"positions must have shape (n_atoms, 3) with n_atoms >= 1, got {points.shape}")
        n = points.shape[0]
        frac = points.copy() if fractional else points @ np.linalg.inv(lattice)
        frac = _inside_cell(frac, wrap)
        mass = _validate.real_values(masses, "masses")
        if mass.ndim == 0:
            mass = np.full(n, float(mass))
        if mass.shape != (n,):
            raise ValueError(f"masses must have {n} entries (one per atom), got shape {mass.shape}")
        _validate.positive(mass, "masses", "mass")
        if symbols is None:
            labels = ("X",) * n
        else:
            labels = tuple(_validate.text(s, f"symbols[{k}]") for k, s in enumerate(symbols))
            if len(labels) != n:
                raise ValueError(f"symbols must have {n} entries (one per atom), got {len(labels)}")
        flags = tuple(bool(p) for p in periodic)
        if len(flags) != 3:
            raise ValueError(f"periodic must hold 3 bools (one per lattice vector), got {len(flags)}")
        cartesian = frac @ lattice
        _check_overlaps(lattice, frac)
        return cls(cell=lattice, positions=cartesian, masses=mass, symbols=labels, units=units,
                   periodic=flags, name=name)  # type: ignore[arg-type]

    @classmethod
    def from_ase(cls, atoms: Atoms, *, wrap: bool = False, left_handed: bool = False,
                 name: str | None = None) -> Crystal:
        """A crystal from an `ase.Atoms` with a cell: positions, masses and symbols, in ASE units.

        ASE's ``pbc`` flags become `periodic`. Masses are ASE's (``atoms.get_masses()``, amu).

        Raises
        ------
        TypeError
            `atoms` is not an ase.Atoms.
        ValueError
            The atoms have no cell (or a singular one), and the checks of `from_cell`.
        """
        from ase import Atoms  # at the edge: ase only when asked

        if not isinstance(atoms, Atoms):
            raise TypeError(f"atoms must be an ase.Atoms, got {type(atoms).__name__}")
        cell = np.asarray(atoms.get_cell().array, dtype=float)
        if abs(np.linalg.det(cell)) == 0.0:
            raise ValueError("atoms has no cell (or a singular one); a crystal needs three lattice vectors "
                             "(set atoms.cell, e.g. ase.build.bulk)")
        return cls.from_cell(cell, atoms.get_positions(), atoms.get_masses(),
                             symbols=atoms.get_chemical_symbols(), periodic=tuple(bool(p) for p in atoms.pbc),
                             units="ASE", wrap=wrap, left_handed=left_handed,
                             name=name if name is not None else atoms.get_chemical_formula())

    # ------------------------------------------------------------------ structure
    @property
    def n_atoms(self) -> int:
        return int(self.positions.shape[0])

    @property
    def n_branches(self) -> int:
        """3 n_atoms: phonon branches per wave vector."""
        return 3 * self.n_atoms

    @property
    def fractional(self) -> NDArray[np.float64]:
        """(n_atoms, 3) positions in the basis of the lattice vectors, in [0, 1)."""
        return self.positions @ np.linalg.inv(self.cell)

    @property
    def reciprocal(self) -> NDArray[np.float64]:
        """(3, 3) reciprocal lattice vectors b_k as rows, a_i . b_k = 2 pi delta_ik, in rad / length."""
        return 2.0 * np.pi * np.linalg.inv(self.cell).T

    @property
    def volume(self) -> float:
        """Cell volume |det cell|, in length^3."""
        return float(abs(np.linalg.det(self.cell)))

    @functools.cached_property
    def point_rotations(self) -> NDArray[np.int32] | None:
        """The space group's rotations (spglib's), searched once per crystal (`vibra.crystals.mesh`)."""
        return mesh_module.point_rotations(self)

    @functools.cached_property
    def assembly(self) -> dynamical.Assembly:
        """What D(q) is made of (`vibra.crystals.dynamical.assembly`), formed once per crystal."""
        return dynamical.assembly(self)

    def __getstate__(self) -> dict[str, object]:
        """The fields only: the caches (`assembly`, `point_rotations`, `nac_parts`: the Ewald
        moments grow as n_G n_atoms^2) are formed again where the crystal is used (a Dask worker),
        not shipped with it."""
        return {field: getattr(self, field) for field in self.__dataclass_fields__}

    def __setstate__(self, state: dict[str, object]) -> None:
        for field, value in state.items():
            object.__setattr__(self, field, value)

    @functools.cached_property
    def nac_parts(self) -> Parts | None:
        """What D(q) with the correction is made of (`vibra.crystals.nac.parts`: the short-range
        crystal, the Ewald or phase-sum tables), formed once per crystal; None without `nac`."""
        from vibra.crystals.nac import parts

        return None if self.nac is None else parts(self, self.nac)

    @property
    def index_asymmetry(self) -> float:
        """How far the force constants break Phi(i 0; j R) = Phi(j 0; i -R)^T, relative to their largest entry.

        0 for a spring model; phonopy's force constants made from forces without symmetrisation
        break it by ~1e-2. D(q) is then not Hermitian: its Hermitian part is solved, as phonopy
        does, and the part removed is counted in `Phonons.omega_error` (`Phonons.non_hermitian`).
        """
        return 0.0 if self.force_constants is None else index_asymmetry(self.force_constants)

    def with_force_constants(self, force_constants: ForceConstants, springs: SpringModel | None = None
                             ) -> Crystal:
        """The same structure with other force constants (checked against it).

        Force constants that break the index symmetry by more than `INDEX_SYMMETRY_RTOL` of
        their largest entry draw a `ForceConstantsWarning` naming the figure (see
        `index_asymmetry`).
        """
        check_force_constants(force_constants, self.n_atoms, self.periodic)
        crystal = replace(self, force_constants=force_constants, springs=springs, nac=None)
        asymmetry = index_asymmetry(force_constants)
        if asymmetry > INDEX_SYMMETRY_RTOL:
            warnings.warn(f"the force constants of {self.name!r} break the index symmetry Phi(i,j) = Phi(j,i)^T by "
                          f"{asymmetry:.2g} of their largest entry; D(q) is made Hermitian, (D + D^H)/2, as phonopy "
                          "does, and the part removed is counted in omega_error (symmetrize='phonopy' or True imposes "
                          "the symmetry first)", ForceConstantsWarning, stacklevel=2)
        return crystal

    def with_nac(self, born: ArrayLike, dielectric: ArrayLike, *, method: str = "gonze", factor: float | None = None,
                 phonon: Phonopy | None = None, supercell: ArrayLike | None = None, sum_rule: str = "impose"
                 ) -> Crystal:
        """The same crystal with the non-analytic (LO-TO) correction of its Born charges and eps_inf.

        `born` (n_atoms, 3, 3) are the Born effective charges Z*_i (in e, phonopy's index order),
        `dielectric` (3, 3) the high-frequency dielectric tensor eps_inf; ``method="gonze"``
        (Gonze and Lee's Ewald form, phonopy's default) or ``"wang"``. Everything else, and the
        checks (eps_inf positive definite, the acoustic sum rule on Z* imposed and reported),
        is `vibra.crystals.nac.non_analytic`'s. Frequencies, bands (the direction of approach
        at Gamma taken along the path), group velocities, DOS and thermal properties all use it.
        """
        bare = replace(self, nac=None)
        return replace(self, nac=non_analytic(bare, born, dielectric, method=method, factor=factor, phonon=phonon,
                                              supercell=supercell, sum_rule=sum_rule))

    def require_force_constants(self) -> ForceConstants:
        """The force constants, or a ValueError saying how to attach them."""
        if self.force_constants is None:
            raise ValueError(f"crystal {self.name!r} has no force constants; attach some with "
                             "vibra.crystals.springs(crystal, ...) or vibra.crystals.from_phonopy(phonon)")
        return self.force_constants

    # ------------------------------------------------------------------ lattice dynamics
    # The work lives in the modules of this package (dynamical, bands, dos, thermal, elastic,
    # phonopy_io); these methods are the documented entry points.
    def phonons(self, qpoints: ArrayLike, *, vectors: bool = False, phase: str = "positions",
                accuracy: str = "high", q_direction: ArrayLike | None = None, max_seconds: float | None = None,
                max_memory: float | None = None) -> dynamical.Phonons:
        """`Phonons` at `qpoints` (fractional reciprocal coordinates): `vibra.crystals.dynamical.phonons`
        (planned and guarded by the solver registry's ``hermitian-eigh`` path)."""
        return dynamical.phonons(self, qpoints, vectors=vectors, phase=phase, accuracy=accuracy,
                                 q_direction=q_direction, max_seconds=max_seconds, max_memory=max_memory)

    def frequencies(self, qpoints: ArrayLike, *, accuracy: str = "high", q_direction: ArrayLike | None = None
                    ) -> NDArray[np.float64]:
        """(n_q, n_branches) angular frequencies at `qpoints`, ascending, imaginary as -|omega|.

        `qpoints` (n_q, 3) are in fractional coordinates of the reciprocal lattice (phonopy's
        convention); omega in rad per time unit of `units`. ``phonons(q).omega_error`` bounds them.
        A spring model is solved through its spring factor unless ``accuracy="fast"``. For a polar
        crystal (`with_nac`), `q_direction` is the direction from which Gamma is approached.
        """
        return self.phonons(qpoints, accuracy=accuracy, q_direction=q_direction).omega

    def modes_at(self, q: ArrayLike, *, phase: str = "positions") -> dynamical.Phonons:
        """`Phonons` at one fractional wave vector `q` (n_q = 1), with eigenvectors."""
        point = _validate.real_array(q, "q", ndim=1)
        if point.shape != (3,):
            raise ValueError(f"q must hold 3 fractional coordinates, got shape {point.shape}")
        return self.phonons(point[None, :], vectors=True, phase=phase)

    def band_structure(self, path: Sequence[Sequence[str]] | None = None, *, npoints: int = 200,
                       points: Mapping[str, ArrayLike] | None = None) -> bands.BandStructure:
        """`BandStructure` along `path` (SeeK-path's when None): `vibra.crystals.bands.band_structure`."""
        return bands.band_structure(self, path, npoints=npoints, points=points)

    def dos(self, mesh: int | Sequence[int], *, method: str = "tetrahedron", sigma: float | None = None,
            omega: ArrayLike | None = None, projected: bool = False, symmetry: bool = True) -> DensityOfStates:
        """Phonon DOS on a Gamma-centred mesh (tetrahedron or Gaussian): `vibra.crystals.dos.dos`."""
        return density_of_states(self, mesh, method=method, sigma=sigma, omega=omega, projected=projected, symmetry=symmetry)

    def thermal_properties(self, temperatures: ArrayLike, *, mesh: int | Sequence[int], symmetry: bool = True
                           ) -> thermal.ThermalProperties:
        """Free energy, entropy, heat capacity, zero-point energy: `vibra.crystals.thermal`."""
        return thermal.thermal_properties(self, temperatures, mesh=mesh, symmetry=symmetry)

    def sound_velocities(self, direction: ArrayLike, *, step: float | None = None) -> elastic.SoundVelocities:
        """Sound velocities along a Cartesian direction: `vibra.crystals.elastic.sound_velocities`."""
        return elastic.sound_velocities(self, direction, step=step)

    def supercell_mode(self, q: ArrayLike, branch: int, supercell: ArrayLike) -> supercell_modes.SupercellMode:
        """One mode written out on a supercell: `vibra.crystals.supercell.supercell_mode`."""
        return supercell_modes.supercell_mode(self, q, branch, supercell)

    def to_phonopy(self, supercell: Sequence[int] | None = None) -> Phonopy:
        """A `phonopy.Phonopy` with these force constants: `vibra.crystals.phonopy_io.to_phonopy`."""
        return phonopy_io.to_phonopy(self, supercell=supercell)

    @classmethod
    def from_phonopy(cls, phonon: Phonopy, *, name: str = "phonopy", symmetrize: bool | str | None = False,
                     periodic: Sequence[bool] = (True, True, True), nac: bool = True) -> Crystal:
        """The primitive cell and force constants of a `phonopy.Phonopy`, in ASE units (eV, Angstrom, amu).

        D(q) is phonopy's exactly: each supercell block is split over its equidistant shortest
        images as phonopy does (`vibra.crystals.phonopy_io`), and its Hermitian part is solved
        as phonopy solves it. The force constants are taken as the object holds them by default;
        ``symmetrize="phonopy"`` applies phonopy's ``symmetrize_force_constants`` first (what
        ``phonopy.load`` does to force constants made from forces), ``symmetrize=True`` imposes
        the acoustic sum rule and the index symmetry exactly (`vibra.crystals.impose_sum_rules`).
        `periodic` gives the vacuum axes of a 1-D or 2-D crystal (phonopy's cells are periodic
        along all three): no term may then couple cells along them. A phonon with ``nac_params``
        (a BORN file, a yaml's Born charges) gives a polar crystal with phonopy's correction
        (`with_nac`, the method phonopy's ``nac_params`` name, Gonze-Lee by default); ``nac=False``
        reads the force constants alone.
        """
        parts = phonopy_io.phonopy_terms(phonon, symmetrize=symmetrize)
        crystal = cls.from_cell(parts["cell"], parts["fractional"], parts["masses"], fractional=True,
                                symbols=parts["symbols"], units="ASE", periodic=periodic, name=name)
        crystal = crystal.with_force_constants(parts["force_constants"])
        if nac and phonon.nac_params is not None:
            crystal = crystal.with_nac(**nac_from_phonopy(phonon), phonon=phonon)
        return crystal


# ---------------------------------------------------------------------- checks
def check_cell(cell: ArrayLike, *, left_handed: bool = False) -> NDArray[np.float64]:
    """(3, 3) lattice vectors, refused when singular or (undeclared) left-handed."""
    lattice = _validate.real_array(cell, "cell", ndim=2)
    if lattice.shape != (3, 3):
        raise ValueError(f"cell must be 3 x 3 (lattice vectors as rows), got shape {lattice.shape}")
    lengths = np.linalg.norm(lattice, axis=1)
    if (lengths == 0).any():
        k = int(np.argmin(lengths))
        raise ValueError(f"cell is singular: lattice vector cell[{k}] is zero")
    det = float(np.linalg.det(lattice))
    if abs(det) <= 1e-10 * float(np.prod(lengths)):
        raise ValueError(f"cell is singular: det = {det:.3g} for lattice vectors of lengths "
                         f"{np.round(lengths, 6).tolist()} (they lie in one plane)")
    if det < 0 and not left_handed:
        raise ValueError(f"cell is left-handed (det = {det:.6g} < 0); swap two lattice vectors, or pass "
                         "left_handed=True if that is meant")
    return lattice


def _inside_cell(frac: NDArray[np.float64], wrap: bool) -> NDArray[np.float64]:
    near_one = np.abs(frac - 1.0) <= FRACTIONAL_ATOL
    frac = np.where(near_one, 0.0, frac)
    frac = np.where(np.abs(frac) <= FRACTIONAL_ATOL, 0.0, frac)
    outside = (frac < 0.0) | (frac >= 1.0)
    if outside.any():
        if wrap:
            return frac - np.floor(frac)
        i = int(np.argwhere(outside)[0][0])
        raise ValueError(f"positions[{i}] is outside the cell: fractional coordinates "
                         f"{np.round(frac[i], 6).tolist()} not in [0, 1); pass wrap=True to wrap it into the cell "
                         "(or fractional=True if these are fractional coordinates)")
    return frac


def _check_overlaps(cell: NDArray[np.float64], frac: NDArray[np.float64]) -> None:
    n = frac.shape[0]
    if n < 2:
        return
    tolerance = OVERLAP_RTOL * float(np.linalg.norm(cell, axis=1).min())
    delta = frac[None, :, :] - frac[:, None, :]
    delta -= np.round(delta)  # nearest image in fractional terms, then the 27 around it
    shifts = np.array([(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1)], dtype=float)
    distance = np.linalg.norm((delta[:, :, None, :] + shifts) @ cell, axis=-1).min(axis=2)
    distance[np.arange(n), np.arange(n)] = np.inf
    if (distance < tolerance).any():
        i, j = (int(x) for x in np.argwhere(distance < tolerance)[0])
        raise ValueError(f"positions[{i}] and positions[{j}] overlap (distance {distance[i, j]:.3g} between "
                         "periodic images); every atom needs a place of its own")
