"""`vibra.crystals`: lattice dynamics of periodic crystals (issue 30).

A `Crystal` is a unit cell with atoms and force constants between periodic images. Build one
with a lattice builder (`simple_cubic`, `bcc`, `fcc`, `diamond`, `rock_salt`, `square`,
`honeycomb`), from a structure (`Crystal.from_cell`, `Crystal.from_ase`) plus `springs`, or from
phonopy (`from_phonopy`). Then `frequencies(qpoints)`, `modes_at(q)`, `band_structure()`.

Modules, by role:

- `crystal`: the `Crystal` type and its structure checks; `force_constants`: the terms Phi(i 0; j R)
- `springs`: spring force constants between periodic images; `builders`: the textbook lattices
- `dynamical`: D(q) for many q at once (its Hermitian part, q reduced into the first zone), its
  stacked Hermitian solves (the solver registry's `hermitian-eigh` path, planned and guarded),
  dD/dk; `velocities`: group velocities; `supercell`: one mode on a supercell
- `factor`: the spring factor A(q) (D = A^H A): frequencies as singular values, accurate near Gamma
- `bands`: band structures along SeeK-path's or a given path, branches connected
- `mesh`: Gamma-centred meshes reduced by symmetry (spglib); `dos`: tetrahedron and Gaussian DOS
- `thermal`: free energy, entropy, heat capacity; `elastic`: sound velocities (the continuum limit)
- `finite_difference`: force constants from any ASE calculator (`from_ase`), with their error;
  `reach`: whether the supercell holds the calculator's range
- `infrared`: the infrared response of a polar crystal at Gamma (mode charges, epsilon(omega),
  reflectivity, irreps with IR and Raman activity)
- `phonopy_io`: to and from `phonopy.Phonopy`; `phonopy_files`: `FORCE_CONSTANTS` and `phonopy.yaml`
"""

from __future__ import annotations

from vibra.crystals.bands import BandStructure, band_structure
from vibra.crystals.builders import bcc, diamond, fcc, honeycomb, rock_salt, simple_cubic, square
from vibra.crystals.crystal import Crystal
from vibra.crystals.dos import DensityOfStates, dos
from vibra.crystals.dynamical import PHASES, Phonons, dynamical_matrices
from vibra.crystals.velocities import group_velocities
from vibra.crystals.supercell import SupercellMode, conventional_cube, supercell_mode
from vibra.crystals.elastic import SoundVelocities, acoustic_slopes, sound_velocities
from vibra.crystals.finite_difference import (FiniteDifferenceForceConstants, finite_difference_force_constants,
                                              from_ase)
from vibra.crystals.force_constants import (ForceConstants, ForceConstantsWarning, SpringModel, SumRuleReport,
                                            impose_sum_rules)
from vibra.crystals.infrared import InfraredResponse, infrared_response
from vibra.crystals.phonopy_files import read_phonopy, write_force_constants, write_phonopy
from vibra.crystals.phonopy_io import to_phonopy
from vibra.crystals.reach import SupercellRangeWarning, SupercellReach
from vibra.crystals.springs import springs
from vibra.crystals.thermal import ThermalProperties, thermal_properties

__all__ = [
    "BandStructure", "Crystal", "DensityOfStates", "FiniteDifferenceForceConstants", "ForceConstants",
    "ForceConstantsWarning", "InfraredResponse", "SupercellRangeWarning", "SupercellReach", "infrared_response",
    "PHASES", "Phonons", "SoundVelocities", "SpringModel", "SupercellMode", "supercell_mode", "conventional_cube", "SumRuleReport", "ThermalProperties",
    "acoustic_slopes", "band_structure", "bcc", "diamond", "dos", "dynamical_matrices", "fcc",
    "finite_difference_force_constants", "from_ase", "from_phonopy", "group_velocities", "honeycomb",
    "impose_sum_rules", "read_phonopy", "rock_salt", "simple_cubic", "sound_velocities", "springs", "square",
    "thermal_properties", "to_phonopy", "write_force_constants", "write_phonopy",
]

#: `Crystal.from_phonopy`, under the name the issue gives it.
from_phonopy = Crystal.from_phonopy
