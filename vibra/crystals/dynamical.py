"""The dynamical matrix D(q) of a crystal, built for many q at once, and its eigenpairs.

Wave vectors q are in fractional coordinates of the reciprocal lattice (phonopy's convention):
the Cartesian wave vector is q @ reciprocal = 2 pi q @ inv(cell).T. For the terms Phi(i 0; j R)
of `ForceConstants`,

    D_{i a, j b}(q) = sum_{terms (i, j, R)} Phi_ab(i 0; j R) exp(2 pi i q . d) / sqrt(m_i m_j),

with d the fractional vector of the term. Two phase conventions:

- ``phase="positions"`` (default; phonopy's): d = x_j + R - x_i, the vector between the atoms
  themselves. Eigenvectors are smooth in q and match phonopy's.
- ``phase="cell"``: d = R, the lattice translation alone. D is then periodic in q with the
  reciprocal lattice; its eigenvectors differ from phonopy's by the phase exp(2 pi i q . x_j)
  per atom. Eigenvalues are the same in both.

Batched: the phases of all terms at all q form one (n_q, n_terms) matrix P, and D for every q
is P @ A with A the (n_terms, (3n)^2) scatter of the mass-weighted blocks: two real GEMMs, in
chunks of q bounded in memory, then stacked Hermitian solves: the solver registry's
``hermitian-eigh`` path, planned from sizes and guarded before any work (`solve_plan`), its runner
`vibra.solvers.standard.hermitian.hermitian_stack`. No Python loop runs per q.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Iterator

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import frequency_span
from vibra._results import Result, stored
from vibra.crystals.factor import singular_frequencies
from vibra.solvers.accuracy import HIGH_TARGET, check as check_accuracy, uses_springs
from vibra.solvers.common import EPS, omega_and_error
from vibra._core.text import counted
from vibra.solvers.budget import guard
from vibra.solvers.dispatch import SolvePlan, plan_problem
from vibra.solvers.problem import bloch_problem
from vibra.solvers.registry import BY_NAME
from vibra.units import UnitSystem

if TYPE_CHECKING:
    from vibra.crystals.force_constants import CrystalLike as Crystal  # the protocol: no import cycle

__all__ = ["PHASES", "Phonons", "phonons", "solve_plan", "dynamical_matrices", "derivative_matrices",
           "check_qpoints", "check_periodic_qpoints", "reduce_qpoints", "brillouin_qpoints",
           "Assembly", "assembly", "lattice_phases"]

#: The phase conventions of D(q) (module docstring).
PHASES: tuple[str, ...] = ("positions", "cell")

#: The levels `phonons` offers (`vibra.solvers.accuracy`; "certified" refused: D(q)'s bounds are not certificates).
ACCURACY: tuple[str, ...] = ("high", "fast")

#: "high" re-solves a spring model's q-point through its factor where a bound on D(q) misses this (`accuracy.HIGH_TARGET`).
HIGH_RTOL = HIGH_TARGET

#: Entries per chunk of the stacked D(q) and phases (~1 MiB of complex D(q); the peak is a few
#: times that): small enough that frequencies on a path take no more memory than phonopy's
#: run_qpoints, large enough that the GEMMs and stacked solves run at full speed
#: (benchmarks/RESULTS.md, "Crystals against phonopy": memory).
CHUNK_ENTRIES = 1 << 16

#: dD/dk of a polar crystal by central differences (phonopy's group velocities difference D(q)
#: likewise) with a step of this fraction of |k|, the distance from the nearest Gamma (at least
#: 1e-3 of the shortest reciprocal vector): the correction (q Z)(q Z) / (q eps q) varies on the
#: scale of |k| itself, so truncation ~(step / |k|)^2 = 1e-10 relative, rounding ~eps |k| / step ~1e-11.
NAC_DERIVATIVE_STEP = 1e-5

#: Entries of D(q) per call of a polar crystal's correction (4 MiB of complex D; its parts are
#: kept per crystal, `Crystal.nac_parts`): 16 MiB ran 0-3 % faster on phonopy's NaCl and ZnO and
#: held 4-6 MiB more at 2,000 q (bench_crystals --memory --real).
POLAR_CHUNK = 1 << 18

@dataclass(frozen=True, eq=False, repr=False)
class Phonons(Result):
    """Phonon frequencies (and eigenvectors) of a crystal at a set of wave vectors (a `vibra._results.Result`).

    Attributes
    ----------
    qpoints : (n_q, 3) ndarray
        Wave vectors in fractional coordinates of the reciprocal lattice.
    omega : (n_q, n_branches) ndarray
        Angular frequencies, ascending per q, in rad per time unit of `units`; an unstable
        mode is -|omega| (as `vibra.Modes.omega`).
    omega_error : (n_q, n_branches) ndarray
        |omega - omega_true| <= omega_error: for eigenvalues of D(q), LAPACK's (3n + 32) eps ||D(q)||_inf
        plus the rounding of forming D(q) (`_assembly_error`) plus the non-Hermitian part removed
        (`non_hermitian`), through the signed square root
        (`vibra.solvers.common.omega_and_error`); for refined q-points, the factor's bound.
    vectors : (n_q, 3 n_atoms, n_branches) ndarray of complex, or None
        Mass-weighted orthonormal eigenvectors of D(q) as columns (dof 3 i + a is atom i, axis a),
        in the phase convention `phase`; None when not asked.
    masses : (n_atoms,) ndarray
        Atomic masses, in the mass unit (for `displacements`).
    phase : str
        ``"positions"`` (phonopy's) or ``"cell"``.
    units : UnitSystem
        The crystal's units.
    path : str
        How they were solved: ``"hermitian-eigh"`` (stacked eigenvalues of D(q)), with
        ``" + spring-svd"`` when some q-points were re-solved through the spring factor
        (`refined`).
    refined : (n_q,) ndarray of bool or None
        The q-points re-solved through the spring factor (`vibra.crystals.factor`: singular
        values, relative accuracy kept near Gamma) because the eigenvalues of D(q) missed
        HIGH_RTOL there; None when not checked (``accuracy="fast"`` or no springs).
    non_hermitian : (n_q,) ndarray or None
        A bound on ||(D - D^H) / 2||_F at each q (`Assembly.skew`), in 1 / time unit^2: the part
        of D(q) removed to solve its Hermitian part (as phonopy does), nonzero when the force
        constants break the index symmetry (`Crystal.index_asymmetry`); included in `omega_error`.
    """

    STORED = {"qpoints": stored(("n_q", 3)), "omega": stored(("n_q", "n_branches")),  # (vibra._results)
              "omega_error": stored(("n_q", "n_branches")), "masses": stored(("n_atoms",)),
              "vectors": stored(("n_q", ("n_atoms", 3), "n_branches"), kind="complex", optional=True),
              "refined": stored(("n_q",), kind="bool", optional=True), "non_hermitian": stored(("n_q",), optional=True)}
    AXIS, NOUNS = "n_q", ("q-point", "q-points")
    qpoints: NDArray[np.float64]
    omega: NDArray[np.float64]
    omega_error: NDArray[np.float64]
    vectors: NDArray[np.complex128] | None
    masses: NDArray[np.float64]
    phase: str
    units: UnitSystem
    path: str = "hermitian-eigh"
    refined: NDArray[np.bool_] | None = None
    non_hermitian: NDArray[np.float64] | None = None

    def _repr_parts(self) -> tuple[str, ...]:
        skew = 0.0 if self.non_hermitian is None else float(np.max(self.non_hermitian, initial=0.0))
        return (f"{self._size()} x {self.omega.shape[1]} branches", frequency_span(self.omega, self.units),
                "with vectors" if self.vectors is not None else "", f"phase {self.phase!r}",
                "" if self.refined is None else f"{int(np.count_nonzero(self.refined))} refined",
                f"non-Hermitian part {skew:.2g} removed" if skew > 0 else "")

    def displacements(self) -> NDArray[np.complex128]:
        """(n_q, 3 n_atoms, n_branches) physical displacement patterns M^-1/2 e, in length / sqrt(mass)."""
        if self.vectors is None:
            raise ValueError("these phonons were computed without eigenvectors; ask with vectors=True "
                             "(or use Crystal.modes_at)")
        return self.vectors / np.sqrt(np.repeat(self.masses, 3))[None, :, None]

    def frequencies_thz(self) -> NDArray[np.float64]:
        """(n_q, n_branches) signed ordinary frequencies omega / 2 pi, in THz."""
        return self.units.omega_to_thz(self.omega)

    def wavenumbers_cm1(self) -> NDArray[np.float64]:
        """(n_q, n_branches) signed wavenumbers omega / (2 pi c), in cm^-1."""
        return self.units.omega_to_cm1(self.omega)


# ---------------------------------------------------------------------- validation
def check_qpoints(qpoints: ArrayLike, name: str = "qpoints") -> NDArray[np.float64]:
    """(n_q, 3) finite fractional wave vectors (a single (3,) q is taken as one row)."""
    q = _validate.real_array(qpoints, name, ndim=(1, 2))
    q = q[None, :] if q.ndim == 1 else q
    if q.shape[1] != 3 or q.shape[0] == 0:
        raise ValueError(f"{name} must have shape (n_q, 3) with n_q >= 1 (fractional reciprocal coordinates), "
                         f"got {q.shape}")
    return q


def _check_phase(phase: str) -> str:
    return _validate.choice(phase, "phase", PHASES)


#: A fractional wave-vector component along a vacuum axis above this is refused (a 1-D or 2-D
#: crystal has no Bloch wave vector there; its bands would be flat along it).
VACUUM_Q_ATOL = 1e-12


def check_periodic_qpoints(crystal: Crystal, q: NDArray[np.float64], name: str = "qpoints") -> None:
    """Refuse wave vectors with a component along a vacuum axis of `crystal`, naming the first."""
    for axis in range(3):
        if crystal.periodic[axis]:
            continue
        off = np.abs(q[:, axis]) > VACUUM_Q_ATOL
        if off.any():
            k = int(np.argmax(off))
            raise ValueError(f"{name}[{k}] is {np.round(q[k], 12).tolist()}: component {axis} lies along a vacuum axis "
                             f"of {crystal.name!r} (periodic {tuple(crystal.periodic)}); wave vectors of a 1-D or 2-D "
                             "crystal lie along its periodic axes only (that component must be 0)")


# ---------------------------------------------------------------------- assembly
@dataclass(frozen=True, eq=False)
class Assembly:
    """What D(q) is made of, independent of q: the force constants' Hermitian part by lattice translation.

    D_cell(q) = sum_R A_R exp(2 pi i q . R) with A_R the (3n, 3n) mass-weighted sum of the blocks
    of every term with translation R, after the index symmetry is imposed term by term:
    A_R = (Phi(R) + Phi(-R)^T) / 2, which makes D(q) Hermitian at every q as phonopy's
    (D + D^H) / 2 does, once instead of per q-point. The positions phase
    (phonopy's) is D_pos = P^H D_cell P with P = diag(exp(2 pi i q . x_j)). One phase per
    translation, not per term, and one dense product per chunk of q-points: the arithmetic of a
    term-by-term sum (issue 42: the earlier (n_terms, (3n)^2) product cost 2.2x phonopy's time on
    SnO2's 18 branches).

    Since A_-R = A_R^T, each pair +-R is one phase: D_cell(q) = A_0 + sum_{R in half}
    [cos(2 pi q . R) (A_R + A_R^T) + i sin(2 pi q . R) (A_R - A_R^T)], half the products.

    Attributes
    ----------
    translations : (n_h, 3) ndarray
        One of each pair +-R of the nonzero lattice translations (the one whose first nonzero
        component is positive), in cells.
    symmetric, antisymmetric : (n_h, (3n)^2) ndarray
        A_R + A_R^T and A_R - A_R^T flattened row-major, in 1 / time unit^2.
    zero : ((3n)^2,) ndarray
        A_0, real symmetric, in 1 / time unit^2.
    fractional : (n_atoms, 3) ndarray
        The atoms' fractional positions x_j (for the positions phase).
    cartesian : (n_h, 3) ndarray
        R @ cell, in the length unit (for dD/dk).
    cell : (3, 3) ndarray
        The crystal's lattice vectors as rows, in the length unit.
    error : float
        Bound on ||D~ - D||_2 from forming D in floating point (`_assembly_error`), 1 / time unit^2.
    skew : float
        ||sum_R |S_R| ||_F with S_R = (Phi(R) - Phi(-R)^T) / 2 mass-weighted: a bound, at every q,
        on the Frobenius norm of the anti-Hermitian part removed, 1 / time unit^2 (0 when the
        force constants obey the index symmetry).
    """

    translations: NDArray[np.float64]
    symmetric: NDArray[np.float64]
    antisymmetric: NDArray[np.float64]
    zero: NDArray[np.float64]
    fractional: NDArray[np.float64]
    cartesian: NDArray[np.float64]
    cell: NDArray[np.float64]
    error: float
    skew: float

    @property
    def n3(self) -> int:
        return int(round(np.sqrt(self.zero.shape[0])))


def assembly(crystal: Crystal) -> Assembly:
    """The `Assembly` of `crystal`'s force constants (their Hermitian part grouped by translation)."""
    fc = crystal.require_force_constants()
    n = crystal.n_atoms
    n3 = 3 * n
    keys = np.column_stack([fc.first, fc.second, fc.translations]).astype(np.int64)
    partners = np.column_stack([fc.second, fc.first, -fc.translations]).astype(np.int64)
    table, inverse = np.unique(np.vstack([keys, partners]), axis=0, return_inverse=True)
    inverse = inverse.ravel()
    summed = np.zeros((table.shape[0], 3, 3))
    np.add.at(summed, inverse[:fc.n_terms], fc.blocks)
    # the partner of each key of the table: (j, i, -R)
    mirrored = np.column_stack([table[:, 1], table[:, 0], -table[:, 2:]])
    _, located = np.unique(np.vstack([table, mirrored]), axis=0, return_inverse=True)  # the same sorted rows
    partner = located.ravel()[table.shape[0]:]
    transposed = np.transpose(summed[partner], (0, 2, 1))
    weight = 1.0 / np.sqrt(crystal.masses[table[:, 0]] * crystal.masses[table[:, 1]])[:, None, None]
    hermitian = (summed + transposed) / 2.0 * weight
    skew_blocks = np.abs(summed - transposed) / 2.0 * weight
    translations, which = np.unique(table[:, 2:], axis=0, return_inverse=True)
    which = which.ravel()
    axis = np.arange(3)
    entries = ((3 * table[:, 0, None, None] + axis[None, :, None]) * n3
               + 3 * table[:, 1, None, None] + axis[None, None, :]).reshape(table.shape[0], 9)
    blocks = np.zeros((translations.shape[0], n3 * n3))
    np.add.at(blocks, (np.repeat(which, 9), entries.ravel()), hermitian.reshape(-1))
    skew_matrix = np.zeros(n3 * n3)
    np.add.at(skew_matrix, entries.ravel(), skew_blocks.reshape(-1))
    absolute = np.abs(blocks).sum(axis=0).reshape(n3, n3)
    reach = float(np.abs(translations).sum(axis=1).max()) if translations.size else 0.0
    error = _assembly_error(absolute, translations.shape[0], reach)
    nonzero = np.abs(translations).max(axis=1) > 0
    leading = translations[np.arange(translations.shape[0]), np.argmax(translations != 0, axis=1)]
    half = nonzero & (leading > 0)
    zero = blocks[~nonzero].sum(axis=0) if (~nonzero).any() else np.zeros(n3 * n3)
    forward = blocks[half]
    # A_-R = A_R^T by construction (the table holds every partner), so the pair needs A_R alone
    backward = forward.reshape(-1, n3, n3).transpose(0, 2, 1).reshape(-1, n3 * n3)
    kept = translations[half].astype(float)
    return Assembly(translations=kept, symmetric=forward + backward, antisymmetric=forward - backward, zero=zero,
                    fractional=crystal.fractional, cartesian=kept @ crystal.cell, cell=crystal.cell, error=error,
                    skew=float(np.linalg.norm(skew_matrix)))


def _assembly_error(absolute: NDArray[np.float64], n_translations: int, reach: float) -> float:
    """Bound on ||D~ - D||_2 from forming D: each entry sums its translations' phases times blocks.

    (n_R + 8 + pi (max_R ||R||_1 + 3)) eps times ||sum_R |A_R| ||_inf, the absolute-value matrix
    of the terms (>= ||D||: near Gamma D is small by cancellation while this is not). The LAPACK
    bound alone, eps ||D~||, would miss it. n_R: the sum over translations; 8: the two phase
    factors of the positions phase; pi ||R||_1 and 3 pi: the rounding of the phase angles
    2 pi q . R and 2 pi q . x_j for q reduced into the first zone (|q_k| <= 1/2,
    `reduce_qpoints`): far from it the angles, and their rounding, would grow with |q|.
    """
    return float((n_translations + 8 + np.pi * (reach + 3.0)) * EPS * absolute.sum(axis=1).max())


def _chunks(n_q: int, n_translations: int, n3: int) -> Iterator[slice]:
    size = max(1, CHUNK_ENTRIES // max(1, 2 * n_translations + 3 * n3 * n3))
    for start in range(0, n_q, size):
        yield slice(start, min(n_q, start + size))


def lattice_phases(q: NDArray[np.float64], translations: NDArray[np.float64]) -> NDArray[np.complex128]:
    """(n_q, n_R) exp(2 pi i q . R) as products of per-axis phases exp(2 pi i q_k m), |m| <= max |R_k|.

    3 (2 M + 1) sines and cosines per q instead of n_R: each factor is within ~eps (1 + pi |m|)
    of exact for |q_k| <= 1/2, the same as the phase angle's own rounding (`_assembly_error`).
    """
    if translations.shape[0] == 0:
        return np.ones((q.shape[0], 0), dtype=complex)
    steps = translations.astype(np.int64)
    reach = int(np.abs(steps).max())
    orders = np.arange(-reach, reach + 1)
    axis = np.exp(2j * np.pi * q[:, :, None] * orders[None, None, :])  # (n_q, 3, 2 M + 1)
    index = steps + reach
    return axis[:, 0, index[:, 0]] * axis[:, 1, index[:, 1]] * axis[:, 2, index[:, 2]]


def _matrices(parts: Assembly, q: NDArray[np.float64], phase: str,
              direction: NDArray[np.float64] | None = None) -> NDArray[np.complex128]:
    """(n_q, 3n, 3n) D(q) (or dD/dk along the Cartesian unit `direction`) for q in the first zone."""
    n3 = parts.n3
    phases = lattice_phases(q, parts.translations)
    cos, sin = phases.real, phases.imag
    matrices = np.empty((q.shape[0], n3 * n3), dtype=complex)
    if direction is None:
        matrices.real = cos @ parts.symmetric
        matrices.real += parts.zero
        matrices.imag = sin @ parts.antisymmetric
    else:  # d/dk: i w_R (A_R e^{iqR} - A_R^T e^{-iqR}) = -w sin (A + A^T) + i w cos (A - A^T)
        weight = parts.cartesian @ direction
        matrices.real = -(sin * weight) @ parts.symmetric
        matrices.imag = (cos * weight) @ parts.antisymmetric
    matrices = matrices.reshape(-1, n3, n3)
    if phase == "positions":
        atoms = np.exp(2j * np.pi * (q @ parts.fractional.T)).repeat(3, axis=1)  # (n_q, 3n)
        if direction is not None:  # the atoms' phases depend on k too: + i ((x_j - x_i) . n) D_cell
            value = _matrices(parts, q, "cell")
            offset = np.repeat((parts.fractional @ parts.cell) @ direction, 3)
            matrices = matrices + 1j * (offset[None, None, :] - offset[None, :, None]) * value
        matrices = np.conj(atoms)[:, :, None] * matrices * atoms[:, None, :]
    return matrices


#: The 27 lattice vectors around the nearest one (`brillouin_qpoints`).
_SHIFTS = np.array([(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1)], dtype=float)


def brillouin_qpoints(qpoints: NDArray[np.float64], reciprocal: NDArray[np.float64]
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(q - G, G): each q moved into the first Brillouin zone (Wigner-Seitz cell of the reciprocal lattice).

    For a polar crystal, whose truncated sums over G are not periodic in q: a q already in the
    zone, or on its boundary, is kept as given (as phonopy evaluates it, so band paths agree with
    phonopy's); one farther out is moved to its nearest image.
    """
    base = np.rint(qpoints)
    metric = reciprocal @ reciprocal.T                                         # |x B|^2 = x M x
    offset = qpoints - base                                                    # in [-1/2, 1/2]
    # |(offset - s) B|^2 for the 27 shifts s at once: x M x - 2 x M s + s M s (one small product)
    squared = (np.einsum("qa,ab,qb->q", offset, metric, offset)[:, None] - 2.0 * (offset @ (metric @ _SHIFTS.T))
               + np.einsum("sa,ab,sb->s", _SHIFTS, metric, _SHIFTS)[None, :])
    nearest = squared.min(axis=1)
    best = np.argmax(squared <= nearest[:, None] * (1.0 + 2e-12), axis=1)  # of equal images, the first shift
    own = np.einsum("qa,ab,qb->q", qpoints, metric, qpoints)
    keep = own <= nearest * (1.0 + 2e-12)
    lattice = np.where(keep[:, None], 0.0, base + _SHIFTS[best])
    return qpoints - lattice, lattice


def reduce_qpoints(qpoints: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(q - G, G): each q moved into the first zone's cube, components in [-1/2, 1/2], and the integer G.

    D(q + G) is D(q) up to the unitary phase P(G) = diag(exp(2 pi i G . x_j)) (the identity in
    the cell phase), so eigenvalues are computed at q - G, where the phases 2 pi q . d keep
    their accuracy: at q = 10^4 + 0.3 the phase angles would lose 10^4 eps each.
    """
    lattice = np.rint(qpoints)
    return qpoints - lattice, lattice


def _shift_phases(crystal: Crystal, lattice: NDArray[np.float64]) -> NDArray[np.complex128] | None:
    """(n_q, 3n) exp(-2 pi i G . x_j) per dof, the positions-phase factor between D(q) and D(q - G); None when G = 0."""
    if not lattice.any():
        return None
    frac = crystal.fractional
    return np.exp(-2j * np.pi * (lattice @ frac.T)).repeat(3, axis=1)


def dynamical_matrices(crystal: Crystal, qpoints: ArrayLike, *, phase: str = "positions",
                       q_direction: ArrayLike | None = None, analytic: bool = False) -> NDArray[np.complex128]:
    """(n_q, 3 n_atoms, 3 n_atoms) dynamical matrices D(q), in 1 / time unit^2 (Hermitian).

    Parameters
    ----------
    crystal : Crystal
        With force constants (and, for a polar crystal, its non-analytic correction `nac`).
    qpoints : (n_q, 3) array_like
        Fractional reciprocal coordinates.
    phase : {"positions", "cell"}
        The phase convention (module docstring).
    q_direction : (3,) array_like, optional
        A polar crystal's direction of approach to Gamma (fractional), phonopy's nac_q_direction.
    analytic : bool
        The force constants' D(q) alone, without a polar crystal's correction (what the
        correction itself adds to).
    """
    q = check_qpoints(qpoints)
    phase = _check_phase(phase)
    check_periodic_qpoints(crystal, q)
    polar = crystal.nac is not None and not analytic
    reduced, lattice = brillouin_qpoints(q, crystal.reciprocal) if polar else reduce_qpoints(q)
    if polar:  # its truncated sum over G is not periodic: the first Brillouin zone, as phonopy's paths
        matrices = np.asarray(crystal.nac.dynamical_matrices(crystal, reduced, q_direction=q_direction, phase=phase))
    else:
        matrices = _matrices(crystal.assembly, reduced, phase)
    shift = _shift_phases(crystal, lattice) if phase == "positions" else None
    if shift is not None:  # D(q) = P(G)^H D(q - G) P(G) in the positions phase
        matrices = shift[:, :, None] * matrices * np.conj(shift)[:, None, :]
    return matrices


def derivative_matrices(crystal: Crystal, qpoints: ArrayLike, direction: ArrayLike, *,
                        phase: str = "positions") -> NDArray[np.complex128]:
    """(n_q, 3n, 3n) dD/dk along the Cartesian unit `direction`, k the Cartesian wave vector.

    Analytic: d/dk exp(i k . r) = i (r . n) exp(i k . r), r the Cartesian vector of the term.
    In 1 / time unit^2 per (rad / length), i.e. length / time unit^2. For a polar crystal, central
    differences of D(q) with its correction, a step of NAC_DERIVATIVE_STEP |b|_min.
    """
    q = check_qpoints(qpoints)
    phase = _check_phase(phase)
    check_periodic_qpoints(crystal, q)
    n = unit_direction(direction)
    if crystal.nac is not None:  # the correction's dD/dk by central differences, as phonopy's group velocities
        shortest = float(np.linalg.norm(crystal.reciprocal, axis=1).min())
        reduced, _ = reduce_qpoints(q)
        distance = np.linalg.norm(reduced @ crystal.reciprocal, axis=1)  # from the nearest Gamma, rad / length
        step = NAC_DERIVATIVE_STEP * np.maximum(distance, 1e-3 * shortest)  # the correction varies on |k|'s scale
        dq = step[:, None] * (crystal.cell @ n)[None, :] / (2.0 * np.pi)  # k = 2 pi q inv(cell)^T: dq = dk cell n / 2 pi
        return (dynamical_matrices(crystal, q + dq, phase=phase)
                - dynamical_matrices(crystal, q - dq, phase=phase)) / (2.0 * step)[:, None, None]
    reduced, lattice = reduce_qpoints(q)
    matrices = _matrices(crystal.assembly, reduced, phase, direction=n)
    shift = _shift_phases(crystal, lattice) if phase == "positions" else None
    if shift is not None:
        matrices = shift[:, :, None] * matrices * np.conj(shift)[:, None, :]
    return matrices


def unit_direction(direction: ArrayLike) -> NDArray[np.float64]:
    n = _validate.real_array(direction, "direction", ndim=1)
    if n.shape != (3,):
        raise ValueError(f"direction must be a Cartesian 3-vector, got shape {n.shape}")
    norm = float(np.linalg.norm(n))
    if norm == 0.0:
        raise ValueError("direction is the zero vector; give a Cartesian direction such as [1, 0, 0]")
    return n / norm


# ---------------------------------------------------------------------- solves
def solve_plan(crystal: Crystal, n_q: int, *, vectors: bool, accuracy: str = "high",
               max_seconds: float | None = None, max_memory: float | None = None, guarded: bool = True) -> SolvePlan:
    """The solver registry's plan of `phonons` at `n_q` wave vectors (`problem.bloch_problem`: the
    ``hermitian-eigh`` path and its estimate from sizes), guarded as every solve is
    (`budget.guard`: `ResourceLimitError` over `max_seconds` / `max_memory`, naming cheaper
    requests) unless `guarded` is False (a cost line: ``vibra validate``)."""
    parts, n3 = crystal.assembly, crystal.n_branches
    polar = crystal.nac
    g_vectors = 0 if polar is None or polar.g_vectors is None else polar.g_vectors.shape[0]
    # per q: the phases' GEMMs over the force constants, and a polar crystal's Ewald sum over its G vectors
    # (~1e-9 s per G and entry of D measured on phonopy's NaCl, ZnO, SnO2 and MgO: half an entry's rate)
    entries = 2 * parts.symmetric.size + parts.zero.size + g_vectors * n3 * n3 // 2
    springs = crystal.springs is not None and uses_springs(accuracy)
    plan = plan_problem(bloch_problem(n3, n_q, vectors=vectors, accuracy=accuracy, entries=entries, springs=springs),
                        "auto")
    if guarded:
        guard(plan.cost, n_dof=n3, max_memory=max_memory, max_seconds=max_seconds,
              alternatives=["fewer wave vectors (a coarser mesh, fewer points per segment)"] + (
                  ["vectors=False"] if vectors else []), subject=f"D(q) has {counted(n3, 'branch')}")
    return plan


def phonons(crystal: Crystal, qpoints: ArrayLike, *, vectors: bool = False, phase: str = "positions",
            accuracy: str = "high", q_direction: ArrayLike | None = None, max_seconds: float | None = None,
            max_memory: float | None = None) -> Phonons:
    """Frequencies (and eigenvectors) at every q of `qpoints`, solved as stacked Hermitian problems.

    Parameters
    ----------
    crystal : Crystal
        With force constants.
    qpoints : (n_q, 3) array_like
        Wave vectors, fractional coordinates of the reciprocal lattice (phonopy's convention).
    vectors : bool
        Also compute the eigenvectors.
    phase : {"positions", "cell"}
        Phase convention of D(q) and of the eigenvectors (module docstring).
    accuracy : {"high", "fast"}
        ``"fast"``: eigenvalues of D(q), absolute accuracy ~eps ||D|| (relative eps / (|q| a)^2
        near Gamma). ``"high"`` (default): the same, then for a spring model every q-point
        whose bound misses HIGH_RTOL relative (near Gamma, or a zero mode) is re-solved through
        its spring factor (`vibra.crystals.factor`: eps-level relative accuracy, never an
        imaginary mode); other force constants keep the eigenvalues and their bound. A polar
        crystal (with `nac`) keeps the eigenvalues of its corrected D(q).
    q_direction : (3,) array_like, optional
        For a polar crystal, the direction (fractional) from which Gamma is approached: at q =
        Gamma it selects the LO-TO split of that direction (phonopy's nac_q_direction);
        without it Gamma has no correction.
    max_seconds, max_memory : float, optional
        Limits on the solve's estimate (`solve_plan`), as for `vibra.normal_modes`.

    Returns
    -------
    Phonons

    Raises
    ------
    ValueError
        `qpoints` not (n_q, 3) or not finite, or with a component along a vacuum axis; an unknown
        `phase` or `accuracy` (or "certified"); a crystal without force constants.
    ResourceLimitError
        The estimate exceeds `max_seconds` or `max_memory` (before any work).
    """
    q = check_qpoints(qpoints)
    phase = _check_phase(phase)
    accuracy = check_accuracy(accuracy, offered=ACCURACY, by="phonons")
    crystal.require_force_constants()
    check_periodic_qpoints(crystal, q)
    plan = solve_plan(crystal, q.shape[0], vectors=vectors, accuracy=accuracy, max_seconds=max_seconds,
                      max_memory=max_memory)
    solve = BY_NAME[plan.path].run
    parts = crystal.assembly
    n3 = crystal.n_branches
    values = np.empty((q.shape[0], n3))
    error = np.empty_like(values)
    basis = np.empty((q.shape[0], n3, n3), dtype=complex) if vectors else None
    polar = crystal.nac
    reduced, lattice = reduce_qpoints(q) if polar is None else brillouin_qpoints(q, crystal.reciprocal)
    if polar is not None:  # its truncated sum over G is not periodic in q: the first Brillouin zone (as given there)
        g_vectors = 0 if polar.g_vectors is None else polar.g_vectors.shape[0]
    # a polar crystal's D(q) comes whole from its correction, which forms its parts once per call: larger chunks
    chunks = (_chunks(q.shape[0], parts.translations.shape[0], n3) if polar is None else
              (slice(start, min(q.shape[0], start + POLAR_CHUNK // (3 * n3 * n3) + 1))
               for start in range(0, q.shape[0], POLAR_CHUNK // (3 * n3 * n3) + 1)))
    for part in chunks:
        if polar is None:
            matrices = _matrices(parts, reduced[part], phase)
        else:
            matrices = polar.dynamical_matrices(crystal, reduced[part], q_direction=q_direction, phase=phase)
        values[part], chunk_basis, error[part] = solve(plan.problem, matrices)
        error[part] += parts.error + parts.skew
        if polar is not None:  # the Ewald sum's rounding: each entry sums n_G terms
            error[part] += ((g_vectors + 16) * EPS * np.abs(matrices).sum(axis=-1).max(axis=-1))[:, None]
        if basis is not None:
            basis[part] = chunk_basis
    omega, omega_error = (x.reshape(values.shape) for x in omega_and_error(values.ravel(), error.ravel()))
    refined = None
    path = plan.path if polar is None else f"{plan.path} + nac-{polar.method}"
    if uses_springs(accuracy) and crystal.springs is not None and polar is None:
        refined = (omega_error > HIGH_RTOL * np.abs(omega)).any(axis=1)
        if refined.any():
            path += " + spring-svd"
            omega[refined], better, omega_error[refined] = singular_frequencies(
                crystal, reduced[refined], crystal.springs, vectors=vectors)
            if basis is not None and better is not None:
                if phase == "positions":  # the factor is in the cell phase: v_pos = conj(P) v_cell
                    better *= np.exp(-2j * np.pi * reduced[refined] @ crystal.fractional.T
                                     ).repeat(3, axis=1)[:, :, None]
                basis[refined] = better
    shift = _shift_phases(crystal, lattice) if phase == "positions" and basis is not None else None
    if basis is not None and shift is not None:  # eigenvectors of D(q) = P(G)^H D(q - G) P(G)
        basis *= shift[:, :, None]
    return Phonons(qpoints=q, omega=omega, omega_error=omega_error, vectors=basis, masses=crystal.masses,
                   phase=phase, units=crystal.units, path=path, refined=refined,
                   non_hermitian=np.full(q.shape[0], parts.skew))
