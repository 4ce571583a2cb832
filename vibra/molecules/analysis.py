"""The vibrational analysis of a molecule: Eckart projection of translations and rotations,
3N-6 (3N-5) vibrations, imaginary modes flagged, reduced masses, force constants, zero-point energy."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Literal

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy import constants

from vibra._core import validate as _validate
from vibra._core.frozen import Frozen
from vibra._core.text import counted
from vibra.modes import Modes, normal_modes
from vibra.molecules.checks import nonnegative_scalar
from vibra.molecules.numbering import herzberg_numbers
from vibra.molecules.rigid_body import is_linear, rigid_body_vectors, warn_soft_modes
from vibra.molecules.symmetry import PointGroup, mode_species, point_group
from vibra.system import System, Vibrating

__all__ = ["VibrationalAnalysis", "vibrational_analysis"]


@dataclass(frozen=True, eq=False)
class VibrationalAnalysis(Frozen):
    """Normal modes of a molecule split into rigid-body motions and vibrations.

    Attributes
    ----------
    modes : Modes
        All n_dof modes, ascending omega (imaginary ones first, as -|omega|), in ASE units
        (rad per Angstrom sqrt(amu/eV)). With projection the rigid-body modes have omega = 0
        exactly and the rigid-body vectors as their vectors.
    rigid : (n_dof,) ndarray of bool
        True for a translation or rotation (matched by overlap with the rigid-body subspace).
    imaginary : (n_dof,) ndarray of bool
        True for an imaginary vibration (omega < 0, not rigid).
    rigid_overlap : (n_dof,) ndarray
        |T^T d_k|^2: weight of each mass-weighted vector in the rigid-body subspace (0 to 1).
    reduced_mass : (n_dof,) ndarray
        mu_k = 1 / sum_i (d_ki^2 / m_i), amu: the quantum-chemistry reduced mass (the Cartesian
        displacement M^-1/2 d_k normalised to 1).
    force_constant : (n_dof,) ndarray
        k_k = mu_k omega_k |omega_k|, eV / Angstrom^2 (negative for imaginary modes).
    linear : bool
        The geometry is linear (inertia tensor, relative tolerance).
    n_rigid : int
        Number of rigid-body modes (3N-6 or 3N-5 vibrations remain in 3-D).
    projected : bool
        Translations and rotations were projected out of K~ (Eckart) before solving.
    name : str
        Name of the system.
    system : System or None
        The molecule analysed (for `point_group` and `species`).
    """

    modes: Modes
    rigid: NDArray[np.bool_]
    imaginary: NDArray[np.bool_]
    rigid_overlap: NDArray[np.float64]
    reduced_mass: NDArray[np.float64]
    force_constant: NDArray[np.float64]
    linear: bool
    n_rigid: int
    projected: bool
    name: str = "molecule"
    system: System | None = None

    def __repr__(self) -> str:
        """One line: the molecule, its vibrations and rigid-body modes, imaginary ones, the path."""
        imaginary = int(np.count_nonzero(self.imaginary))
        return (f"VibrationalAnalysis({self.name}: {counted(self.n_vibrations, 'vibration')}, "
                f"{counted(self.n_rigid, 'rigid-body mode')}{', linear' if self.linear else ''}"
                f"{', ' + counted(imaginary, 'imaginary mode') if imaginary else ''}, path {self.modes.path!r})")

    @cached_property
    def point_group(self) -> PointGroup:
        """Point group of the molecule (`vibra.molecules.point_group`, tolerance 0.01 Angstrom)."""
        if self.system is None:
            raise ValueError("this analysis was built without its system; call point_group(system)")
        return point_group(self.system)

    @cached_property
    def species(self) -> tuple[str, ...]:
        """Mulliken label of each vibration, in the order of `vibrations` (ASCII, e.g. "A1", "Pi_u").

        From the characters of the vibrations' Cartesian shapes under `point_group`'s operations,
        degenerate sets (frequencies within 1e-6 of the largest) taken together
        (`vibra.molecules.mode_species`). IR and Raman activity by symmetry:
        ``self.point_group.table.is_ir_active(label)``, ``.is_raman_active(label)``.
        """
        shapes = np.asarray(self.modes.shapes)[:, self.vibrations]
        return mode_species(self.point_group, shapes, self.modes.omega[self.vibrations])

    @cached_property
    def numbers(self) -> tuple[int, ...]:
        """Herzberg's number of each vibration (1 for nu1), in the order of `vibrations`.

        By species in the order of `point_group`'s character table, decreasing frequency within
        a species, a degenerate set counted once (`vibra.molecules.numbering.herzberg_numbers`):
        the numbering of Shimanouchi's tables. A C1 molecule: by decreasing frequency alone.
        """
        group = self.point_group
        return herzberg_numbers(group.table.labels, self.species, self.vibration_wavenumbers_cm1(),
                                linear=group.name in ("Cinfv", "Dinfh"), n_atoms=group.permutations.shape[1])

    @property
    def vibrations(self) -> NDArray[np.intp]:
        """Indices of the vibrational (non-rigid) modes, ascending omega."""
        return np.flatnonzero(~self.rigid)

    @property
    def n_vibrations(self) -> int:
        """Number of vibrations (3N-6, 3N-5, or n_dof - n_rigid)."""
        return int((~self.rigid).sum())

    def wavenumbers_cm1(self) -> NDArray[np.float64]:
        """(n_dof,) signed wavenumbers of all modes, in cm^-1 (imaginary as negative)."""
        return self.modes.wavenumbers_cm1()

    def vibration_wavenumbers_cm1(self) -> NDArray[np.float64]:
        """(n_vibrations,) signed wavenumbers of the vibrations, ascending, in cm^-1."""
        return self.modes.wavenumbers_cm1()[~self.rigid]

    def force_constants_mdyn_per_angstrom(self) -> NDArray[np.float64]:
        """(n_dof,) force constants in mdyn / Angstrom (Gaussian's unit; 1 mdyn/A = 100 N/m)."""
        si = self.force_constant * constants.electron_volt / constants.angstrom**2  # N/m
        return si / 100.0

    def zero_point_energy_ev(self) -> float:
        """Zero-point energy sum 1/2 hbar omega over real vibrations, in eV."""
        real = (~self.rigid) & (self.modes.omega > 0)
        return float(0.5 * np.sum(self.modes.energies_mev()[real]) / 1000.0)

    def table(self) -> str:
        """Plain-text table: mode, kind, wavenumber, reduced mass, force constant."""
        lines = [f"{self.name}: {self.n_vibrations} vibrations, {self.n_rigid} rigid-body modes"
                 f"{' (linear)' if self.linear else ''}",
                 f"{'mode':>4}  {'kind':<10} {'cm^-1':>11} {'mu (amu)':>9} {'k (mdyn/A)':>11}"]
        k_mdyn = self.force_constants_mdyn_per_angstrom()
        for i, wave in enumerate(self.wavenumbers_cm1()):
            kind = "rigid" if self.rigid[i] else ("imaginary" if self.imaginary[i] else "vibration")
            text = f"{abs(wave):10.2f}{'i' if wave < 0 else ' '}"
            lines.append(f"{i:>4}  {kind:<10} {text} {self.reduced_mass[i]:9.4f} {k_mdyn[i]:11.4f}")
        lines.append(f"zero-point energy: {self.zero_point_energy_ev():.6f} eV")
        return "\n".join(lines)


def _reported_when_built(system: System) -> bool:
    """A molecule from a valence force field (K = B^T W B exactly, chemical symbols set, as
    `from_atoms` and `molecule` build it): its builder counted the zero modes of B and warned,
    naming the missing terms, so the analysis does not warn a second time."""
    return (getattr(system, "symbols", None) is not None and getattr(system, "extra_hessian", None) is None
            and system.spring_factor() is not None)


def vibrational_analysis(
    system: System,
    *,
    project: bool = True,
    accuracy: Literal["high", "fast"] = "high",
    linear_rtol: float = 1e-6,
    zero_rtol: float = 1e-6,
) -> VibrationalAnalysis:
    """Vibrations of a molecule, rigid-body motions handled like quantum-chemistry codes.

    With `project` the mass-weighted Hessian K~ = M^-1/2 K M^-1/2 is restricted to the
    orthogonal complement Q of the rigid-body vectors T (`rigid_body_vectors`, Eckart
    conditions): Q^T K~ Q is solved for exactly n_dof - n_rigid vibrations, and the rigid modes
    get omega = 0. Without it K~ is solved as is and the n_rigid modes with the largest overlap
    |T^T d_k|^2 are labelled rigid (matched, not picked by position).

    Parameters
    ----------
    system : System
        A molecule (sites, no frozen dofs); any dimension 1 to 3.
    project : bool
        Project out translations and rotations before solving.
    accuracy : {"high", "fast"}
        "high" hands the projected spring factor (B M^-1/2 Q, w) to the solver for high relative
        accuracy when K is factorised; "fast" solves the dense projected K~ directly.
    linear_rtol : float
        Relative tolerance on the smallest principal moment of inertia for linearity.
    zero_rtol : float
        A vibration with |omega| <= zero_rtol * max|omega| counts as a soft (zero) mode: more
        of them than allowed raise a `SoftModeWarning`.

    Returns
    -------
    VibrationalAnalysis

    Warns
    -----
    SoftModeWarning
        Vibrations with zero frequency (the force field does not hold some motion). Not for a
        molecule of `from_atoms` or `molecule`: those warn once, when built, naming the
        keyword that adds the missing terms.
    RuntimeWarning
        Imaginary vibrations (from `normal_modes`); they are kept and flagged.

    Raises
    ------
    TypeError
        `system` is not a System, or is in generalised coordinates.
    ValueError
        A system with frozen degrees of freedom (rigid-body motions are then not free); an
        unknown `accuracy`; a negative `linear_rtol` or `zero_rtol`.

    Examples
    --------
    >>> from vibra.molecules import h2o
    >>> analysis = vibrational_analysis(h2o())
    >>> analysis.n_vibrations, analysis.n_rigid, analysis.linear
    (3, 6, False)
    >>> round(analysis.zero_point_energy_ev(), 3)
    0.558
    """
    if not isinstance(system, Vibrating):
        raise TypeError(f"system must be a vibra System, got {type(system).__name__}")
    if system.is_generalized:
        raise TypeError("system is in generalised coordinates; a vibrational analysis needs sites")
    if system.frozen.any():
        raise ValueError(
            f"system has {counted(int(system.frozen.sum()), 'frozen degree of freedom')}; translations and "
            "rotations are not free, so there are no rigid-body modes to separate"
        )
    project = _validate.boolean(project, "project")
    _validate.choice(accuracy, "accuracy", ("high", "fast"))
    linear_rtol = nonnegative_scalar(linear_rtol, "linear_rtol", "relative")
    zero_rtol = nonnegative_scalar(zero_rtol, "zero_rtol", "relative")
    positions = np.asarray(system.positions)
    masses = np.asarray(system.masses)
    dim = system.dim
    n_dof = system.n_dof
    t = rigid_body_vectors(positions, masses, linear_rtol=linear_rtol)
    n_rigid = t.shape[1]
    linear = dim == 3 and is_linear(positions, masses, rtol=linear_rtol)
    mass_dof = np.repeat(masses, dim)
    inv_sqrt = 1.0 / np.sqrt(mass_dof)
    K = system.hessian()
    if project:
        full, _ = np.linalg.qr(np.hstack([t, np.eye(n_dof)]))
        q = full[:, n_rigid:n_dof]
        # Q spans the complement of T: QR of [T, I] gives T's span first, then the rest.
        K_tilde = (K.multiply(inv_sqrt[:, None]).multiply(inv_sqrt[None, :])).toarray() if sp.issparse(K) else (
            inv_sqrt[:, None] * K * inv_sqrt[None, :])
        K_internal = q.T @ K_tilde @ q
        K_internal = (K_internal + K_internal.T) / 2.0
        factor = system.spring_factor() if accuracy == "high" else None
        spring = None
        if factor is not None and factor[0].shape[0]:
            b = factor[0].toarray() * inv_sqrt[None, :] @ q
            spring = (b, factor[1])
        inner = normal_modes(K_internal, np.ones(n_dof - n_rigid), spring_factor=spring, units=system.units)
        vectors_internal = q @ inner.vectors
        omega = np.concatenate([np.zeros(n_rigid), inner.omega])
        vectors = np.hstack([t, vectors_internal])
        errors = np.concatenate([np.zeros(n_rigid), inner.omega_error])
        order = np.argsort(omega, kind="stable")
        omega, vectors, errors = omega[order], vectors[:, order], errors[order]
        rigid = np.concatenate([np.ones(n_rigid, bool), np.zeros(n_dof - n_rigid, bool)])[order]
        orthogonality = float(np.abs(vectors.T @ vectors - np.eye(n_dof)).max())
        modes = Modes(omega=omega, vectors=vectors, shapes=vectors * inv_sqrt[:, None], mass=mass_dof,
                      omega_error=errors, residual=inner.residual, orthogonality=orthogonality,
                      solver=f"eckart+{inner.solver}", units=system.units)
        overlap = np.sum((t.T @ vectors) ** 2, axis=0)
    else:
        modes = system.modes(accuracy=accuracy)
        overlap = np.sum((t.T @ np.asarray(modes.vectors)) ** 2, axis=0)
        rigid = np.zeros(n_dof, bool)
        rigid[np.argsort(-overlap, kind="stable")[:n_rigid]] = True
    scale = float(np.abs(modes.omega).max()) if n_dof else 0.0
    soft = (~rigid) & (np.abs(modes.omega) <= zero_rtol * scale)
    if soft.any() and not _reported_when_built(system):
        warn_soft_modes(int(soft.sum()) + n_rigid, n_rigid, system.name,
                        "its Hessian holds them with no force (a force field that lacks terms, or a geometry "
                        "off the minimum); for a valence force field see vibra.molecules.valence_model")
    d = np.asarray(modes.vectors)
    reduced_mass = 1.0 / np.sum(d**2 / mass_dof[:, None], axis=0)
    return VibrationalAnalysis(
        modes=modes, rigid=rigid, imaginary=(~rigid) & (modes.omega < 0), rigid_overlap=overlap,
        reduced_mass=reduced_mass, force_constant=reduced_mass * modes.omega * np.abs(modes.omega),
        linear=bool(linear), n_rigid=n_rigid, projected=bool(project), name=system.name, system=system,
    )
