"""The engine protocol: what vibra asks of an electronic-structure code at one geometry.

An engine is any object with these five members (`Engine`, a `typing.Protocol`: no base class
to inherit):

- ``level``: the level of theory in words (``"RHF/STO-3G"``, ``"B3LYP/6-31G*"``, ``"GFN2-xTB"``),
  carried by every spectrum computed from it and shown on its charts;
- ``capabilities``: which of ``"dipole"``, ``"polarizability"`` and ``"hessian"`` (analytic)
  it gives beside the energy and forces;
- ``noise``: the noise of one component of each value it returns, by name (``"forces"`` in
  eV / Angstrom, ``"dipole"`` in e Angstrom, ``"polarizability"`` in Angstrom^3), where it knows
  it (an SCF stopped at a convergence threshold); a value left out is probed or taken at the
  rounding level, as `vibra.molecules.finite_difference_hessian` does;
- ``compute(numbers, positions, properties)`` -> `EngineResult`: energy and forces, plus the
  properties asked for, at one geometry, every call from scratch (the same numbers whatever
  ran before, serially or on a Dask worker);
- ``hessian(numbers, positions)``: the analytic Hessian, (3 n_atoms, 3 n_atoms) in eV /
  Angstrom^2 (only called when ``"hessian"`` is in ``capabilities``).

Units are vibra's molecular units throughout: Angstrom, eV, e. Polarisabilities are
polarisability volumes alpha / (4 pi epsilon_0), in Angstrom^3 (1 bohr^3 = 0.148185 Angstrom^3).

``methods`` (optional, a mapping) says how a property is computed (``{"polarizability":
"analytic response (CPHF)"}``); `vibra.molecules.engines.electronic_structure` reports it.

Everything else (the displacements, the cache, Dask, the error estimates) is vibra's
finite-difference machinery, reached through `EngineCalculator` (an ASE calculator view of an
engine), so a new engine needs no new code path.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Collection, Mapping, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from vibra._core.frozen import Frozen

__all__ = ["Engine", "EngineResult", "CAPABILITIES", "engine_methods"]

#: What an engine may give beside energy and forces.
CAPABILITIES = frozenset({"dipole", "polarizability", "hessian"})


@runtime_checkable
class Engine(Protocol):
    """An electronic-structure engine (see the module docstring)."""

    @property
    def level(self) -> str: ...

    @property
    def capabilities(self) -> frozenset[str]: ...

    @property
    def noise(self) -> Mapping[str, float]: ...

    def compute(self, numbers: NDArray[np.int_], positions: NDArray[np.float64],
                properties: Collection[str] = ()) -> EngineResult: ...

    def hessian(self, numbers: NDArray[np.int_], positions: NDArray[np.float64]) -> NDArray[np.float64]: ...


@dataclass(frozen=True, eq=False)
class EngineResult(Frozen):
    """What an engine computed at one geometry.

    Attributes
    ----------
    energy : float
        Total energy, in eV.
    forces : (n_atoms, 3) ndarray
        Forces, in eV / Angstrom.
    dipole : (3,) ndarray or None
        Dipole moment about the origin of the coordinates, in e Angstrom (None: not asked).
    polarizability : (3, 3) ndarray or None
        Static polarisability volume, in Angstrom^3 (None: not asked).
    """

    energy: float
    forces: NDArray[np.float64]
    dipole: NDArray[np.float64] | None = None
    polarizability: NDArray[np.float64] | None = None


def engine_methods(engine: object) -> dict[str, str]:
    """The engine's ``methods`` mapping (how each property is computed), or an empty dict."""
    methods = getattr(engine, "methods", None)
    return {str(k): str(v) for k, v in methods.items()} if isinstance(methods, Mapping) else {}
