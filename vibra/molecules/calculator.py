"""`ValenceForceField`: an ASE calculator for a `ValenceModel`.

The only module of `vibra.molecules` that imports ASE at import time; `vibra.molecules` loads
it on first access of ``vibra.molecules.ValenceForceField``, so ``import vibra.molecules`` stays
free of ASE.
"""

from __future__ import annotations

from typing import Any, Sequence

from ase import Atoms
from ase.calculators.calculator import Calculator, all_changes

from vibra.molecules.valence import ValenceModel

__all__ = ["ValenceForceField"]


class ValenceForceField(Calculator):  # type: ignore[misc]
    """ASE calculator for a `ValenceModel`: energy (eV) and forces (eV / Angstrom).

    Evaluates the exact nonlinear internal coordinates, so finite differences of its forces
    (ASE `Vibrations`, phonopy) converge to the analytic Hessian B^T diag(w) B at an
    equilibrium. Periodic boundaries are ignored (positions are used as given).

    Parameters
    ----------
    model : ValenceModel
        The force field.
    """

    implemented_properties = ["energy", "forces"]

    def __init__(self, model: ValenceModel, **kwargs: Any) -> None:
        if not isinstance(model, ValenceModel):
            raise TypeError(f"model must be a ValenceModel, got {type(model).__name__}")
        super().__init__(**kwargs)
        self.model = model

    def calculate(self, atoms: Atoms | None = None, properties: Sequence[str] = ("energy",),
                  system_changes: Sequence[str] = all_changes) -> None:
        super().calculate(atoms, properties, system_changes)
        positions = self.atoms.get_positions()
        if len(positions) != self.model.n_atoms:
            raise ValueError(f"atoms has {len(positions)} atoms; this force field is for {self.model.n_atoms}")
        energy, forces = self.model.energy_and_forces(positions)
        self.results = {"energy": energy, "free_energy": energy, "forces": forces}
