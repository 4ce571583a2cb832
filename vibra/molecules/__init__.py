"""Molecules: `System` builders from ASE `Atoms`, Hessians, and the vibrational analysis.

Units are ASE's (amu, Angstrom, eV; docs/architecture.md, "Units"): positions in Angstrom, masses in amu,
force constants in eV / Angstrom^2 (stretches) or eV / rad^2 (bends, torsions); frequencies are
reported in cm^-1.

Where K comes from
------------------
- A **valence force field** (`ValenceModel`, `valence.py`): bond stretches, angle bends, linear
  bends (two perpendicular bending coordinates, as CO2 needs), torsions and out-of-plane impropers
  (`internal_terms.py`), with potential V = 1/2 sum_t w_t (q_t(X) - q_t0)^2 and, by default, typed
  constants by element pair and bond order, bend centre, torsion axis and planar centre from one
  small table fitted to observed fundamentals (`force_constants.py`). At an equilibrium dV/dq = 0,
  so the Hessian is exactly K = B^T diag(w) B with B the Wilson B matrix (row t = gradient of q_t,
  `coordinates.py`); `from_atoms` (`hessians.py`) builds the `System` with `System.from_terms` so
  that the accurate solver path stays available. `ValenceForceField` (`calculator.py`) is an ASE
  calculator for the same potential with the exact nonlinear coordinates (used by the cross-checks
  against ASE and phonopy).
- **Any ASE calculator**: `finite_difference_hessian` (`finite_difference.py`: 2- or 4-point
  central differences of the forces, symmetrised, with a Richardson estimate of its truncation
  error and a round-off estimate) and `from_calculator`.
- A Hessian given directly (`from_hessian`), ASE's `VibrationsData` (`from_vibrations_data`) or
  phonopy force constants (`from_phonopy`), all in `hessians.py`.

The vibrational analysis (`vibrational_analysis`, `analysis.py`) projects out translations and
rotations like the quantum-chemistry codes (Eckart, with the rigid-body vectors of
`rigid_body.py`), detects linear molecules from the inertia tensor with a relative tolerance,
reports 3N-6 (3N-5) vibrations, keeps imaginary modes and flags them, and gives per-mode reduced
masses, force constants and the zero-point energy.

Symmetry (`symmetry.py`, `character_tables.py`): `point_group(atoms_or_system, tolerance)` finds
the Schoenflies point group (tolerance in Angstrom, linear groups included) with its operations,
atom permutations and character table; `mode_species` and `VibrationalAnalysis.species` label
each vibration with its Mulliken symbol; IR and Raman activity follow from the table;
`VibrationalAnalysis.numbers` and `herzberg_numbers` (`numbering.py`) number the vibrations as
Herzberg and Shimanouchi's tables do (nu1, nu2, ... by species).

`co2` and `h2o` are ready-made models (`builders.py`); `molecule` builds any molecule of ASE's
collection or any `Atoms` at its valence-force-field equilibrium (`named.py`); isotope labels
(``isotopes=``) work in all three, and `substitute_isotopes` changes masses on the same K
(`isotopes.py`); `export.py` writes ASE `VibrationsData`, Molden files, mode trajectories and
phonopy force constants; `symbols_from_masses` and `bonds_from_distances` (`elements.py`)
recover elements and bonds from masses and positions.

``import vibra.molecules`` does not import ASE: functions that need it import it when called,
and `ValenceForceField` (a subclass of ASE's ``Calculator``) is loaded on first access.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from vibra.modes import Modes, normal_modes
from vibra.molecules.analysis import VibrationalAnalysis, vibrational_analysis
from vibra.molecules.builders import (CO2_BEND, CO2_BOND_LENGTH, CO2_STRETCH, H2O_ANGLE_DEG, H2O_BEND,
                                      H2O_BOND_LENGTH, H2O_STRETCH, co2, co2_atoms, h2o, h2o_atoms)
from vibra.molecules.character_tables import CharacterTable, character_table
from vibra.molecules.checks import MIN_DISTANCE
from vibra._core.elements import bonds_from_distances, symbols_from_masses
from vibra.molecules.finite_difference import FiniteDifferenceHessian, finite_difference_hessian, from_calculator
from vibra.molecules.hessians import from_atoms, from_hessian, from_phonopy, from_vibrations_data
from vibra.molecules.experimental import (EXPERIMENTAL, ExperimentalFundamentals, Fundamental,
                                          experimental_fundamentals, match_fundamentals)
from vibra.molecules.export import (BOHR_ANGSTROM, system_atoms, to_vibrations_data, write_force_constants,
                                    write_mode_trajectory, write_molden)
from vibra.molecules.isotopes import ISOTOPE_MASSES, isotope_mass, isotope_masses, substitute_isotopes
from vibra.molecules.named import EQUILIBRIUM_FORCE, molecule, molecule_atoms, molecule_names
from vibra.molecules.numbering import herzberg_numbers
from vibra.molecules.rigid_body import SoftModeWarning, is_linear, principal_moments, rigid_body_vectors
from vibra.molecules.symmetry import SYMMETRY_TOLERANCE, PointGroup, mode_species, point_group, symmetry_number
from vibra.molecules.valence import ValenceModel, valence_model
from vibra.system import System
from vibra.units import ASE

if TYPE_CHECKING:
    from vibra.molecules.calculator import ValenceForceField

__all__ = [
    "EXPERIMENTAL", "ExperimentalFundamentals", "Fundamental", "experimental_fundamentals", "match_fundamentals",
    "herzberg_numbers",
    "SoftModeWarning", "ValenceModel", "ValenceForceField", "valence_model", "from_atoms",
    "FiniteDifferenceHessian", "finite_difference_hessian", "from_calculator", "from_hessian",
    "from_vibrations_data", "from_phonopy", "VibrationalAnalysis", "vibrational_analysis",
    "rigid_body_vectors", "is_linear", "isotope_mass", "substitute_isotopes", "co2", "h2o",
    "co2_atoms", "h2o_atoms",
    "CO2_STRETCH", "CO2_BEND", "CO2_BOND_LENGTH", "H2O_STRETCH", "H2O_BEND", "H2O_BOND_LENGTH",
    "H2O_ANGLE_DEG", "MIN_DISTANCE", "ISOTOPE_MASSES",
    "symbols_from_masses", "bonds_from_distances",
    "molecule", "molecule_atoms", "molecule_names", "EQUILIBRIUM_FORCE", "isotope_masses", "principal_moments",
    "system_atoms", "to_vibrations_data", "write_molden", "write_mode_trajectory", "write_force_constants",
    "BOHR_ANGSTROM",
    "point_group", "PointGroup", "mode_species", "symmetry_number", "SYMMETRY_TOLERANCE", "CharacterTable",
    "character_table",
]

# re-exported from the stages below, as the single-module vibra.molecules did
_REEXPORTED = (ASE, Modes, System, normal_modes)

_LAZY = {"ValenceForceField": "vibra.molecules.calculator"}


def __getattr__(name: str) -> Any:
    """Load `ValenceForceField` (and with it ASE) on first access."""
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'vibra.molecules' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
