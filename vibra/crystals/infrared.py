"""The infrared response of a polar crystal: mode effective charges, ε(ω), reflectivity, LO modes.

At Gamma the analytic dynamical matrix D(0) gives the transverse optical (TO) modes ω_m with
mass-weighted eigenvectors e_m. With the Born effective charges Z*_i (in units of the elementary
charge e) each mode carries a charge (Gonze & Lee, Phys. Rev. B 55, 10355 (1997))

    Z_m,a = sum_{i,b} Z*_i,ab e_m,ib / sqrt(m_i),

and an oscillator strength S_m = Z_m ⊗ Z_m. The dielectric tensor of the crystal (Gaussian form,
as in Gonze & Lee) is

    ε(ω) = ε∞ + (4π f / V) sum_m S_m / (ω_m² - ω² - i γ_m ω),

with f = e² / (4π ε0) in the crystal's energy x length (eV Angstrom for ``ASE`` units, J m for
``SI``), V the cell volume and γ_m the damping of mode m. The longitudinal (LO) frequencies
for a direction q̂ are the zeros of q̂·ε(ω)·q̂ (undamped); between each active TO pole and the
next LO zero q̂·ε·q̂ < 0, and light polarised along q̂ is totally reflected there (the
reststrahlen band). Lyddane-Sachs-Teller: prod_j ω_LO,j² / ω_TO,j² = q̂·ε(0)·q̂ / q̂·ε∞·q̂.

Symmetry: the space-group operations of the cell (spglib) act on the Gamma displacements; the
characters of each degenerate level are computed from the eigenvectors, decomposed on phonopy's
character tables (`phonopy.phonon.character_table`) into irrep labels, and compared with the
vector representation (χ(R) = tr R: infrared active) and its symmetric square
(χ(R) = (tr(R)² + tr(R²)) / 2: Raman active).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import Frozen, short_repr, span
from vibra.crystals.nac import FACTOR_ASE, FACTOR_SI, SUM_RULE_TOLERANCE, check_dielectric
from vibra.crystals.irreps import DEGENERACY_RTOL, analytic_gamma, classify_levels, symmetry_operations
from vibra.units import UnitSystem

if TYPE_CHECKING:
    from vibra.crystals.crystal import Crystal

__all__ = ["InfraredResponse", "infrared_response", "coulomb_factor", "BORN_SUM_ATOL", "DEGENERACY_RTOL",
           "ACTIVE_RTOL"]

#: Largest |sum_i Z*_i,ab| (in e) accepted by default: the correction's own (`vibra.crystals.nac`).
BORN_SUM_ATOL = SUM_RULE_TOLERANCE
#: A level couples to light along a direction when its strength there exceeds this fraction of
#: the strongest level's: below it the strength is rounding of a symmetry zero.
ACTIVE_RTOL = 1e-8


def coulomb_factor(units: UnitSystem) -> float:
    """e² / (4π ε0) in the energy x length of `units`: the correction's (`vibra.crystals.nac`, CODATA).

    Raises
    ------
    ValueError
        `units` is dimensionless (pass ``factor=`` to `infrared_response`).
    """
    if units.name == "ASE":
        return float(FACTOR_ASE)
    if units.name == "SI":
        return float(FACTOR_SI)
    raise ValueError(f"the crystal is in {units.name} units, which have no e^2 / (4 pi eps0); pass factor= "
                     "(the Coulomb factor in the crystal's energy x length)")


@dataclass(frozen=True, eq=False)
class InfraredResponse(Frozen):
    """The Gamma modes of a polar crystal and its infrared dielectric response.

    Modes are in ascending frequency, as `Crystal.modes_at` gives them; within a degenerate level
    the eigenvectors are real and rotated so that their mode charges are mutually orthogonal.

    Attributes
    ----------
    omega : (n_modes,) ndarray
        Transverse Gamma frequencies (analytic D(0)), in rad per time unit of `units`; the three
        acoustic ones are near 0, an unstable mode is -|omega|.
    vectors : (3 n_atoms, n_modes) ndarray
        Real mass-weighted orthonormal eigenvectors (dof 3 i + a), dimensionless.
    acoustic : (n_modes,) ndarray of bool
        The three modes closest to the uniform translations; excluded from ε(ω).
    mode_charges : (n_modes, 3) ndarray
        Z_m, in e / sqrt(mass unit).
    strengths : (n_modes, 3, 3) ndarray
        S_m = Z_m ⊗ Z_m, in e² / mass unit; zero for the acoustic modes.
    damping : (n_modes,) ndarray
        γ_m, in rad per time unit (0 for acoustic modes).
    epsilon_inf : (3, 3) ndarray
        ε∞, dimensionless.
    born : (n_atoms, 3, 3) ndarray
        Born charges used, in e, after removing `born_residual` evenly.
    born_residual : (3, 3) ndarray
        sum_i Z*_i of the charges given, in e (removed before use).
    volume : float
        Cell volume, in length unit³.
    factor : float
        e² / (4π ε0), in energy x length of `units`.
    levels : (n_modes,) ndarray of int
        Index of the degenerate level of each mode (0, 1, ... ascending).
    irreps : tuple of str
        Irrep label of each mode's level from phonopy's character table (Mulliken, e.g. ``"T1u"``;
        ``"A1+E"`` for an accidental degeneracy, ``"?"`` when the table has no match).
    ir_active, raman_active : (n_modes,) ndarray of bool
        The level's representation shares an irrep with the vector representation (infrared), or
        with its symmetric square (Raman); from characters, independent of the labels.
    point_group : str
        International symbol of the crystal's point group (spglib's).
    units : UnitSystem
        The crystal's units.
    """

    omega: NDArray[np.float64]
    vectors: NDArray[np.float64]
    acoustic: NDArray[np.bool_]
    mode_charges: NDArray[np.float64]
    strengths: NDArray[np.float64]
    damping: NDArray[np.float64]
    epsilon_inf: NDArray[np.float64]
    born: NDArray[np.float64]
    born_residual: NDArray[np.float64]
    volume: float
    factor: float
    levels: NDArray[np.int64]
    irreps: tuple[str, ...]
    ir_active: NDArray[np.bool_]
    raman_active: NDArray[np.bool_]
    point_group: str
    units: UnitSystem

    def __repr__(self) -> str:
        optical = ~self.acoustic
        try:
            to = span(self.units.omega_to_cm1(self.omega[optical & self.ir_active]), "cm^-1")
        except ValueError:
            to = span(self.omega[optical & self.ir_active], "rad/time unit")
        return short_repr(self, f"point group {self.point_group}", f"{int(optical.sum())} optical modes",
                          f"{int((optical & self.ir_active).sum())} IR active (TO {to})",
                          f"{int((optical & self.raman_active).sum())} Raman active",
                          f"eps_inf {span(np.linalg.eigvalsh(self.epsilon_inf))}", f"{self.units.name} units")

    def __len__(self) -> int:
        return int(self.omega.shape[0])

    # ------------------------------------------------------------------ frequencies
    def wavenumbers_cm1(self) -> NDArray[np.float64]:
        """(n_modes,) signed TO wavenumbers omega / (2 pi c), in cm^-1."""
        return self.units.omega_to_cm1(self.omega)

    def _prefactor(self) -> float:
        return 4.0 * np.pi * self.factor / self.volume

    # ------------------------------------------------------------------ dielectric tensor
    def dielectric(self, omega: ArrayLike) -> NDArray[np.complex128]:
        """(n_w, 3, 3) complex ε(ω) at angular frequencies `omega` (n_w,), in rad per time unit.

        Im ε >= 0 for omega > 0 (time dependence exp(-i omega t)); with zero damping ε is real
        and infinite at each TO frequency.
        """
        w = _validate.real_array(omega, "omega", ndim=(0, 1)).reshape(-1)
        optical = ~self.acoustic
        poles = self.omega[optical] ** 2
        gamma = self.damping[optical]
        with np.errstate(divide="ignore", invalid="ignore"):
            weights = 1.0 / (poles[None, :] - w[:, None] ** 2 - 1j * gamma[None, :] * w[:, None])
            sums = np.einsum("wm,mab->wab", weights, self.strengths[optical])
        return self.epsilon_inf[None, :, :] + self._prefactor() * sums

    def dielectric_cm1(self, wavenumbers: ArrayLike) -> NDArray[np.complex128]:
        """(n_w, 3, 3) complex ε at `wavenumbers` (n_w,), in cm^-1."""
        return self.dielectric(self.units.cm1_to_omega(np.atleast_1d(wavenumbers)))

    def static_dielectric(self) -> NDArray[np.float64]:
        """(3, 3) ε0 = ε∞ + (4π f / V) sum_m S_m / ω_m², dimensionless (the ω = 0 limit)."""
        optical = ~self.acoustic
        return self.epsilon_inf + self._prefactor() * np.einsum(
            "m,mab->ab", 1.0 / self.omega[optical] ** 2, self.strengths[optical])

    def reflectivity(self, omega: ArrayLike, direction: ArrayLike) -> NDArray[np.float64]:
        """(n_w,) normal-incidence reflectivity |(√ε_pp - 1) / (√ε_pp + 1)|², dimensionless in [0, 1].

        ε_pp = p·ε(ω)·p for light polarised along the Cartesian unit `direction` p (exact when p
        is a principal axis of ε, as on a face of a cubic, tetragonal or hexagonal crystal);
        `omega` (n_w,) in rad per time unit. At an undamped TO frequency itself R is 1.
        """
        p = _unit(direction, "direction")
        with np.errstate(invalid="ignore"):  # an undamped pole hit exactly: |r| -> 1 there
            epsilon = np.einsum("a,wab,b->w", p, self.dielectric(omega), p)
            root = np.sqrt(epsilon.astype(complex))
            ratio = np.abs((root - 1.0) / (root + 1.0)) ** 2
        return np.where(np.isfinite(epsilon), ratio, 1.0).astype(float)

    def reflectivity_cm1(self, wavenumbers: ArrayLike, direction: ArrayLike) -> NDArray[np.float64]:
        """(n_w,) reflectivity at `wavenumbers` (n_w,) in cm^-1, as `reflectivity`."""
        return self.reflectivity(self.units.cm1_to_omega(np.atleast_1d(wavenumbers)), direction)

    # ------------------------------------------------------------------ LO modes
    def _active_levels(self, q: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(poles ω², weights (q̂·Z)² summed per level) of the optical levels active along q."""
        optical = ~self.acoustic
        levels = self.levels[optical]
        along = (self.mode_charges[optical] @ q) ** 2
        index = np.unique(levels)
        weights = np.array([along[levels == k].sum() for k in index])
        poles = np.array([self.omega[optical][levels == k].mean() for k in index]) ** 2
        if weights.size == 0 or weights.max() <= 0.0:
            return np.zeros(0), np.zeros(0)
        keep = weights > ACTIVE_RTOL * weights.max()
        return poles[keep], weights[keep]

    def to_frequencies(self, direction: ArrayLike) -> NDArray[np.float64]:
        """(n_active,) TO frequencies whose modes couple to a field along `direction` (the poles of
        q̂·ε·q̂, each degenerate level once), ascending, in rad per time unit."""
        poles, _ = self._active_levels(_unit(direction, "direction"))
        return np.sqrt(poles)

    def lo_frequencies(self, direction: ArrayLike) -> NDArray[np.float64]:
        """(n_active,) LO frequencies for the Cartesian wave-vector `direction` q̂ → 0: the zeros of
        the undamped q̂·ε(ω)·q̂, ascending, in rad per time unit.

        They are the eigenvalues of diag(ω_TO,j²) + (4π f / V) a aᵀ / (q̂·ε∞·q̂), a_j² the strength
        of level j along q̂ (each active level collapsed onto its one coupled combination): one LO
        zero above each active TO pole, below the next.
        """
        q = _unit(direction, "direction")
        poles, weights = self._active_levels(q)
        if poles.size == 0:
            return np.zeros(0)
        amplitude = np.sqrt(weights)
        matrix = np.diag(poles) + self._prefactor() * np.outer(amplitude, amplitude) / float(q @ self.epsilon_inf @ q)
        return np.sqrt(np.linalg.eigvalsh(matrix))

    def lo_wavenumbers_cm1(self, direction: ArrayLike) -> NDArray[np.float64]:
        """(n_active,) `lo_frequencies` as wavenumbers, in cm^-1."""
        return self.units.omega_to_cm1(self.lo_frequencies(direction))

    def reststrahlen_bands(self, direction: ArrayLike) -> NDArray[np.float64]:
        """(n_active, 2) (ω_TO, ω_LO) pairs along `direction`, in rad per time unit: q̂·ε·q̂ < 0
        between them (total reflection without damping)."""
        return np.column_stack([self.to_frequencies(direction), self.lo_frequencies(direction)])

    def lyddane_sachs_teller(self, direction: ArrayLike) -> tuple[float, float]:
        """(prod_j ω_LO,j² / ω_TO,j², q̂·ε0·q̂ / q̂·ε∞·q̂) along `direction`: both dimensionless, and
        equal (the Lyddane-Sachs-Teller relation) for any ε of this oscillator form."""
        q = _unit(direction, "direction")
        bands = self.reststrahlen_bands(q)
        product = float(np.prod((bands[:, 1] / bands[:, 0]) ** 2)) if bands.size else 1.0
        return product, float(q @ self.static_dielectric() @ q) / float(q @ self.epsilon_inf @ q)


# ---------------------------------------------------------------------- construction
def infrared_response(crystal: Crystal, born: ArrayLike | None = None, dielectric: ArrayLike | None = None, *,
                      damping: ArrayLike | None = None,
                      factor: float | None = None, symprec: float = 1e-5,
                      born_sum_atol: float = BORN_SUM_ATOL) -> InfraredResponse:
    """The infrared response of `crystal` from its Born charges and high-frequency dielectric tensor.

    Parameters
    ----------
    crystal : Crystal
        With force constants (the analytic part: no dipole-dipole correction), primitive cell.
    born : (n_atoms, 3, 3) array_like, optional
        Born effective charges Z*_i,ab = dP_a / du_ib per atom in the crystal's order, in units
        of the elementary charge e (phonopy's ``nac_params["born"]``); default: the crystal's own
        (`Crystal.nac`, with its eps_inf and factor).
    dielectric : (3, 3) array_like, optional
        ε∞, symmetric positive definite, dimensionless; default: the crystal's own.
    damping : float or (3 n_atoms,) array_like, optional
        γ >= 0 per mode (in the ascending order of `Crystal.modes_at`) or one for all, in rad per
        time unit (``crystal.units.cm1_to_omega(w)`` converts from cm^-1). Default 0: harmonic
        force constants hold no phonon lifetime, so any other default would be invented; with
        γ = 0 the relations of harmonic theory (Lyddane-Sachs-Teller, R = 1 in the reststrahlen
        band) hold exactly. Modes of one degenerate level need one value.
    factor : float, optional
        e² / (4π ε0) in the crystal's energy x length; default `coulomb_factor` (required for a
        dimensionless crystal).
    symprec : float
        spglib's tolerance for the symmetry operations, as a fraction of the cell's size (the cell is
        scaled to unit size first, as `vibra.crystals.mesh` does, so that an SI cell in metres works),
        dimensionless.
    born_sum_atol : float
        Largest |sum_i Z*_i,ab| accepted, in e (default `BORN_SUM_ATOL`).

    Returns
    -------
    InfraredResponse

    Raises
    ------
    TypeError
        `crystal` is not a crystal.
    ValueError
        No force constants; `born` not (n_atoms, 3, 3) or missing charge neutrality by more than
        `born_sum_atol`; `dielectric` not (3, 3), not symmetric or not positive definite;
        negative or mis-shaped `damping`, or unequal damping within a degenerate level; a
        non-positive `factor` (or none for a dimensionless crystal); a non-positive `symprec`;
        an unstable optical mode at Gamma; a cell that is not primitive.
    """
    if not hasattr(crystal, "require_force_constants") or not hasattr(crystal, "modes_at"):
        raise TypeError(f"crystal must be a vibra.crystals.Crystal, got {type(crystal).__name__}")
    crystal.require_force_constants()
    polar = getattr(crystal, "nac", None)
    if born is None or dielectric is None:
        if polar is None:
            raise ValueError(f"crystal {crystal.name!r} has no Born charges: pass born= and dielectric=, or give the "
                             "crystal its correction first (crystal.with_nac(born, dielectric), read_phonopy(born=))")
        born = polar.born if born is None else born
        dielectric = polar.dielectric if dielectric is None else dielectric
        factor = polar.factor if factor is None else factor
    n_atoms = crystal.n_atoms
    charges = _validate.real_array(born, "born", ndim=3)
    if charges.shape != (n_atoms, 3, 3):
        raise ValueError(f"born must have shape ({n_atoms}, 3, 3) (one 3 x 3 tensor per atom of {crystal.name!r}), "
                         f"got {charges.shape}")
    tolerance = _validate.nonnegative_scalar(born_sum_atol, "born_sum_atol")
    residual = charges.sum(axis=0)
    miss = float(np.abs(residual).max())
    if miss > tolerance:
        a, b = (int(x) for x in np.unravel_index(np.argmax(np.abs(residual)), (3, 3)))
        raise ValueError(f"born breaks charge neutrality: |sum_i born[i,{a},{b}]| = {miss:.4g} e > "
                         f"born_sum_atol={tolerance:g} e; check the atom order and units of the charges "
                         "(or raise born_sum_atol)")
    epsilon = check_dielectric(dielectric)
    coulomb = coulomb_factor(crystal.units) if factor is None else _validate.positive_scalar(factor, "factor",
                                                                                             "Coulomb factor")
    tolerance_length = _validate.positive_scalar(symprec, "symprec", "symmetry tolerance")

    symmetry = symmetry_operations(crystal, tolerance_length)
    charges = charges - residual[None, :, :] / n_atoms
    omega, vectors, levels = analytic_gamma(crystal)
    gamma = _check_damping(damping, omega.size, levels)
    acoustic = _acoustic(vectors, crystal.masses)
    if (omega[~acoustic] <= 0).any():
        k = int(np.flatnonzero(~acoustic & (omega <= 0))[0])
        raise ValueError(f"crystal {crystal.name!r} has a zero or unstable optical mode at Gamma (branch {k}, "
                         f"omega = {omega[k]:.4g}); its dielectric response is not defined")
    vectors = _orient_levels(vectors, levels, acoustic, charges, crystal.masses)
    mode_charges = _mode_charges(vectors, charges, crystal.masses)
    strengths = mode_charges[:, :, None] * mode_charges[:, None, :]
    strengths[acoustic] = 0.0
    gamma = np.where(acoustic, 0.0, gamma)
    labels, ir, raman, point_group = classify_levels(symmetry, vectors, levels)
    return InfraredResponse(omega=omega, vectors=vectors, acoustic=acoustic, mode_charges=mode_charges,
                            strengths=strengths, damping=gamma, epsilon_inf=epsilon, born=charges,
                            born_residual=residual, volume=crystal.volume, factor=coulomb, levels=levels,
                            irreps=labels, ir_active=ir, raman_active=raman, point_group=point_group,
                            units=crystal.units)


# ---------------------------------------------------------------------- checks
def _unit(direction: ArrayLike, name: str) -> NDArray[np.float64]:
    vector = _validate.real_array(direction, name, ndim=1)
    if vector.shape != (3,):
        raise ValueError(f"{name} must hold 3 Cartesian components, got shape {vector.shape}")
    norm = float(np.linalg.norm(vector))
    if norm == 0.0:
        raise ValueError(f"{name} is the zero vector; it needs a direction")
    return vector / norm


def _check_damping(damping: ArrayLike | None, n_modes: int, levels: NDArray[np.int64]) -> NDArray[np.float64]:
    if damping is None:
        return np.zeros(n_modes)
    gamma = _validate.real_array(damping, "damping", ndim=(0, 1))
    if gamma.ndim == 0:
        gamma = np.full(n_modes, float(gamma))
    elif gamma.shape != (n_modes,):
        raise ValueError(f"damping must be one value or {n_modes} (one per Gamma mode), got {gamma.shape[0]}")
    _validate.nonnegative(gamma, "damping", "damping rate")
    for level in np.unique(levels):
        members = np.flatnonzero(levels == level)
        if np.ptp(gamma[members]) > 0:
            raise ValueError(f"damping[{members[0]}] and damping[{members[-1]}] differ but belong to one degenerate "
                             "level; give the modes of a level one damping")
    return gamma


# ---------------------------------------------------------------------- modes
def _acoustic(vectors: NDArray[np.float64], masses: NDArray[np.float64]) -> NDArray[np.bool_]:
    """The three modes with the largest weight on the mass-weighted uniform translations."""
    translations = np.kron(np.sqrt(masses)[:, None], np.eye(3)) / np.sqrt(masses.sum())
    weight = ((translations.T @ vectors) ** 2).sum(axis=0)
    acoustic = np.zeros(vectors.shape[1], dtype=bool)
    acoustic[np.argsort(-weight, kind="stable")[:3]] = True
    return acoustic


def _mode_charges(vectors: NDArray[np.float64], born: NDArray[np.float64],
                  masses: NDArray[np.float64]) -> NDArray[np.float64]:
    """(n_modes, 3) Z_m,a = sum_{i,b} Z*_i,ab e_m,ib / sqrt(m_i)."""
    n_atoms = masses.size
    shapes = vectors.reshape(n_atoms, 3, -1) / np.sqrt(masses)[:, None, None]
    return np.einsum("iab,ibm->ma", born, shapes)


def _orient_levels(vectors: NDArray[np.float64], levels: NDArray[np.int64], acoustic: NDArray[np.bool_],
                   born: NDArray[np.float64], masses: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotate each optical level's basis so that its mode charges are orthogonal (SVD of the 3 x d
    charge matrix), signs fixed so that the largest component is positive."""
    oriented = vectors.copy()
    for level in np.unique(levels):
        members = np.flatnonzero((levels == level) & ~acoustic)
        if members.size == 0:
            continue
        charges = _mode_charges(vectors[:, members], born, masses)  # (d, 3)
        _, _, right = np.linalg.svd(charges.T, full_matrices=True)
        oriented[:, members] = vectors[:, members] @ right.T
    for k in range(oriented.shape[1]):
        if oriented[np.argmax(np.abs(oriented[:, k])), k] < 0:
            oriented[:, k] = -oriented[:, k]
    return oriented
