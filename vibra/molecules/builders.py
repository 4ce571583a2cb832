"""Ready-made molecules: CO2 (Kneller, Mécanique analytique, Example 11) and H2O with fitted valence force fields."""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal, Mapping, Sequence

import numpy as np

from vibra._core import validate as _validate
from vibra.molecules.hessians import from_atoms
from vibra.molecules.isotopes import isotope_masses
from vibra.molecules.valence import valence_model
from vibra.system import System

if TYPE_CHECKING:
    from ase import Atoms

__all__ = ["co2", "h2o", "co2_atoms", "h2o_atoms", "CO2_STRETCH", "CO2_BEND", "CO2_BOND_LENGTH",
           "H2O_STRETCH", "H2O_BEND", "H2O_BOND_LENGTH", "H2O_ANGLE_DEG"]

#: CO2 bond length, Angstrom (Kneller, Mécanique analytique, Example 11: L = 0.116 nm).
CO2_BOND_LENGTH = 1.16
#: CO2 C=O stretch constant kappa, eV/Angstrom^2 (= 15.4 mdyn/Angstrom). Fitted here, in the
#: Kneller's axial model (eq. 157, masses 15.999 and 12.011 amu), to the experimental
#: fundamentals 1333 and 2349 cm^-1 by least squares on log(omega): one kappa cannot give both
#: (the ratio sqrt(1 + 2 m_O / m_C) = 1.915 of eq. 157 against 1.762 observed), so the model
#: gives 1279 and 2448 cm^-1, each 4 % off. Literature valence force fields give 16 mdyn/A.
CO2_STRETCH = 96.24
#: CO2 linear-bend constant k_delta, eV/rad^2 (k_delta / L^2 = 0.57 mdyn/Angstrom, as in
#: Herzberg's valence force field). Fitted here to the experimental bend 667 cm^-1:
#: omega^2 = k_delta (2 / m_O + 4 / m_C) / L^2 gives 667.0 cm^-1 exactly.
CO2_BEND = 4.806
#: H2O geometry (experimental equilibrium: r_e = 0.9572 Angstrom, angle 104.52 degrees).
H2O_BOND_LENGTH = 0.9572
H2O_ANGLE_DEG = 104.52
#: H2O O-H stretch constant, eV/Angstrom^2, and bend constant, eV/rad^2. Fitted here (simple
#: valence force field, no interaction constants) by least squares on log(omega) to the
#: experimental fundamentals 1595, 3657 and 3756 cm^-1; the model gives 1595, 3680 and
#: 3733 cm^-1 (k_r = 7.67 mdyn/Angstrom; see docs/molecules.md).
H2O_STRETCH = 47.89
H2O_BEND = 4.021


def co2(
    dims: Literal[1, 3] = 3,
    *,
    bond_length: float = CO2_BOND_LENGTH,
    stretch: float = CO2_STRETCH,
    bend: float = CO2_BEND,
    isotopes: Sequence[str | None] | Mapping[int, str] | None = None,
) -> System:
    """Carbon dioxide O=C=O with a valence force field (ASE units).

    ``dims=1``: the axial model of Kneller, Mécanique analytique, Example 11 (eqs. 152-158): three sites at
    (0, L, 2L) on a line, two springs kappa = `stretch`; 3 degrees of freedom, frequencies
    0, sqrt(kappa/m_O), sqrt(kappa (1/m_O + 2/m_C)). ``dims=3`` (default): the full model along
    the x axis, the same two stretches plus a linear bend (two perpendicular coordinates,
    constant `bend`); 9 degrees of freedom: symmetric stretch, asymmetric stretch, a doubly
    degenerate bend and 5 rigid-body modes. Masses: ``ase.data.atomic_masses`` (12.011, 15.999).

    Parameters
    ----------
    dims : {1, 3}
        Axial (1-D) or full (3-D) model.
    bond_length : float
        C=O length L, Angstrom (seed: 0.116 nm).
    stretch : float
        kappa, eV / Angstrom^2; default `CO2_STRETCH` (fitted to 1333 and 2349 cm^-1).
    bend : float
        Linear-bend constant, eV / rad^2; default `CO2_BEND` (fitted to 667 cm^-1).
    isotopes : sequence of (str or None) or mapping of int to str, optional
        Isotope labels for the atoms O, C, O (``[None, "13C", None]`` or ``{0: "18O"}``); see
        `isotope_masses`. The force field is unchanged.

    Examples
    --------
    >>> from vibra import molecules
    >>> analysis = molecules.vibrational_analysis(molecules.co2())
    >>> analysis.n_vibrations, analysis.n_rigid, analysis.linear
    (4, 5, True)
    >>> [round(float(w)) for w in analysis.vibration_wavenumbers_cm1()]
    [667, 667, 1279, 2448]
    >>> molecules.co2(dims=1).n_dof
    3
    """
    from ase import Atoms as _Atoms
    from ase.data import atomic_masses, atomic_numbers

    if isinstance(dims, bool) or dims not in (1, 3):
        raise ValueError(f"dims is {dims!r}; expected 1 (axial model) or 3 (full model)")
    length = _validate.real_scalar(bond_length, "bond_length")
    if not length > 0:
        raise ValueError(f"bond_length is {length!r}; it must be positive (Angstrom)")
    masses = isotope_masses(("O", "C", "O"), atomic_masses[[atomic_numbers[z] for z in "OCO"]],
                            isotopes=isotopes)
    if dims == 1:
        return System.from_springs(np.array([0.0, length, 2.0 * length]), masses,
                                   springs=np.array([[0, 1], [1, 2]]), stiffness=stretch,
                                   units="ASE", name="CO2 (axial)").with_symbols(("O", "C", "O"))
    atoms = _Atoms("OCO", positions=[(-length, 0, 0), (0, 0, 0), (length, 0, 0)], masses=masses)
    model = valence_model(atoms, bonds=np.array([[0, 1], [1, 2]]), stretch=stretch, bend=bend)
    return from_atoms(atoms, model, name="CO2")


def co2_atoms(bond_length: float = CO2_BOND_LENGTH) -> Atoms:
    """ase.Atoms of linear CO2 along x (O, C, O), masses set explicitly from ase.data.

    Examples
    --------
    >>> atoms = co2_atoms()
    >>> atoms.get_chemical_symbols(), atoms.positions[:, 0].tolist()
    (['O', 'C', 'O'], [-1.16, 0.0, 1.16])
    """
    from ase import Atoms as _Atoms
    from ase.data import atomic_masses, atomic_numbers

    masses = atomic_masses[[atomic_numbers["O"], atomic_numbers["C"], atomic_numbers["O"]]]
    return _Atoms("OCO", positions=[(-bond_length, 0, 0), (0, 0, 0), (bond_length, 0, 0)], masses=masses)


def h2o_atoms(bond_length: float = H2O_BOND_LENGTH, angle_deg: float = H2O_ANGLE_DEG) -> Atoms:
    """ase.Atoms of H2O in the xy plane (O, H, H), masses set explicitly from ase.data.

    Examples
    --------
    >>> atoms = h2o_atoms()
    >>> atoms.get_chemical_symbols(), round(float(atoms.get_angle(1, 0, 2)), 2)
    (['O', 'H', 'H'], 104.52)
    """
    from ase import Atoms as _Atoms
    from ase.data import atomic_masses, atomic_numbers

    half = np.radians(angle_deg) / 2.0
    positions = [(0, 0, 0), (bond_length * np.sin(half), bond_length * np.cos(half), 0),
                 (-bond_length * np.sin(half), bond_length * np.cos(half), 0)]
    masses = atomic_masses[[atomic_numbers["O"], atomic_numbers["H"], atomic_numbers["H"]]]
    return _Atoms("OHH", positions=positions, masses=masses)


def h2o(*, stretch: float = H2O_STRETCH, bend: float = H2O_BEND,
        isotopes: Sequence[str | None] | Mapping[int, str] | None = None) -> System:
    """Water with a simple valence force field (two stretches, one bend), ASE units.

    Geometry: r = 0.9572 Angstrom, angle 104.52 degrees; constants `H2O_STRETCH` (eV/A^2) and
    `H2O_BEND` (eV/rad^2), fitted to the experimental fundamentals (see the module constants).
    9 degrees of freedom: 3 vibrations and 6 rigid-body modes. `isotopes` relabels atoms
    O, H, H (``[None, "D", "D"]`` gives D2O on the same force field; see `isotope_masses`).

    Examples
    --------
    >>> from vibra import molecules
    >>> [round(float(w)) for w in molecules.vibrational_analysis(h2o()).vibration_wavenumbers_cm1()]
    [1595, 3680, 3733]
    >>> d2o = h2o(isotopes=[None, "D", "D"])
    >>> [round(float(w)) for w in molecules.vibrational_analysis(d2o).vibration_wavenumbers_cm1()]
    [1163, 2664, 2736]
    """
    atoms = h2o_atoms()
    masses = isotope_masses(atoms.get_chemical_symbols(), atoms.get_masses(), isotopes=isotopes)
    model = valence_model(atoms, bonds=np.array([[0, 1], [0, 2]]), stretch=stretch, bend=bend)
    return from_atoms(atoms, model, masses=masses, name="H2O")
