"""What a structural biologist does with a network's modes: correlations, B-factors, collectivity,
hinges, perturbation response, and an export to VMD.

Everything is computed from the modes themselves in ProDy's convention (the covariance
C = sum_k v_k v_k^T / lambda_k over the nonzero modes given, kT = 1, the network's gamma as
given), so that a user moving from ProDy finds the same numbers; and nothing forms the dense
3N x 3N covariance: with k modes, a residue map costs O(N^2 k) time and one N x N array (a
16,716-residue complex: 2.2 GB in float64, where ProDy's covariance would need 20 GB first).

- `cross_correlations(modes)`: C_ij summed over x, y, z (ProDy's ``calcCrossCorr``), normalised
  by sqrt(C_ii C_jj) by default;
- `fit_bfactors(modes, experimental)`: mean square fluctuations scaled to the crystallographic
  B-factors (ProDy's ``calcTempFactors``: the ratio of the sums; or least squares), with the
  Pearson correlation;
- `collectivity(modes)`: Brüschweiler's kappa = exp(-sum u_i^2 ln u_i^2) / N per mode (ProDy's
  ``calcCollectivity``);
- `hinges(modes)`: residues where a GNM mode changes sign (ProDy's ``calcHinges``; see there);
- `perturbation_response(modes)`: perturbation response scanning (Atilgan and Atilgan 2009;
  ProDy's ``calcPerturbResponse`` in its default "turbo" limit) from the same low-rank
  covariance: the normalised response matrix, each residue's effectiveness and sensitivity;
- `write_nmd(path, modes, structure)`: VMD's NMWiz format (ProDy's ``writeNMD``);
- `deformation_overlap(modes, reference, target)`: how much of a conformational change (the
  target superposed onto the reference, Kabsch) each mode and the lowest ones together carry
  (ProDy's ``calcOverlap`` with ``calcDeformVector``).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import Frozen
from vibra._core.filesystem import atomic_write_text, check_target
from vibra.modes import Modes

if TYPE_CHECKING:
    from vibra.networks.pdb import Structure

__all__ = ["cross_correlations", "fit_bfactors", "BFactorFit", "BFACTOR_METHODS", "collectivity", "hinges", "perturbation_response",
           "PerturbationResponse", "write_nmd", "superpose", "deformation_overlap", "DeformationOverlap"]

#: `fit_bfactors`' scale conventions: ProDy's ratio of the sums (the default), or least squares.
BFACTOR_METHODS = ("sum", "least_squares")

#: A mode with lambda <= ZERO_RTOL * max |lambda| (or |omega| within its omega_error) is a
#: rigid-body (zero) mode and is left out.
ZERO_RTOL = 1e-8


def _sites(modes: Modes, dim: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(vectors as (n_sites, dim, k), 1 / lambda (k,)) of the nonzero modes given."""
    if not isinstance(modes, Modes):
        raise TypeError(f"modes must be a vibra Modes result, got {type(modes).__name__}")
    if modes.vectors is None:
        raise ValueError("modes have no vectors: compute them with vectors=True")
    dim = _validate.count(dim, "dim", low=1, high=3)
    if modes.n_dof % dim:
        raise ValueError(f"modes have {modes.n_dof} dofs, not a multiple of dim={dim}")
    lam = modes.omega_squared
    scale = float(np.abs(lam).max(initial=0.0))
    # a rigid-body mode: zero within its own bound (whatever the other modes given), or
    # within ZERO_RTOL of the largest given
    keep = (lam > ZERO_RTOL * scale) & (np.abs(modes.omega) > modes.omega_error)
    if not keep.any():
        raise ValueError("modes hold no nonzero mode (all are rigid-body or unstable)")
    V = np.asarray(modes.vectors)[:, keep]
    return V.reshape(modes.n_dof // dim, dim, V.shape[1]), 1.0 / lam[keep]


def cross_correlations(modes: Modes, normalize: bool = True, *, dim: int = 3) -> NDArray[np.float64]:
    """(n_sites, n_sites) residue cross-correlations from the nonzero `modes` (ProDy's convention).

    `dim` is 3 for an ANM (x, y, z per site), 1 for a GNM. One (n x 3k) (3k x n) product: no
    3N x 3N covariance is formed.

    Examples
    --------
    >>> import numpy as np
    >>> from vibra import networks
    >>> rng = np.random.default_rng(0)
    >>> modes = networks.anm(rng.normal(size=(12, 3)) * 4, cutoff=12.0).modes(n_modes=16)
    >>> C = cross_correlations(modes)
    >>> C.shape, bool(np.allclose(np.diag(C), 1.0))
    ((12, 12), True)
    """
    U, w = _sites(modes, dim)
    n = U.shape[0]
    flat = U.reshape(n, -1)                                    # (n, dim k): site i's rows, all modes
    weights = np.tile(w, U.shape[1])                           # the same 1 / lambda for x, y, z
    C = (flat * weights) @ flat.T
    if normalize:
        root = np.sqrt(np.diag(C).copy())
        C /= root[:, None]
        C /= root[None, :]
    return C


@dataclass(frozen=True, eq=False)
class BFactorFit(Frozen):
    """Predicted B-factors on the experimental ones' axis.

    Attributes
    ----------
    predicted : (n_sites,) ndarray
        scale x the mean square fluctuations, in the experimental B-factors' unit (Å^2).
    fluctuations : (n_sites,) ndarray
        Mean square fluctuations sum_k |v_k,i|^2 / lambda_k (ProDy's ``calcSqFlucts``).
    scale : float
        The factor applied (its physical meaning: 8 pi^2 kT / (3 gamma) for a fitted gamma).
    correlation : float
        Pearson correlation of `predicted` with the experimental B-factors.
    method : str
        ``"sum"`` (ProDy's: the ratio of the sums) or ``"least_squares"``.
    """

    predicted: NDArray[np.float64]
    fluctuations: NDArray[np.float64]
    scale: float
    correlation: float
    method: str

    def __repr__(self) -> str:
        return (f"BFactorFit({self.predicted.shape[0]} sites, scale {self.scale:.4g} ({self.method}), "
                f"correlation {self.correlation:.3f})")


def fit_bfactors(modes: Modes, experimental: ArrayLike, *, method: str = "sum", dim: int = 3) -> BFactorFit:
    """Mean square fluctuations of the nonzero `modes`, scaled onto the `experimental` B-factors.

    An elastic network gives B-factors only up to its scale kT / gamma; this is the one place
    vibra fixes that scale (the report's B-factor chart calls it too). The convention is
    ProDy's ``calcTempFactors``: f_i = sum_k |v_k,i|^2 / lambda_k over the nonzero modes given
    (``calcSqFlucts``), scaled by s = sum_i B_i / sum_i f_i, so the fitted and the experimental
    B-factors have the same mean. ``method="least_squares"`` takes instead the s minimising
    ||s f - B||^2 = f.B / f.f, which a few very mobile sites (a free terminus) dominate. Either
    way the Pearson correlation, the scale-free figure of merit, is the same.

    Parameters
    ----------
    modes : Modes
        Modes of an ANM (``dim=3``) or a GNM (``dim=1``) with vectors; rigid-body modes among
        them are left out (`ZERO_RTOL`).
    experimental : (n_sites,) array_like
        Crystallographic B-factors, in Å^2, one per site in the order of the modes' sites.
    method : {"sum", "least_squares"}
        ``"sum"``: ProDy's ratio of the sums (the default); ``"least_squares"``: the
        least-squares scale.
    dim : {1, 2, 3}
        Dofs per site of the modes.

    Returns
    -------
    BFactorFit
        The fitted B-factors in Å^2, the fluctuations, the scale, the correlation, `method`.

    Raises
    ------
    ValueError
        An unknown method; experimental not 1-D, not finite, of another length than the
        modes' sites, or all equal (nothing to fit).

    Examples
    --------
    >>> import numpy as np
    >>> from vibra import networks
    >>> rng = np.random.default_rng(0)
    >>> modes = networks.anm(rng.normal(size=(12, 3)) * 4, cutoff=12.0).modes()
    >>> measured = np.linspace(10.0, 30.0, 12)
    >>> fit = networks.fit_bfactors(modes, measured)
    >>> bool(np.isclose(fit.predicted.sum(), measured.sum()))  # ProDy's: the same mean
    True
    """
    _validate.choice(method, "method", BFACTOR_METHODS)
    U, w = _sites(modes, dim)
    flucts = np.einsum("idk,idk,k->i", U, U, w)
    b = _validate.real_array(experimental, "experimental", ndim=1)
    if b.shape[0] != flucts.shape[0]:
        raise ValueError(f"experimental has {b.shape[0]} B-factors; the modes have {flucts.shape[0]} sites")
    if float(np.ptp(b)) == 0.0:
        raise ValueError("experimental B-factors are all equal: nothing to fit (is the file's B column empty?)")
    scale = float(b.sum() / flucts.sum()) if method == "sum" else float(flucts @ b / (flucts @ flucts))
    predicted = scale * flucts
    correlation = float(np.corrcoef(predicted, b)[0, 1])
    return BFactorFit(predicted, flucts, scale, correlation, method)


def collectivity(modes: Modes, masses: ArrayLike | None = None, *, dim: int = 3) -> NDArray[np.float64]:
    """Brüschweiler's collectivity of each nonzero mode: kappa = exp(-sum_i u_i^2 ln u_i^2) / N,
    u_i^2 = |v_i|^2 / m_i normalised to sum 1 (1: every site moves alike; 1/N: one site).

    With `masses`, u_i^2 is normalised to sum 1 as Brüschweiler defines it (ProDy divides by the
    square root of the sum there instead; without masses the two agree)."""
    U, _ = _sites(modes, dim)
    u2 = np.sum(U**2, axis=1)                                  # (n_sites, k)
    if masses is not None:
        m = _validate.real_array(masses, "masses", ndim=1)
        if m.shape[0] != u2.shape[0]:
            raise ValueError(f"masses has {m.shape[0]} entries; the modes have {u2.shape[0]} sites")
        _validate.positive(m, "masses", "mass")
        u2 = u2 / m[:, None]
    u2 = u2 / u2.sum(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        terms = np.where(u2 > 0, u2 * np.log(u2), 0.0)
    return np.exp(-terms.sum(axis=0)) / u2.shape[0]


def hinges(modes: Modes) -> list[int]:
    """Sites where a GNM mode changes sign (one value per site), over the nonzero `modes`: at each
    sign change between sites i and i + 1, the one nearer zero. ProDy's ``calcHinges`` moves a
    flag on along a run of decreasing |v| (its loop reads the flag it just moved): where that
    run passes zero again the two lists differ; this one keeps the crossing's own site."""
    U, _ = _sites(modes, 1)
    V = U[:, 0, :]
    found: set[int] = set()
    for v in V.T:
        crossing = np.flatnonzero(np.diff(np.sign(v)) != 0)
        nearer = np.where(np.abs(v[crossing + 1]) < np.abs(v[crossing]), crossing + 1, crossing)
        found.update(int(i) for i in nearer)
    return sorted(found)


@dataclass(frozen=True, eq=False)
class PerturbationResponse(Frozen):
    """Perturbation response scanning.

    Attributes
    ----------
    matrix : (n_sites, n_sites) ndarray
        Row i: the mean square response of every site to unit forces on site i (isotropic,
        the turbo limit), divided by site i's own response (ProDy's normalised PRS matrix).
    effectiveness : (n_sites,) ndarray
        Row means without the diagonal: how strongly a force on the site moves the rest.
    sensitivity : (n_sites,) ndarray
        Column means without the diagonal: how strongly the site answers forces elsewhere.
    """

    matrix: NDArray[np.float64]
    effectiveness: NDArray[np.float64]
    sensitivity: NDArray[np.float64]

    def __repr__(self) -> str:
        return (f"PerturbationResponse({self.matrix.shape[0]} sites; most effective site "
                f"{int(np.argmax(self.effectiveness))}, most sensitive {int(np.argmax(self.sensitivity))})")


def perturbation_response(modes: Modes, *, dim: int = 3) -> PerturbationResponse:
    """PRS from the nonzero `modes`: R_ij = ||C_ij||_F^2 (the squared 3 x 3 covariance block
    between sites i and j), from the low-rank covariance without forming it: with U_i the
    (dim x k) block of site i and W = diag(1 / lambda), R_ij = <W U_i^T U_i W, U_j^T U_j>_F,
    one (n x k^2) (k^2 x n) product."""
    U, w = _sites(modes, dim)
    n, k = U.shape[0], U.shape[2]
    UW = U * w
    A = np.einsum("idk,idl->ikl", UW, UW).reshape(n, k * k)
    B = np.einsum("idk,idl->ikl", U, U).reshape(n, k * k)
    response = A @ B.T
    diagonal = np.diag(response).copy()
    with np.errstate(divide="ignore", invalid="ignore"):
        matrix = np.where(diagonal[:, None] != 0, response / diagonal[:, None], 0.0)
    off = ~np.eye(n, dtype=bool)
    effectiveness = np.where(off, matrix, 0.0).sum(axis=1) / max(n - 1, 1)
    sensitivity = np.where(off, matrix, 0.0).sum(axis=0) / max(n - 1, 1)
    return PerturbationResponse(matrix, effectiveness, sensitivity)


def write_nmd(path: str | os.PathLike[str], modes: Modes, structure: Structure, *, title: str | None = None) -> Path:
    """Write the nonzero `modes` of an ANM for VMD's NMWiz (``.nmd``, ProDy's ``writeNMD`` layout):
    names, residue names and numbers, chains, B-factors and coordinates from `structure` (a
    `vibra.networks.Structure` from `from_pdb`), then one line per mode: its index (from 1),
    sqrt(1 / lambda) and the vector. Written atomically (`vibra._core.filesystem.atomic_write`), never over
    the structure's own file (``structure.path``: the PDB it was read from) nor another input
    of the run."""
    source = getattr(structure, "path", None)
    inputs = [source] if isinstance(source, (str, os.PathLike)) else []
    check_target(path, inputs=inputs)  # before any work
    U, w = _sites(modes, 3)
    positions = np.asarray(getattr(structure, "positions", structure), dtype=float)
    if positions.ndim != 2 or positions.shape != (U.shape[0], 3):
        raise ValueError(f"structure has positions of shape {positions.shape}; the modes have {U.shape[0]} sites")
    labels = list(getattr(structure, "labels", ()))
    lines = [f"name {title or Path(str(getattr(structure, 'path', 'vibra'))).stem}"]
    if labels and len(labels) == U.shape[0]:
        parts = [label.split(":") for label in labels]
        chains = [p[0] or "A" for p in parts]
        residues = [p[1] if len(p) > 1 else "UNK1" for p in parts]
        names = [p[2] if len(p) > 2 else "CA" for p in parts]
        resnames = ["".join(ch for ch in r if ch.isalpha()) or "UNK" for r in residues]
        resids = ["".join(ch for ch in r if ch.isdigit() or ch == "-") or "0" for r in residues]
        lines += [f"atomnames {' '.join(names)}", f"resnames {' '.join(resnames)}",
                  f"resids {' '.join(resids)}", f"chainids {' '.join(chains)}"]
    b = getattr(structure, "b_factors", None)
    if b is not None and len(b) == U.shape[0]:
        lines.append("bfactors " + " ".join(f"{float(x):.2f}" for x in b))
    lines.append("coordinates " + " ".join(f"{x:.3f}" for x in positions.ravel()))
    V = U.reshape(U.shape[0] * 3, -1)
    for index in range(V.shape[1]):
        lines.append(f"mode {index + 1} {np.sqrt(w[index]):.2f} " + " ".join(f"{x:.3f}" for x in V[:, index]))
    return atomic_write_text(path, "\n".join(lines) + "\n", inputs=inputs)


def superpose(target: ArrayLike, reference: ArrayLike) -> NDArray[np.float64]:
    """`target` (n, 3) moved onto `reference` (n, 3) by the rotation and translation of least
    RMSD (Kabsch's algorithm, W. Kabsch, Acta Cryst. A 32, 922 (1976): the SVD of the
    centred cross-covariance, a reflection excluded)."""
    a = _validate.real_array(target, "target", ndim=2)
    b = _validate.real_array(reference, "reference", ndim=2)
    if a.shape != b.shape or a.shape[1] != 3:
        raise ValueError(f"target has shape {a.shape} and reference {b.shape}; expected the same (n, 3)")
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    u, _, vt = np.linalg.svd((a - ca).T @ (b - cb))
    d = np.sign(np.linalg.det(u @ vt))
    rotation = u @ np.diag([1.0, 1.0, d]) @ vt
    return np.asarray((a - ca) @ rotation + cb)


@dataclass(frozen=True, eq=False)
class DeformationOverlap(Frozen):
    """How the modes carry a conformational change.

    Attributes
    ----------
    overlap : (k,) ndarray
        |cos| between each nonzero mode and the deformation (target superposed - reference).
    cumulative : (k,) ndarray
        sqrt of the running sum of overlap^2: how much of the change the lowest j modes span.
    rmsd : float
        RMSD between the superposed target and the reference, in their length unit.
    """

    overlap: NDArray[np.float64]
    cumulative: NDArray[np.float64]
    rmsd: float

    def __repr__(self) -> str:
        best = int(np.argmax(self.overlap)) if self.overlap.size else -1
        return (f"DeformationOverlap({self.overlap.shape[0]} modes, RMSD {self.rmsd:.3g}; best mode {best} "
                f"({float(self.overlap.max(initial=0.0)):.3f}), all {float(self.cumulative[-1]):.3f})")


def deformation_overlap(modes: Modes, reference: ArrayLike, target: ArrayLike) -> DeformationOverlap:
    """Overlap of each nonzero mode of a network built on `reference` (n, 3) with the change to
    `target` (n, 3, the same atoms in the same order), after superposing the target on the
    reference (`superpose`)."""
    U, _ = _sites(modes, 3)
    b = _validate.real_array(reference, "reference", ndim=2)
    if b.shape != (U.shape[0], 3):
        raise ValueError(f"reference has shape {b.shape}; the modes have {U.shape[0]} sites")
    moved = superpose(target, b)
    change = (moved - b).ravel()
    norm = float(np.linalg.norm(change))
    if norm <= 1e-12 * float(np.linalg.norm(b - b.mean(axis=0))):  # (superposing leaves rounding)
        raise ValueError("target and reference are the same conformation after superposition: no change to compare")
    V = U.reshape(U.shape[0] * 3, -1)
    overlap = np.abs(V.T @ change) / (np.linalg.norm(V, axis=0) * norm)
    return DeformationOverlap(overlap, np.sqrt(np.cumsum(overlap**2)), norm / np.sqrt(U.shape[0]))
