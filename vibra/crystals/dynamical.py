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
chunks of q bounded in memory, then stacked Hermitian solves (`vibra.solvers.standard.hermitian`).
No Python loop runs per q.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Iterator, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra import _validate
from vibra._frozen import freeze_arrays, frequency_span, short_repr
from vibra.crystals.factor import singular_frequencies
from vibra.solvers.common import EPS, omega_and_error
from vibra.solvers.standard.hermitian import hermitian_stack
from vibra.units import UnitSystem

if TYPE_CHECKING:
    from vibra.crystals.force_constants import CrystalLike as Crystal  # the protocol: no import cycle

__all__ = ["PHASES", "Phonons", "SupercellMode", "phonons", "supercell_mode", "conventional_cube", "CUBIC_CENTRINGS", "dynamical_matrices", "derivative_matrices", "group_velocities",
           "check_qpoints", "eigenvalue_slopes"]

#: The phase conventions of D(q) (module docstring).
PHASES: tuple[str, ...] = ("positions", "cell")

#: The accuracy levels of `phonons` (the crystals' subset of vibra's levels).
ACCURACY: tuple[str, ...] = ("high", "fast")

#: accuracy="high" re-solves a spring model's q-point through its factor when a bound of the
#: eigenvalues of D(q) exceeds this relative to omega (docs/architecture.md, "Accuracy": ~1e-10 where the structure allows).
HIGH_RTOL = 1e-10

#: Entries per chunk of the stacked D(q) and phases (~1 MiB of complex D(q); the peak is a few
#: times that): small enough that frequencies on a path take no more memory than phonopy's
#: run_qpoints, large enough that the GEMMs and stacked solves run at full speed
#: (benchmarks/RESULTS.md, "Crystals against phonopy": memory).
CHUNK_ENTRIES = 1 << 16

#: Two eigenvalues within this many of their error bounds are one degenerate level.
DEGENERACY_BOUNDS = 1e4


@dataclass(frozen=True, eq=False)
class Phonons:
    """Phonon frequencies (and eigenvectors) of a crystal at a set of wave vectors.

    Attributes
    ----------
    qpoints : (n_q, 3) ndarray
        Wave vectors in fractional coordinates of the reciprocal lattice.
    omega : (n_q, n_branches) ndarray
        Angular frequencies, ascending per q, in rad per time unit of `units`; an unstable
        mode is -|omega| (as `vibra.Modes.omega`).
    omega_error : (n_q, n_branches) ndarray
        |omega - omega_true| <= omega_error: for eigenvalues of D(q), LAPACK's (3n + 32) eps ||D(q)||_inf
        plus the rounding of forming D(q) (`_assembly_error`), through the signed square root
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
    """

    qpoints: NDArray[np.float64]
    omega: NDArray[np.float64]
    omega_error: NDArray[np.float64]
    vectors: NDArray[np.complex128] | None
    masses: NDArray[np.float64]
    phase: str
    units: UnitSystem
    path: str = "hermitian-eigh"
    refined: NDArray[np.bool_] | None = None

    def __post_init__(self) -> None:
        freeze_arrays(self)

    def __repr__(self) -> str:
        n_q, n_branches = self.omega.shape
        refined = "" if self.refined is None else f"{int(np.count_nonzero(self.refined))} refined"
        return short_repr(self, f"{n_q} q-points x {n_branches} branches", frequency_span(self.omega, self.units),
                          "with vectors" if self.vectors is not None else "", f"phase {self.phase!r}",
                          f"path {self.path!r}", refined, f"{self.units.name} units")

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
    if q.ndim == 1:
        q = q[None, :]
    if q.shape[1] != 3 or q.shape[0] == 0:
        raise ValueError(f"{name} must have shape (n_q, 3) with n_q >= 1 (fractional reciprocal coordinates), "
                         f"got {q.shape}")
    return q


def _check_phase(phase: str) -> str:
    return _validate.choice(phase, "phase", PHASES)


# ---------------------------------------------------------------------- assembly
def _term_vectors(crystal: Crystal, phase: str) -> NDArray[np.float64]:
    """(n_terms, 3) fractional vectors d of the phase exp(2 pi i q . d)."""
    fc = crystal.require_force_constants()
    d = fc.translations.astype(float)
    if phase == "positions":
        frac = crystal.fractional
        d = d + frac[fc.second] - frac[fc.first]
    return d


def _scatter(crystal: Crystal) -> NDArray[np.float64]:
    """(n_terms, (3n)^2) A: row t holds Phi_t / sqrt(m_i m_j) at the entries of block (i, j)."""
    fc = crystal.require_force_constants()
    n3 = 3 * crystal.n_atoms
    scaled = fc.blocks / np.sqrt(crystal.masses[fc.first] * crystal.masses[fc.second])[:, None, None]
    axis = np.arange(3)
    rows = 3 * fc.first[:, None, None] + axis[None, :, None]
    cols = 3 * fc.second[:, None, None] + axis[None, None, :]
    scatter = np.zeros((fc.n_terms, n3 * n3))
    scatter[np.arange(fc.n_terms)[:, None, None], rows * n3 + cols] = scaled
    return scatter


def _assembly_error(crystal: Crystal, scatter: NDArray[np.float64]) -> float:
    """Bound on ||D~ - D||_2 from forming D: each entry sums its terms' phases times blocks.

    (terms per entry + 4) eps times ||sum_t |A_t| ||_inf, the absolute-value matrix of the terms
    (>= ||D||: near Gamma D is small by cancellation while this is not). The LAPACK bound alone,
    eps ||D~||, would miss it.
    """
    fc = crystal.require_force_constants()
    n3 = crystal.n_branches
    absolute = np.abs(scatter).sum(axis=0).reshape(n3, n3)
    pairs = fc.first * crystal.n_atoms + fc.second
    per_entry = int(np.bincount(pairs).max()) if pairs.size else 0
    return float((per_entry + 4) * EPS * absolute.sum(axis=1).max())


def _chunks(n_q: int, n_terms: int, n3: int) -> Iterator[slice]:
    size = max(1, CHUNK_ENTRIES // max(1, n_terms + 2 * n3 * n3))
    for start in range(0, n_q, size):
        yield slice(start, min(n_q, start + size))


def _assemble(phases_real: NDArray[np.float64], phases_imag: NDArray[np.float64],
              scatter: NDArray[np.float64], n3: int) -> NDArray[np.complex128]:
    matrices = np.empty((phases_real.shape[0], n3 * n3), dtype=complex)
    matrices.real = phases_real @ scatter
    matrices.imag = phases_imag @ scatter
    return matrices.reshape(-1, n3, n3)


def dynamical_matrices(crystal: Crystal, qpoints: ArrayLike, *, phase: str = "positions"
                       ) -> NDArray[np.complex128]:
    """(n_q, 3 n_atoms, 3 n_atoms) dynamical matrices D(q), in 1 / time unit^2.

    Parameters
    ----------
    crystal : Crystal
        With force constants.
    qpoints : (n_q, 3) array_like
        Fractional reciprocal coordinates.
    phase : {"positions", "cell"}
        The phase convention (module docstring).
    """
    q = check_qpoints(qpoints)
    phase = _check_phase(phase)
    d = _term_vectors(crystal, phase)
    scatter = _scatter(crystal)
    n3 = crystal.n_branches
    angle = 2.0 * np.pi * (q @ d.T)
    return _assemble(np.cos(angle), np.sin(angle), scatter, n3)


def derivative_matrices(crystal: Crystal, qpoints: ArrayLike, direction: ArrayLike, *,
                        phase: str = "positions") -> NDArray[np.complex128]:
    """(n_q, 3n, 3n) dD/dk along the Cartesian unit `direction`, k the Cartesian wave vector.

    Analytic: d/dk exp(i k . r) = i (r . n) exp(i k . r), r the Cartesian vector of the term.
    In 1 / time unit^2 per (rad / length), i.e. length / time unit^2.
    """
    q = check_qpoints(qpoints)
    phase = _check_phase(phase)
    n = _unit_direction(direction)
    d = _term_vectors(crystal, phase)
    weight = (d @ crystal.cell) @ n  # r . n for each term, in length
    scatter = _scatter(crystal)
    angle = 2.0 * np.pi * (q @ d.T)
    # i w e^{i angle} = -w sin + i w cos
    return _assemble(-np.sin(angle) * weight, np.cos(angle) * weight, scatter, crystal.n_branches)


def _unit_direction(direction: ArrayLike) -> NDArray[np.float64]:
    n = _validate.real_array(direction, "direction", ndim=1)
    if n.shape != (3,):
        raise ValueError(f"direction must be a Cartesian 3-vector, got shape {n.shape}")
    norm = float(np.linalg.norm(n))
    if norm == 0.0:
        raise ValueError("direction is the zero vector; give a Cartesian direction such as [1, 0, 0]")
    return n / norm


# ---------------------------------------------------------------------- solves
def phonons(crystal: Crystal, qpoints: ArrayLike, *, vectors: bool = False, phase: str = "positions",
            accuracy: str = "high") -> Phonons:
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
        imaginary mode); other force constants keep the eigenvalues and their bound.

    Returns
    -------
    Phonons

    Raises
    ------
    ValueError
        `qpoints` not (n_q, 3) or not finite; an unknown `phase`; a crystal without force constants.
    """
    q = check_qpoints(qpoints)
    phase = _check_phase(phase)
    accuracy = _validate.choice(accuracy, "accuracy", ACCURACY)
    crystal.require_force_constants()
    d = _term_vectors(crystal, phase)
    scatter = _scatter(crystal)
    n3 = crystal.n_branches
    assembly = _assembly_error(crystal, scatter)
    values = np.empty((q.shape[0], n3))
    error = np.empty_like(values)
    basis = np.empty((q.shape[0], n3, n3), dtype=complex) if vectors else None
    for part in _chunks(q.shape[0], d.shape[0], n3):
        angle = 2.0 * np.pi * (q[part] @ d.T)
        matrices = _assemble(np.cos(angle), np.sin(angle), scatter, n3)
        values[part], chunk_basis, error[part] = hermitian_stack(matrices, vectors=vectors)
        error[part] += assembly
        if basis is not None:
            basis[part] = chunk_basis
    omega, omega_error = (x.reshape(values.shape) for x in omega_and_error(values.ravel(), error.ravel()))
    refined = None
    path = "hermitian-eigh"
    if accuracy == "high" and crystal.springs is not None:
        refined = (omega_error > HIGH_RTOL * np.abs(omega)).any(axis=1)
        if refined.any():
            path += " + spring-svd"
            omega[refined], better, omega_error[refined] = singular_frequencies(
                crystal, q[refined], crystal.springs, vectors=vectors)
            if basis is not None and better is not None:
                if phase == "positions":  # the factor is in the cell phase: v_pos = conj(P) v_cell
                    better *= np.exp(-2j * np.pi * q[refined] @ crystal.fractional.T).repeat(3, axis=1)[:, :, None]
                basis[refined] = better
    return Phonons(qpoints=q, omega=omega, omega_error=omega_error, vectors=basis, masses=crystal.masses,
                   phase=phase, units=crystal.units, path=path, refined=refined)


def eigenvalue_slopes(derivative: NDArray[np.complex128], values: NDArray[np.float64],
                      basis: NDArray[np.complex128], error: NDArray[np.float64]
                      ) -> tuple[NDArray[np.float64], NDArray[np.complex128]]:
    """(n_q, n) d lambda / dk from dD/dk, with degenerate levels resolved, and the basis that goes with it.

    Within a degenerate level (eigenvalues within DEGENERACY_BOUNDS times their bounds) the
    slopes are the eigenvalues of V_g^H dD V_g (first-order degenerate perturbation theory),
    ascending, and the returned basis is rotated to diagonalise it: its columns are the
    branches that leave the degeneracy with those slopes.
    """
    projected = np.einsum("qia,qij,qjb->qab", basis.conj(), derivative, basis, optimize=True)
    slopes = np.einsum("qaa->qa", projected).real.copy()
    rotated = basis.copy()
    gap = np.diff(values, axis=1) <= DEGENERACY_BOUNDS * (error[:, 1:] + error[:, :-1])
    n = values.shape[1]
    for k in np.nonzero(gap.any(axis=1))[0]:
        start = 0
        while start < n:
            stop = start + 1
            while stop < n and gap[k, stop - 1]:
                stop += 1
            if stop - start > 1:
                block = projected[k, start:stop, start:stop]
                slopes[k, start:stop], turn = np.linalg.eigh(0.5 * (block + block.conj().T))
                rotated[k, :, start:stop] = basis[k, :, start:stop] @ turn
            start = stop
    return slopes, rotated


def group_velocities(crystal: Crystal, qpoints: ArrayLike, direction: ArrayLike) -> NDArray[np.float64]:
    """(n_q, n_branches) group velocities d omega / dk along a Cartesian `direction`, in length / time unit.

    Analytic: d omega / dk = (d lambda / dk) / (2 omega) with d lambda / dk from dD/dk
    (`eigenvalue_slopes`); where |omega| is within its error bound (the acoustic branches at
    Gamma) the velocity is reported as 0 (the slope there depends on the direction of approach:
    see `vibra.crystals.elastic.sound_velocities`).
    """
    q = check_qpoints(qpoints)
    n = _unit_direction(direction)
    result = phonons(crystal, q, vectors=True)
    derivative = derivative_matrices(crystal, q, n)
    values = np.sign(result.omega) * result.omega ** 2
    error = 2.0 * np.abs(result.omega) * result.omega_error + result.omega_error ** 2
    slopes, _ = eigenvalue_slopes(derivative, values, cast(NDArray[np.complex128], result.vectors), error)
    zero = np.abs(result.omega) <= result.omega_error
    return np.where(zero, 0.0, slopes / np.where(zero, 1.0, 2.0 * result.omega))


# ---------------------------------------------------------------------- one mode on a supercell
@dataclass(frozen=True, eq=False)
class SupercellMode:
    """One phonon written out on a supercell: what a render animates.

    The displacement of atom j in cell n is u_j(n) = Re[a_j exp(i (2 pi q . n - omega t))] with
    a_j = e_j / sqrt(m_j) (the cell-phase eigenvector), scaled so that max_j |a_j| = 1.

    Attributes
    ----------
    positions : (n_cells n_atoms, 3) ndarray
        Rest positions of the supercell's atoms, Cartesian, in the length unit; cell by cell.
    amplitudes : (n_cells n_atoms, 3) ndarray of complex
        Complex displacement of each atom (dimensionless, largest modulus 1).
    symbols : tuple of str
        The label of each atom.
    cell : (3, 3) ndarray
        The supercell's lattice vectors as rows, in the length unit.
    q : (3,) ndarray
        The wave vector, fractional coordinates of the reciprocal lattice.
    branch : int
        Branch index, 0 = lowest.
    omega : float
        Angular frequency, rad per time unit (imaginary as -|omega|).
    units : UnitSystem
    """

    positions: NDArray[np.float64]
    amplitudes: NDArray[np.complex128]
    symbols: tuple[str, ...]
    cell: NDArray[np.float64]
    q: NDArray[np.float64]
    branch: int
    omega: float
    units: UnitSystem

    def __post_init__(self) -> None:
        freeze_arrays(self)

    def __repr__(self) -> str:
        q = ", ".join(f"{x:.4g}" for x in self.q)
        return short_repr(self, f"branch {self.branch} at q ({q})", frequency_span([self.omega], self.units),
                          f"{len(self.positions)} atoms", f"{self.units.name} units")

    def displacements(self, phase: float) -> NDArray[np.float64]:
        """(n, 3) real displacements Re[a exp(-i phase)] at the phase omega t = `phase` (radians)."""
        return np.real(self.amplitudes * np.exp(-1j * phase))


#: Integer matrices P that turn a centred cubic lattice's primitive cell into its conventional
#: cube (P @ cell): face-centred (det 4) and body-centred (det 2), in the usual primitive setting.
CUBIC_CENTRINGS: tuple[NDArray[np.int64], ...] = (
    np.array([[-1, 1, 1], [1, -1, 1], [1, 1, -1]], dtype=np.int64),
    np.array([[0, 1, 1], [1, 0, 1], [1, 1, 0]], dtype=np.int64),
)


def conventional_cube(crystal: Crystal) -> NDArray[np.int64] | None:
    """(3, 3) integer P with P @ cell a cube (the conventional cell of an fcc or bcc lattice, or
    the identity for a simple cubic one), or None when the lattice is not cubic in that setting."""
    if not all(crystal.periodic):
        return None
    for matrix in (np.eye(3, dtype=np.int64), *CUBIC_CENTRINGS):
        rows = matrix @ crystal.cell
        lengths = np.linalg.norm(rows, axis=1)
        gram = rows @ rows.T
        if np.allclose(gram, np.diag(np.full(3, lengths[0] ** 2)), rtol=0.0, atol=1e-8 * lengths[0] ** 2):
            return matrix
    return None


def _supercell_matrix(supercell: ArrayLike, crystal: Crystal) -> NDArray[np.int64]:
    """(3, 3) integer supercell matrix from 3 sizes or a 3 x 3 matrix (rows: the supercell's lattice
    vectors in units of the crystal's), checked."""
    size = np.asarray(supercell)
    if size.shape == (3,):
        if not np.issubdtype(size.dtype, np.integer) or (size < 1).any() or (size > 12).any():
            raise ValueError(f"supercell must be 3 integers from 1 to 12 (cells along each lattice vector), "
                             f"got {supercell!r}")
        matrix = np.diag(size).astype(np.int64)
    elif size.shape == (3, 3) and np.issubdtype(size.dtype, np.integer):
        matrix = size.astype(np.int64)
        cells = abs(round(float(np.linalg.det(matrix))))
        if cells < 1 or cells > 12 ** 3:
            raise ValueError(f"supercell matrix {matrix.tolist()} holds {cells} cells; expected 1 to {12 ** 3}")
    else:
        raise ValueError(f"supercell must be 3 integers (cells along each lattice vector) or a 3 x 3 integer "
                         f"matrix, got {supercell!r}")
    for axis in range(3):
        if not crystal.periodic[axis] and (matrix[axis, axis] != 1 or np.count_nonzero(matrix[axis]) != 1
                                           or np.count_nonzero(matrix[:, axis]) != 1):
            raise ValueError(f"supercell[{axis}] is {matrix[axis].tolist()} along a vacuum axis; it must be 1 "
                             "(that axis unmixed)")
    return matrix


def _cells_in(matrix: NDArray[np.int64]) -> NDArray[np.int64]:
    """(|det|, 3) the lattice translations n (in cell units) inside the supercell `matrix` @ cell, ordered."""
    corners = np.array([[a, b, c] for a in (0, 1) for b in (0, 1) for c in (0, 1)]) @ matrix
    low, high = corners.min(axis=0), corners.max(axis=0)
    box = np.stack(np.meshgrid(*[np.arange(lo, hi + 1) for lo, hi in zip(low, high)], indexing="ij"),
                   axis=-1).reshape(-1, 3)
    fractional = box @ np.linalg.inv(matrix.astype(float))
    inside = ((fractional > -1e-9) & (fractional < 1.0 - 1e-9)).all(axis=1)
    return box[inside]


def supercell_mode(crystal: Crystal, q: ArrayLike, branch: int, supercell: ArrayLike) -> SupercellMode:
    """Branch `branch` at `q` written out on a `supercell` of the crystal (see `SupercellMode`).

    `supercell` is 3 sizes (cells along each lattice vector) or a 3 x 3 integer matrix S whose
    rows are the supercell's lattice vectors in the crystal's (S @ cell), e.g.
    ``2 * conventional_cube(crystal)`` for 2 x 2 x 2 conventional cubes of an fcc lattice.

    Raises
    ------
    ValueError
        q not 3 finite numbers; branch outside 0 .. n_branches - 1; a supercell that is not 3
        positive integers (at most 12 each) or an integer matrix of 1 to 12^3 cells, or that is
        not 1 (unmixed) along a vacuum axis.
    """
    point = check_qpoints(np.asarray(q, dtype=float).reshape(1, -1) if np.ndim(q) == 1 else q, "q")
    if point.shape[0] != 1:
        raise ValueError(f"q must be one wave vector (3 fractional coordinates), got shape {np.shape(q)}")
    index = _validate.count(branch, "branch", low=0, high=crystal.n_branches - 1)
    matrix = _supercell_matrix(supercell, crystal)
    result = phonons(crystal, point, vectors=True, phase="cell")
    assert result.vectors is not None
    vector = result.vectors[0][:, index].reshape(crystal.n_atoms, 3) / np.sqrt(crystal.masses)[:, None]
    cells = _cells_in(matrix)
    phase = np.exp(2j * np.pi * cells @ point[0])
    amplitudes = (phase[:, None, None] * vector[None, :, :]).reshape(-1, 3)
    largest = float(np.abs(amplitudes).max())
    if largest > 0:
        amplitudes = amplitudes / largest
    positions = (cells @ crystal.cell)[:, None, :] + crystal.positions[None, :, :]
    return SupercellMode(positions=positions.reshape(-1, 3), amplitudes=amplitudes,
                         symbols=tuple(crystal.symbols) * len(cells), cell=matrix @ crystal.cell,
                         q=point[0], branch=index, omega=float(result.omega[0, index]), units=crystal.units)
