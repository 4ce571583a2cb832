"""The non-analytic correction of polar crystals (LO-TO splitting), as phonopy makes it.

An ionic crystal's long-range dipole-dipole forces make D(q) non-analytic at Gamma: its limit
depends on the direction q^ of approach, and the longitudinal optical modes split from the
transverse ones. The correction needs the Born effective charges Z*_i (in e, phonopy's index
order Z*[i][a][b]: a the field, b the displacement) and the high-frequency dielectric tensor
eps (dimensionless), with factor = e^2 / (4 pi eps0) in the crystal's energy x length unit.
Two forms, both exactly as phonopy 4.10 builds them (`phonopy.harmonic.dynamical_matrix`,
``c/dynmat.c``), so that frequencies agree with phonopy's to rounding:

- ``"gonze"`` (Gonze & Lee, PRB 55, 10355 (1997); phonopy's default). The reciprocal Ewald sum

      C_ij(q) = f sum_G (K Z_i)(K Z_j)^T / (K eps K) exp(-K eps K / 4 Lambda^2) exp(2 pi i G.(r_i - r_j))
                - delta_ij C0_i,           K = q + G (Cartesian, no 2 pi), f = 4 pi factor / V,

  is subtracted from the supercell force constants at the commensurate points (brought into
  the first Brillouin zone) to give short-range force constants, whose D(q) is interpolated
  as any other and Hermitianised; C(q) / sqrt(m_i m_j) is then added back. The G = 0 term at
  q = Gamma needs a direction: q^ q^ / (q^ eps q^) without the Gaussian, or nothing. The
  G-vectors are those within phonopy's cutoff for 300 points, Lambda from it.
- ``"wang"`` (Wang et al., J. Phys.: Condens. Matter 22, 202201 (2010)). f / N (q Z_i)(q Z_j)^T
  / (q eps q) is added to every supercell block Phi(i, s) (N cells in the supercell) before the
  usual folding, i.e. to D_ij(q) times the phase sum S_ij(q) of the supercell images of j.

At |q| < 1e-5 / Angstrom (phonopy's tolerance) without a direction there is no correction:
D(Gamma) is the analytic one. The result is (D + D^H) / 2, as phonopy's.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Iterator

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import constants

from vibra._core import validate as _validate
from vibra._core.frozen import Frozen, short_repr, span
from vibra.crystals.dynamical import PHASES, brillouin_qpoints, check_qpoints, dynamical_matrices, lattice_phases
from vibra.crystals.force_constants import ForceConstants
from vibra.crystals.phonopy_io import fold_force_constants, to_ase_factors, to_phonopy
from vibra.units import ASE

if TYPE_CHECKING:
    from phonopy import Phonopy

    from vibra.crystals.force_constants import CrystalLike as Crystal  # the protocol: no import cycle

__all__ = ["NonAnalytic", "non_analytic", "nac_dynamical_matrices", "check_dielectric",
           "METHODS", "SUM_RULES", "SUM_RULE_TOLERANCE", "FACTOR_ASE", "FACTOR_SI", "Q_ZERO_ANGSTROM"]

#: The forms of the correction (module docstring).
METHODS: tuple[str, ...] = ("gonze", "wang")
#: What `non_analytic` does with charges that do not sum to zero: ``"impose"`` subtracts the
#: mean charge up to SUM_RULE_TOLERANCE and refuses beyond it, ``"force"`` subtracts it
#: whatever its size, ``"keep"`` uses the charges as given.
SUM_RULES: tuple[str, ...] = ("impose", "force", "keep")
#: Largest |sum_i Z*_i| entry, in e, that ``sum_rule="impose"`` removes. DFPT charges of a
#: converged calculation miss the rule by 0.001-0.1 e per cell (phonopy's own ZnO example: 0.06 e,
#: NaCl 3e-4 e); beyond 0.1 e the charges are more likely in the wrong atom order, with a sign
#: lost, or for another structure, and removing the mean would hide that.
SUM_RULE_TOLERANCE = 0.1
#: e^2 / (4 pi eps0) in eV Angstrom (CODATA via scipy.constants; phonopy's Hartree * Bohr is
#: 14.3996517, 4e-7 larger: pass ``factor=`` for phonopy's value, `nac_from_phonopy` does).
FACTOR_ASE = constants.e / (4.0 * np.pi * constants.epsilon_0 * constants.angstrom)
#: e^2 / (4 pi eps0) in J m.
FACTOR_SI = constants.e ** 2 / (4.0 * np.pi * constants.epsilon_0)
#: phonopy's |q| (Cartesian, no 2 pi) below which q is Gamma, in 1 / Angstrom.
Q_ZERO_ANGSTROM = 1e-5
#: Array entries per chunk of q-points for the analytic part, D(q) from force constants (complex
#: entries of the largest temporary: 1 MiB each; `dynamical_matrices` prepares its terms once per chunk).
#: 4 and 16 MiB ran no faster on phonopy's NaCl and ZnO (2,000 q, within the noise) and held more.
CHUNK_ENTRIES = 1 << 16
#: ... and per sub-chunk of the Ewald sum, whose (q, G) temporaries stay in cache (1 MiB each:
#: 2000 q-points of NaCl ran 1.5x faster than with 4 MiB).
EWALD_ENTRIES = 1 << 16


@dataclass(frozen=True, eq=False)
class NonAnalytic(Frozen):
    """The non-analytic correction of one crystal, ready to add at any q.

    Attributes
    ----------
    born : (n_atoms, 3, 3) ndarray
        Born effective charges Z*[i][a][b] as used (after the sum rule), in e.
    dielectric : (3, 3) ndarray
        High-frequency dielectric tensor eps_inf, dimensionless.
    factor : float
        e^2 / (4 pi eps0) in the crystal's energy x length unit (eV Angstrom, J m).
    method : str
        ``"gonze"`` or ``"wang"``.
    sum_rule : float
        Largest entry of |sum_i Z*_i| of the charges as given, in e: removed (the mean charge
        subtracted from every atom) unless built with ``sum_rule="keep"``.
    supercell : (3, 3) ndarray of int
        The supercell the force constants were made on, rows in units of the crystal's lattice vectors.
    short_range : ForceConstants or None
        Gonze-Lee: the short-range force constants, energy / length^2; None for Wang.
    g_vectors : (n_g, 3) ndarray or None
        Gonze-Lee: the reciprocal lattice vectors G of the Ewald sum, Cartesian, 1 / length
        (without 2 pi); None for Wang.
    ewald : float or None
        Gonze-Lee: phonopy's Lambda, the Ewald parameter, 1 / length; None for Wang.
    dd_q0 : (n_atoms, 3, 3) ndarray of complex or None
        Gonze-Lee: the self term C0_i subtracted on the diagonal blocks (dimensionless, before
        the factor 4 pi factor / V); None for Wang.
    phase_sums : ForceConstants or None
        Wang: the supercell images of each atom pair as terms whose nine block entries are all
        1 / multiplicity (dimensionless), so that their D(q) is S_ij(q) / sqrt(m_i m_j); None for Gonze-Lee.
    """

    born: NDArray[np.float64]
    dielectric: NDArray[np.float64]
    factor: float
    method: str
    sum_rule: float
    supercell: NDArray[np.int64]
    short_range: ForceConstants | None = None
    g_vectors: NDArray[np.float64] | None = None
    ewald: float | None = None
    dd_q0: NDArray[np.complex128] | None = None
    phase_sums: ForceConstants | None = None

    def dynamical_matrices(self, crystal: Crystal, qpoints: ArrayLike, *, q_direction: ArrayLike | None = None,
                           phase: str = "positions") -> NDArray[np.complex128]:
        """D(q) of `crystal` with this correction: `nac_dynamical_matrices` (what `Crystal.phonons` calls)."""
        return nac_dynamical_matrices(crystal, self, qpoints, q_direction=q_direction, phase=phase)

    def __repr__(self) -> str:
        cells = abs(round(float(np.linalg.det(self.supercell))))
        extra = f"{len(self.g_vectors)} G-vectors" if self.g_vectors is not None else ""
        return short_repr(self, repr(self.method), f"{self.born.shape[0]} atoms",
                          f"Z* {span(self.born[:, np.arange(3), np.arange(3)], 'e')}",
                          f"eps_inf {span(np.linalg.eigvalsh(self.dielectric))}",
                          f"sum rule {self.sum_rule:.3g} e", f"supercell of {cells} cells", extra)


# ---------------------------------------------------------------------- units
def _default_factor(crystal: Crystal) -> float:
    name = crystal.units.name
    if name == "ASE":
        return float(FACTOR_ASE)
    if name == "SI":
        return float(FACTOR_SI)
    raise ValueError(f"crystal {crystal.name!r} is dimensionless: give factor= (e^2 / (4 pi eps0) in its "
                     "energy x length unit)")


# ---------------------------------------------------------------------- validation
def _check_born(born: ArrayLike, n_atoms: int) -> NDArray[np.float64]:
    charges = _validate.real_array(born, "born")
    if charges.shape != (n_atoms, 3, 3):
        raise ValueError(f"born must have shape ({n_atoms}, 3, 3) (one 3x3 Born charge tensor per atom, in e), "
                         f"got {charges.shape}")
    return charges


#: Largest |eps - eps^T| relative to max |eps| accepted as symmetric (BORN files print 8 decimals).
DIELECTRIC_RTOL = 1e-6


def check_dielectric(dielectric: ArrayLike) -> NDArray[np.float64]:
    """(3, 3) eps_inf, symmetric to DIELECTRIC_RTOL of its largest entry (then symmetrised) and positive
    definite: the one check of the correction and of the infrared response (`vibra.crystals.infrared`)."""
    epsilon = _validate.real_array(dielectric, "dielectric", ndim=2)
    if epsilon.shape != (3, 3):
        raise ValueError(f"dielectric must be the 3 x 3 tensor eps_inf, dimensionless; got shape {epsilon.shape}")
    gap = np.abs(epsilon - epsilon.T)
    tolerance = DIELECTRIC_RTOL * float(np.abs(epsilon).max())
    if gap.max() > tolerance:
        i, j = (int(x) for x in np.unravel_index(np.argmax(gap), (3, 3)))
        raise ValueError(f"dielectric is not symmetric: |dielectric[{i},{j}] - dielectric[{j},{i}]| = "
                         f"{gap[i, j]:.3g} > {tolerance:.3g} ({DIELECTRIC_RTOL:g} of its largest entry)")
    epsilon = 0.5 * (epsilon + epsilon.T)
    lowest = float(np.linalg.eigvalsh(epsilon).min())
    if lowest <= 0.0:
        raise ValueError(f"dielectric is not positive definite (lowest eigenvalue {lowest:.4g}); eps_inf of a "
                         "stable insulator has positive eigenvalues (usually >= 1)")
    return epsilon


def _check_primitive(crystal: Crystal, phonon: Any) -> None:
    """phonon's primitive cell must be the crystal's (same cell, atoms in the same order, same masses)."""
    from phonopy import Phonopy

    if not isinstance(phonon, Phonopy):
        raise TypeError(f"phonon must be a phonopy.Phonopy, got {type(phonon).__name__}")
    if phonon.calculator not in (None, "vasp"):
        raise ValueError(f"phonon uses the {phonon.calculator!r} calculator's units; vibra reads phonopy's "
                         "default units (eV/Angstrom^2, Angstrom, amu)")
    length, mass, _ = to_ase_factors(crystal, dimensionless=True)
    primitive = phonon.primitive
    if len(primitive) != crystal.n_atoms:
        raise ValueError(f"phonon's primitive cell has {len(primitive)} atoms, crystal {crystal.name!r} "
                         f"{crystal.n_atoms}; pass the phonopy object the crystal was made from")
    cell = np.asarray(primitive.cell, dtype=float)
    if not np.allclose(cell, crystal.cell * length, rtol=0.0, atol=1e-8 * float(np.abs(cell).max())):
        raise ValueError(f"phonon's primitive cell {cell.round(6).tolist()} is not the cell of crystal "
                         f"{crystal.name!r}; pass the phonopy object the crystal was made from")
    delta = np.asarray(primitive.scaled_positions, dtype=float) - crystal.fractional
    delta -= np.rint(delta)
    masses = np.asarray(primitive.masses, dtype=float)
    bad = (np.abs(delta).max(axis=1) > 1e-6) | ~np.isclose(masses, crystal.masses * mass, rtol=1e-8, atol=0.0)
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(f"phonon's primitive atom {i} is not atom {i} of crystal {crystal.name!r} (position or "
                         "mass differ); pass the phonopy object the crystal was made from")


def _as_phonopy_crystal(crystal: Crystal) -> Any:
    """The crystal as `to_phonopy` takes it: a dimensionless one relabelled ASE (phonopy has no units)."""
    if crystal.units.name == "dimensionless":
        return dataclasses.replace(crystal, units=ASE)  # type: ignore[type-var]
    return crystal


# ---------------------------------------------------------------------- building
def non_analytic(crystal: Crystal, born: ArrayLike, dielectric: ArrayLike, *, method: str = "gonze",
                 factor: float | None = None, phonon: Phonopy | None = None, supercell: ArrayLike | None = None,
                 sum_rule: str = "impose") -> NonAnalytic:
    """The non-analytic correction of a polar crystal (module docstring), as phonopy makes it.

    Parameters
    ----------
    crystal : Crystal
        With force constants; the correction goes with them (`nac_dynamical_matrices`).
    born : (n_atoms, 3, 3) array_like
        Born effective charges Z*[i][a][b] of every atom, in e (phonopy's order; `read_born`).
    dielectric : (3, 3) array_like
        eps_inf, symmetric positive definite, dimensionless.
    method : {"gonze", "wang"}
        Gonze-Lee (phonopy's default) or Wang.
    factor : float, optional
        e^2 / (4 pi eps0) in the crystal's energy x length unit; by default FACTOR_ASE (eV
        Angstrom) or FACTOR_SI (J m). Required for a dimensionless crystal.
    phonon : phonopy.Phonopy, optional
        The phonopy object the crystal's force constants come from: its supercell is the one
        the correction is built on (both methods depend on it). Its primitive cell must be the crystal's.
    supercell : 3 ints, optional
        Without `phonon`: the supercell for `to_phonopy` (default: the smallest that holds the
        force constants).
    sum_rule : {"impose", "force", "keep"}
        The acoustic sum rule sum_i Z*_i = 0: subtract the mean charge (phonopy's way, the last
        step of ``symmetrize_borns_and_epsilon``) when it is missed by at most
        SUM_RULE_TOLERANCE (``"impose"``) or by any amount (``"force"``); or keep the charges.

    Returns
    -------
    NonAnalytic

    Raises
    ------
    ValueError
        born not (n_atoms, 3, 3) or not finite; dielectric not a symmetric positive definite
        3x3 tensor; an unknown method or sum_rule; factor not positive, or missing for a
        dimensionless crystal; phonon's primitive cell not the crystal's; both phonon and
        supercell; born missing the sum rule by more than SUM_RULE_TOLERANCE with ``"impose"``.
    TypeError
        phonon not a phonopy.Phonopy.
    """
    crystal.require_force_constants()
    charges = _check_born(born, crystal.n_atoms)
    eps = check_dielectric(dielectric)
    method = _validate.choice(method, "method", METHODS)
    unit = _default_factor(crystal) if factor is None else _validate.positive_scalar(factor, "factor")
    if phonon is not None:
        if supercell is not None:
            raise ValueError("give phonon or supercell, not both: phonon's supercell is the one used")
        _check_primitive(crystal, phonon)
    sum_rule = _validate.choice(sum_rule, "sum_rule", SUM_RULES)
    total = charges.sum(axis=0)
    violation = float(np.abs(total).max())
    if sum_rule == "impose" and violation > SUM_RULE_TOLERANCE:
        a, b = np.unravel_index(int(np.argmax(np.abs(total))), (3, 3))
        raise ValueError(f"born misses the acoustic sum rule: |sum_i Z*_i[{a}][{b}]| = {violation:.3g} e > "
                         f"{SUM_RULE_TOLERANCE} e; check the atom order and signs, or pass sum_rule='force' "
                         "to subtract the mean charge anyway")
    if sum_rule != "keep":
        charges = charges - total / crystal.n_atoms

    source = phonon if phonon is not None else to_phonopy(_as_phonopy_crystal(crystal), supercell=supercell)
    # phonopy's supercell in units of its primitive cell (= the crystal's)
    cell_matrix = np.rint(np.asarray(source.supercell.cell) @ np.linalg.inv(np.asarray(source.primitive.cell))
                          ).astype(np.int64)
    if method == "gonze":
        return _gonze(crystal, source, charges, eps, unit, violation, cell_matrix)
    n_p, n_s = len(source.primitive), len(source.supercell)
    phase_sums = fold_force_constants(source, np.ones((n_p, n_s, 3, 3)))
    return NonAnalytic(born=charges, dielectric=eps, factor=unit, method=method, sum_rule=violation,
                       supercell=cell_matrix, phase_sums=phase_sums)


def _gonze(crystal: Crystal, source: Any, charges: NDArray[np.float64], eps: NDArray[np.float64], unit: float,
           violation: float, cell_matrix: NDArray[np.int64]) -> NonAnalytic:
    """Gonze-Lee: short-range force constants by phonopy's own make_Gonze_nac_dataset.

    phonopy's machinery (commensurate points brought into the first zone, its Ewald sum, its
    inverse transform) makes the short-range set, so that our D(q) is phonopy's to rounding.
    The supercell force constants it starts from are made from the crystal's own D(q) at the
    commensurate points (an exact round trip for force constants folded as phonopy folds
    them), so the correction goes with the crystal's force constants even when they were
    symmetrised or do not come from `source`.
    """
    from phonopy.harmonic.dynamical_matrix import DynamicalMatrixGL
    from phonopy.harmonic.dynmat_to_fc import DynmatToForceConstants

    length, mass, stiffness = to_ase_factors(crystal, dimensionless=True)
    primitive, scell = source.primitive, source.supercell
    inverse = DynmatToForceConstants(primitive, scell, is_full_fc=False)
    analytic = dynamical_matrices(crystal, inverse.commensurate_points) * (stiffness / mass)
    inverse.dynamical_matrices = (analytic + analytic.conj().transpose(0, 2, 1)) / 2.0
    inverse.run()
    nac_params = {"born": charges, "dielectric": eps, "factor": unit * stiffness * length ** 3}
    ewald = DynamicalMatrixGL(scell, primitive, inverse.force_constants, nac_params=nac_params, log_level=0)
    ewald.make_Gonze_nac_dataset()
    short, dd_q0, _, g_list, lam = ewald.Gonze_nac_dataset
    terms = fold_force_constants(source, short)
    terms = ForceConstants(first=terms.first, second=terms.second, translations=terms.translations,
                           blocks=terms.blocks / stiffness)
    return NonAnalytic(born=charges, dielectric=eps, factor=unit, method="gonze", sum_rule=violation,
                       supercell=cell_matrix, short_range=terms, g_vectors=np.asarray(g_list) * length,
                       ewald=float(lam) * length, dd_q0=np.asarray(dd_q0, dtype=complex))


# ---------------------------------------------------------------------- D(q)
def _chunks(start: int, stop: int, per_q: int, entries: int) -> Iterator[slice]:
    size = max(1, entries // max(1, per_q))
    for first in range(start, stop, size):
        yield slice(first, min(stop, first + size))


@dataclass(frozen=True, eq=False)
class Parts:
    """What D(q) with the correction is made of, formed once per crystal (`parts`, kept by
    `Crystal.nac_parts`): the crystal whose force constants give the analytic part (the
    short-range set for Gonze-Lee, the crystal's own for Wang) and the q-independent tables of
    the correction."""

    base: Any                                        # Crystal
    table: Any                                       # _EwaldTable (Gonze-Lee) or Wang's sum table


@dataclass(frozen=True, eq=False)
class _EwaldTable:
    """The q-independent parts of the Gonze-Lee reciprocal sum (`_ewald_sum`)."""

    g: NDArray[np.float64]            # (n_g, 3) G
    g_squared: NDArray[np.float64]    # (n_g,) |G|^2
    eps_g: NDArray[np.float64]        # (n_g, 3) eps G
    g_eps_g: NDArray[np.float64]      # (n_g,) G eps G
    pair: NDArray[np.complex128]      # (n_g, n^2) P_ij(G) = exp(2 pi i G . (r_i - r_j))
    moments_real: NDArray[np.float64]  # (n_g, 13 n^2) [1, G_d, G_c G_d] P_ij(G), real part
    moments_imag: NDArray[np.float64]  # ... and imaginary part
    charges: NDArray[np.float64]      # (n^2, 9, 9) Z_ica Z_jdb, rows cd, columns ab


def parts(crystal: Crystal, nac: NonAnalytic) -> Parts:
    """The analytic crystal and the q-independent tables of `nac` on `crystal` (`Parts`)."""
    n = crystal.n_atoms
    if nac.method != "gonze":
        assert nac.phase_sums is not None
        return Parts(base=crystal, table=_sum_table(nac.phase_sums, n))
    assert nac.short_range is not None and nac.g_vectors is not None
    g = np.ascontiguousarray(nac.g_vectors, dtype=float)
    eps_g = g @ (0.5 * (nac.dielectric + nac.dielectric.T))  # 2 q (eps_s G) = q eps G + G eps q for any eps
    separation = (crystal.positions[:, None, :] - crystal.positions[None, :, :]).reshape(-1, 3)  # r_i - r_j
    pair = np.exp(2j * np.pi * (g @ separation.T))
    n_g = g.shape[0]
    moments = np.concatenate([pair[:, None, :], g[:, :, None] * pair[:, None, :],
                              (g[:, :, None] * g[:, None, :]).reshape(n_g, 9)[:, :, None] * pair[:, None, :]],
                             axis=1).reshape(n_g, 13 * n * n)
    born = nac.born
    charges = np.einsum("ica,jdb->ijcdab", born, born).reshape(n * n, 9, 9)
    table = _EwaldTable(g=g, g_squared=(g * g).sum(axis=1), eps_g=eps_g, g_eps_g=((g @ nac.dielectric) * g).sum(axis=1),
                        pair=pair, moments_real=np.ascontiguousarray(moments.real),
                        moments_imag=np.ascontiguousarray(moments.imag), charges=charges)
    return Parts(base=crystal.with_force_constants(nac.short_range), table=table)


def _ewald_sum(nac: NonAnalytic, table: _EwaldTable, q_cart: NDArray[np.float64], direction: NDArray[np.float64] | None,
               tolerance: float, outside: NDArray[np.bool_] | None = None) -> NDArray[np.complex128]:
    """(n_c, 3n, 3n) the Gonze-Lee reciprocal sum (module docstring) before the factor and masses.

    C_ia,jb(q) = sum_G w(K) (K Z_i)_a (K Z_j)_b exp(2 pi i G . (r_i - r_j)) - delta_ij dd_q0_i, K = q + G,
    w = exp(-K eps K / 4 Lambda^2) / (K eps K). (K Z_i)_a (K Z_j)_b = sum_cd K_c K_d Z_ica Z_jdb and
    K_c K_d = q_c q_d + q_c G_d + G_c q_d + G_c G_d, so the sum over G is one real product of the
    weights w(q, G) with the q-independent moments [1, G_d, G_c G_d] P_ij(G) for every q at once,
    then a 9 x 9 contraction with the charges per q and atom pair: phonopy's arithmetic in a few
    large products instead of a small matrix product per q. |K|^2 and K eps K are expanded the
    same way (q-independent G parts, one product q G^T): q lies in the first Brillouin zone, so
    |K| >= |G| / 2 wherever G != 0 and the expansion costs at most a few ulps of K eps K; at
    G = 0 it is q's own. The rows `outside` that zone (a caller's own q, not moved there) take
    K = q + G formed directly, as the expansion would lose |G|^2 / |K|^2 ulps where q nears -G.
    A K below the tolerance (Gamma) takes the direction of approach instead, or drops out
    without one, as phonopy's.
    """
    assert nac.ewald is not None and nac.dd_q0 is not None
    eps = nac.dielectric
    n = nac.born.shape[0]
    n_c = q_cart.shape[0]
    q_g = q_cart @ table.g.T
    k_squared = (q_cart * q_cart).sum(axis=1)[:, None] + 2.0 * q_g + table.g_squared
    small = k_squared < tolerance ** 2
    kek = np.einsum("qc,cd,qd->q", q_cart, eps, q_cart)[:, None] + 2.0 * (q_cart @ table.eps_g.T) + table.g_eps_g
    if outside is not None and outside.any():  # K formed directly where the expansion would cancel
        k = q_cart[outside][:, None, :] + table.g[None, :, :]
        k_squared[outside] = (k * k).sum(axis=2)
        kek[outside] = ((k @ eps) * k).sum(axis=2)
        small = k_squared < tolerance ** 2
    safe = np.where(small, 1.0, kek)
    weight = np.exp(safe * (-0.25 / nac.ewald ** 2))
    weight /= safe
    weight[small] = 0.0
    summed = np.empty((n_c, 13 * n * n), dtype=complex)
    summed.real = weight @ table.moments_real
    summed.imag = weight @ table.moments_imag
    summed = summed.reshape(n_c, 13, n * n)
    zeroth, first, second = summed[:, 0], summed[:, 1:4], summed[:, 4:].reshape(n_c, 3, 3, n * n)
    m = (q_cart[:, :, None, None] * q_cart[:, None, :, None] * zeroth[:, None, None, :]
         + q_cart[:, :, None, None] * first[:, None, :, :] + q_cart[:, None, :, None] * first[:, :, None, :]
         + second)                                                                  # (n_c, 3c, 3d, n^2)
    block = np.matmul(m.reshape(n_c, 9, n * n).transpose(2, 0, 1), table.charges)     # (n^2, n_c, 9 ab)
    matrices = block.reshape(n, n, n_c, 3, 3).transpose(2, 0, 3, 1, 4).reshape(n_c, 3 * n, 3 * n)
    if direction is not None and small.any():  # K = 0 approached along the direction: w = 1 / (d eps d), K -> d
        born = nac.born
        along = direction @ born.transpose(1, 0, 2).reshape(3, 3 * n)             # (d Z_i)_a, (3n,)
        term = np.outer(along, along) / float(direction @ eps @ direction)
        for q_index, g_index in zip(*np.nonzero(small)):
            phase = table.pair[g_index].reshape(n, n).repeat(3, axis=0).repeat(3, axis=1)
            matrices[q_index] += term * phase
    for i in range(n):
        matrices[:, 3 * i:3 * i + 3, 3 * i:3 * i + 3] -= nac.dd_q0[i]
    return matrices


def _sum_table(terms: ForceConstants, n: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Wang's phase sums grouped by lattice translation: (n_R, 3) R and (n_R, n^2) the weights s_R,ij."""
    translations, which = np.unique(terms.translations, axis=0, return_inverse=True)
    table = np.zeros((translations.shape[0], n * n))
    np.add.at(table, (which.ravel(), terms.first * n + terms.second), terms.blocks[:, 0, 0])
    return translations.astype(float), table


def _phase_sums(table: tuple[NDArray[np.float64], NDArray[np.float64]], q: NDArray[np.float64],
                fractional: NDArray[np.float64]) -> NDArray[np.complex128]:
    """(n_c, n, n) S_ij(q) = sum_R s_R,ij exp(2 pi i q . (R + x_j - x_i)): Wang's supercell phase sums."""
    translations, weights = table
    n = fractional.shape[0]
    phases = lattice_phases(q, translations)
    sums = np.empty((q.shape[0], n * n), dtype=complex)
    sums.real = phases.real @ weights
    sums.imag = phases.imag @ weights
    atoms = np.exp(2j * np.pi * (q @ fractional.T))
    return np.conj(atoms)[:, :, None] * sums.reshape(-1, n, n) * atoms[:, None, :]


def nac_dynamical_matrices(crystal: Crystal, nac: NonAnalytic, qpoints: ArrayLike, *,
                           q_direction: ArrayLike | None = None, phase: str = "positions"
                           ) -> NDArray[np.complex128]:
    """(n_q, 3 n_atoms, 3 n_atoms) dynamical matrices D(q) with the non-analytic correction, in 1 / time unit^2.

    Parameters
    ----------
    crystal : Crystal
        The crystal `nac` was made for.
    nac : NonAnalytic
        From `non_analytic`.
    qpoints : (n_q, 3) array_like
        Fractional reciprocal coordinates (phonopy's convention).
    q_direction : (3,) array_like, optional
        Fractional reciprocal coordinates of the direction from which Gamma is approached
        (phonopy's nac_q_direction), used wherever q is Gamma (|q + G| < 1e-5 / Angstrom for
        Gonze-Lee, |q| for Wang); without it there is no correction at Gamma.
    phase : {"positions", "cell"}
        The phase convention (`vibra.crystals.dynamical`): D_cell = P D_pos P^H, P = diag(exp(2 pi i q . x_j)).

    Returns
    -------
    (n_q, 3 n_atoms, 3 n_atoms) ndarray of complex
        Hermitian ((D + D^H) / 2, as phonopy's).

    Raises
    ------
    ValueError
        qpoints not (n_q, 3) finite; q_direction not 3 finite numbers or zero; an unknown
        phase; `nac` made for a crystal with another number of atoms.
    TypeError
        nac not a NonAnalytic.
    """
    if not isinstance(nac, NonAnalytic):
        raise TypeError(f"nac must be a NonAnalytic (from non_analytic), got {type(nac).__name__}")
    q = check_qpoints(qpoints)
    direction = None
    if q_direction is not None:
        raw = _validate.real_array(q_direction, "q_direction", ndim=1)
        if raw.shape != (3,) or not np.any(raw):
            raise ValueError(f"q_direction must be 3 fractional reciprocal coordinates, not all zero, got {raw.tolist()}")
        direction = raw @ np.linalg.inv(crystal.cell).T
    phase = _validate.choice(phase, "phase", PHASES)
    n = crystal.n_atoms
    if nac.born.shape[0] != n:
        raise ValueError(f"nac was made for {nac.born.shape[0]} atoms, crystal {crystal.name!r} has {n}")
    length = to_ase_factors(crystal, dimensionless=True)[0]
    tolerance = Q_ZERO_ANGSTROM * length
    volume = abs(float(np.linalg.det(crystal.cell)))
    strength = 4.0 * np.pi * nac.factor / volume
    root = np.sqrt(np.repeat(crystal.masses, 3))
    scale = strength / np.outer(root, root)
    q_cart = q @ np.linalg.inv(crystal.cell).T
    n3 = 3 * n
    made = crystal.nac_parts if nac is crystal.nac else parts(crystal, nac)  # formed once per crystal
    outside = brillouin_qpoints(q, crystal.reciprocal)[1].any(axis=1)  # q a caller did not move into the zone
    base = made.base
    if nac.method == "gonze":
        assert nac.g_vectors is not None
        weights = None
        per_q = 4 * n3 * n3  # the chunk's own arrays: the analytic part bounds its terms itself
        ewald_per_q = 4 * nac.g_vectors.shape[0] + 30 * n * n + 4 * n3 * n3
    else:
        assert nac.phase_sums is not None
        weights = nac.phase_sums
        sum_table = made.table
        cells = abs(round(float(np.linalg.det(nac.supercell))))
        per_q = 2 * sum_table[0].shape[0] + 8 * n3 * n3  # its phases and the (n_c, 3n, 3n) products
    out = np.empty((q.shape[0], n3, n3), dtype=complex)
    for part in _chunks(0, q.shape[0], per_q, CHUNK_ENTRIES):
        matrices = dynamical_matrices(base, q[part], analytic=True)
        if weights is None:
            for sub in _chunks(part.start, part.stop, ewald_per_q, EWALD_ENTRIES):
                local = slice(sub.start - part.start, sub.stop - part.start)
                matrices[local] += _ewald_sum(nac, made.table, q_cart[sub], direction, tolerance,
                                              outside[sub]) * scale
        else:  # Wang: f / N (q Z_i)(q Z_j)^T / (q eps q) times the phase sums S_ij(q) / sqrt(m_i m_j)
            vectors = q_cart[part]
            active = (vectors * vectors).sum(axis=1) >= tolerance ** 2
            if direction is not None:
                vectors = np.where(active[:, None], vectors, direction)
                active[:] = True
            denominator = np.einsum("ca,ab,cb->c", vectors, nac.dielectric, vectors)
            size = np.zeros_like(denominator)
            size[active] = strength / cells / denominator[active]
            charged = (vectors @ nac.born.transpose(1, 0, 2).reshape(3, n3)).reshape(-1, n, 3)
            sums = _phase_sums(sum_table, q[part], crystal.fractional)      # (n_c, n, n): n^2, not (3n)^2
            wang = (size[:, None, None, None, None] * charged[:, :, :, None, None] * charged[:, None, None, :, :]
                    * (sums / np.sqrt(np.outer(crystal.masses, crystal.masses)))[:, :, None, :, None])
            matrices += wang.reshape(-1, n3, n3)
        if phase == "cell":
            turn = np.exp(2j * np.pi * q[part] @ crystal.fractional.T).repeat(3, axis=1)
            matrices *= turn[:, :, None] * turn.conj()[:, None, :]
        out[part] = (matrices + matrices.conj().transpose(0, 2, 1)) / 2.0  # last: exactly Hermitian
    return out
