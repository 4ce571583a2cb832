"""Analyses the plan runs for its drawings: what the renderer and the charts then only draw.

- `inversion_parity`: g/u parity of a mode of a centrosymmetric molecule (mutual exclusion).
- `symmetry_hints`: per-mode symmetry and IR-activity text of a molecule (parity, and the
  point-charge IR intensities of `vibra.spectra`).
- `dispersion_branches`: omega(q) of a chain scene's parameters over its Brillouin zone.
- `chain_dispersion`: the dispersion branches of a chain scene and the wavenumber of each of
  its finite chain's modes (`vibra.continuum`), for the dispersion chart.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["inversion_parity", "symmetry_hints", "DispersionCurves", "chain_dispersion", "dispersion_branches"]

#: A mode whose point-charge IR intensity is below this fraction of the strongest is IR-inactive.
IR_INACTIVE_FRACTION = 1e-8


def inversion_parity(positions: ArrayLike, masses: ArrayLike, displacement: ArrayLike) -> str | None:
    """'g' or 'u' for a centrosymmetric molecule (None otherwise): parity of a mode under inversion.

    Inversion through the centre of mass maps atom i to its partner P(i) and a displacement
    u_i to -u_P(i). A mode is 'g' when u_P(i) = -u_i for all i and 'u' when u_P(i) = u_i.
    By the mutual-exclusion rule g modes are IR-inactive (Raman-allowed) and u modes are
    IR-allowed.

    Parameters
    ----------
    positions : (n_atoms, 3) array_like
        Atom positions, in a length unit.
    masses : (n_atoms,) array_like
        Atom masses (only compared with each other).
    displacement : (n_atoms, 3) array_like
        The mode's displacement of every atom.

    Examples
    --------
    >>> x = [[-1.0, 0, 0], [0.0, 0, 0], [1.0, 0, 0]]
    >>> inversion_parity(x, [16.0, 12.0, 16.0], [[-1.0, 0, 0], [0, 0, 0], [1.0, 0, 0]])
    'g'
    """
    x = np.asarray(positions, dtype=float)
    m = np.asarray(masses, dtype=float)
    u = np.asarray(displacement, dtype=float)
    centre = (m[:, None] * x).sum(axis=0) / m.sum()
    relative = x - centre
    scale = max(float(np.abs(relative).max()), 1e-12)
    partner = []
    for i in range(len(relative)):
        distance = np.linalg.norm(relative + relative[i], axis=1)
        j = int(np.argmin(distance))
        if distance[j] > 1e-6 * scale or not np.isclose(m[j], m[i], rtol=1e-9):
            return None
        partner.append(j)
    size = max(float(np.abs(u).max()), 1e-300)
    mapped = u[partner]
    if np.abs(mapped + u).max() <= 1e-6 * size:
        return "g"
    if np.abs(mapped - u).max() <= 1e-6 * size:
        return "u"
    return None


def _parity_text(parity: str | None) -> str:
    if parity == "g":
        return "g: IR-inactive (centrosymmetric, mutual exclusion)"
    if parity == "u":
        return "u: IR-allowed"
    return "no inversion centre: IR activity not fixed by symmetry"


def _site_displacements(system: Any, shape: NDArray[np.float64]) -> NDArray[np.float64]:
    """(n_sites, 3) displacement of every site (zeros at frozen dofs and unused axes)."""
    full = np.asarray(system.expand(shape)).reshape(system.n_sites, system.dim)
    out = np.zeros((system.n_sites, 3))
    out[:, : system.dim] = full
    return out


def symmetry_hints(system: Any, modes: Any, indices: Sequence[int], symbols: Sequence[str],
                   bonds: Sequence[tuple[int, int]]) -> dict[int, str]:
    """Symmetry and IR-activity text of the modes `indices` of a molecule, for captions.

    Each text is the inversion parity (`inversion_parity`: g modes IR-inactive, u modes
    IR-allowed) and, for a 3-D molecule with bonds, the point-charge IR intensity of
    `vibra.spectra.ir_spectrum` (charges from Pauling electronegativities over `bonds`)
    relative to the strongest mode; parts are joined by ``"; "``.
    """
    positions = np.zeros((system.n_sites, 3))
    positions[:, : system.dim] = np.asarray(system.positions, dtype=float)
    masses = np.asarray(system.masses, dtype=float)
    intensity: dict[int, str] = {}
    if system.dim == 3 and bonds:
        from vibra import spectra

        charges = spectra.electronegativity_charges(list(symbols), list(bonds))
        ir = spectra.ir_spectrum(system, modes, charges=charges)
        strongest = float(np.max(ir.intensities)) if len(ir.intensities) else 0.0
        for k, value in zip(ir.mode_indices, ir.intensities):
            active = strongest > 0 and value > IR_INACTIVE_FRACTION * strongest
            intensity[int(k)] = (f"IR {'active' if active else 'inactive'} "
                                 f"(point charges: {value / strongest if strongest else 0.0:.2f} of strongest)")
    hints = {}
    for k in indices:
        parity = inversion_parity(positions, masses, _site_displacements(system, np.asarray(modes.shapes)[:, k]))
        parts = [_parity_text(parity)] if parity is not None or int(k) not in intensity else []
        if int(k) in intensity:
            parts.append(intensity[int(k)])
        hints[int(k)] = "; ".join(parts)
    return hints


@dataclass(frozen=True, eq=False)
class DispersionCurves:
    """Dispersion branches of an infinite chain and where a finite chain's modes sit on them.

    Attributes
    ----------
    q : (n_q,) ndarray
        Wavenumbers over the first Brillouin zone [0, pi / (cell length)], in rad per length unit.
    branches : (n_branches, n_q) ndarray
        omega(q) of each branch (acoustic first), in rad per time unit.
    mode_q : (n_modes,) ndarray
        Wavenumber assigned to each mode of the finite chain, in rad per length unit.
    mode_omega : (n_modes,) ndarray
        Those modes' omega, in rad per time unit.
    n_sites : int
        Sites of the finite chain.
    ends : str
        Its end conditions.
    """

    q: NDArray[np.float64]
    branches: NDArray[np.float64]
    mode_q: NDArray[np.float64]
    mode_omega: NDArray[np.float64]
    n_sites: int
    ends: str

    def __post_init__(self) -> None:
        for name in ("q", "branches", "mode_q", "mode_omega"):
            array = np.array(getattr(self, name), dtype=float)
            array.flags.writeable = False
            object.__setattr__(self, name, array)


def dispersion_branches(parameters: Any, *, n_q: int = 400) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(q, branches): omega(q) of a ``linear_chain`` / ``diatomic_chain`` scene over its Brillouin zone.

    Parameters
    ----------
    parameters : Mapping
        ``mass`` (a number) or ``masses`` (a pair), ``stiffness`` (a number or a pair), ``spacing``.
    n_q : int
        Points along q (2: the zone's ends, a cheap check).
    """
    from vibra.continuum import dispersion

    masses = parameters["mass"] if "mass" in parameters else tuple(parameters["masses"])
    stiffness = parameters["stiffness"]
    stiffness = tuple(stiffness) if isinstance(stiffness, (tuple, list)) else stiffness
    spacing = parameters["spacing"]
    n_branches = dispersion(np.zeros(1), masses=masses, stiffness=stiffness, spacing=spacing).shape[0]
    q = np.linspace(0.0, np.pi / (n_branches * spacing), n_q)
    return q, dispersion(q, masses=masses, stiffness=stiffness, spacing=spacing)


def chain_dispersion(parameters: Any, modes: Any, *, n_q: int = 400) -> DispersionCurves:
    """Dispersion of a ``linear_chain`` / ``diatomic_chain`` scene's parameters, with its modes placed.

    Parameters
    ----------
    parameters : Mapping
        The scene's system parameters: ``mass`` (a number) or ``masses`` (a pair),
        ``stiffness`` (a number or a pair), ``spacing`` and ``ends``.
    modes : Modes
        The finite chain's modes (their wavenumbers from `vibra.continuum.assign_wavenumbers`).
    n_q : int
        Points along q.
    """
    from vibra.continuum import assign_wavenumbers

    q, branches = dispersion_branches(parameters, n_q=n_q)
    spacing = parameters["spacing"]
    mode_q = assign_wavenumbers(modes, ends=parameters["ends"], spacing=spacing, sites_per_cell=branches.shape[0])
    return DispersionCurves(q=q, branches=branches, mode_q=mode_q, mode_omega=np.asarray(modes.omega),
                            n_sites=int(modes.n_dof), ends=str(parameters["ends"]))
