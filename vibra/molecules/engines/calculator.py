"""`EngineCalculator`: an engine seen as an ASE calculator, so that vibra's finite-difference
machinery (`vibra.molecules.finite_difference_hessian`: displacements, cache, Dask, error
estimates) and ASE's own tools drive any engine the same way.

Imports ASE at import time; `vibra.molecules.engines` loads it on first access.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np
from ase import Atoms
from ase.calculators.calculator import Calculator, all_changes

from vibra.molecules.engines.protocol import Engine

__all__ = ["EngineCalculator"]


class EngineCalculator(Calculator):  # type: ignore[misc]
    """ASE calculator for an `Engine`: energy (eV), forces (eV / Angstrom), and the dipole (e
    Angstrom) and polarisability (Angstrom^3) where the engine gives them.

    Every calculation asks the engine for `properties` too, so that the forces, the dipole and
    the polarisability of one geometry come from one electronic-structure calculation. Periodic
    boundaries are ignored (the engine sees atomic numbers and positions).

    Parameters
    ----------
    engine : Engine
        The engine (kept as it is: it must be picklable to run on a Dask cluster or to key a cache).
    properties : sequence of {"dipole", "polarizability"}
        Computed at every geometry, whether asked for or not (default: none; the dipole is
        then computed only when asked for, by another call to the engine).
    """

    def __init__(self, engine: Engine, properties: Sequence[str] = (), **kwargs: Any) -> None:
        if not isinstance(engine, Engine):
            raise TypeError(f"engine must follow the vibra.molecules.engines.Engine protocol, got "
                            f"{type(engine).__name__}")
        names = tuple(properties)
        missing = [name for name in names if name not in engine.capabilities]
        if missing:
            raise ValueError(f"properties asks for {missing[0]!r}, which engine {engine.level!r} does not give "
                             f"(it gives {sorted(engine.capabilities)})")
        super().__init__(**kwargs)
        self.engine = engine
        self.properties = names
        self.implemented_properties = ["energy", "free_energy", "forces",
                                       *(name for name in ("dipole", "polarizability") if name in engine.capabilities)]

    def calculate(self, atoms: Atoms | None = None, properties: Sequence[str] = ("energy",),
                  system_changes: Sequence[str] = all_changes) -> None:
        super().calculate(atoms, properties, system_changes)
        wanted = tuple(dict.fromkeys([*self.properties, *(p for p in properties if p in ("dipole", "polarizability"))]))
        result = self.engine.compute(self.atoms.get_atomic_numbers(), self.atoms.get_positions(), wanted)
        self.results = {"energy": float(result.energy), "free_energy": float(result.energy),
                        "forces": np.array(result.forces, dtype=float)}
        if result.dipole is not None:
            self.results["dipole"] = np.array(result.dipole, dtype=float)
        if result.polarizability is not None:
            self.results["polarizability"] = np.array(result.polarizability, dtype=float)
