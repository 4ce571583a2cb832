"""vibra: normal-mode and vibration analysis.

Two kinds of public names, listed in one place each below:

- ``__all__``: the eager API, imported with the package and cheap to bind:
  `normal_modes` and `Modes` (vibra.modes), `System` (vibra.system), `GeneralizedSystem`
  (vibra.generalized), the unit systems (vibra.units). ``from vibra import *`` binds these
  and nothing else, so it costs no more than ``import vibra``.
- ``SUBMODULES``: every public submodule (`vibra.chains`, `vibra.molecules`,
  `vibra.response`, `vibra.continuum`, `vibra.dynamics`, `vibra.mechanics`, `vibra.pipeline`, ...). Those not
  already imported load on first attribute access (``vibra.chains.linear_chain``), so that
  ``import vibra`` stays light: no pyvista, ase, phonopy or matplotlib. Import them by name
  (``from vibra import chains``).

``dir(vibra)`` lists both, plus ``__version__``.
"""

from __future__ import annotations

from importlib import import_module as _import_module
from typing import Any as _Any

from vibra.generalized import GeneralizedSystem
from vibra.modes import Modes, normal_modes
from vibra.system import System
from vibra.units import ASE, DIMENSIONLESS, SI, UnitSystem

__version__ = "0.1.0"

__all__ = [
    "ASE", "DIMENSIONLESS", "GeneralizedSystem", "Modes", "SI", "System", "UnitSystem", "normal_modes",
]

#: Every public submodule of vibra, loaded (if not yet) on first attribute access.
SUBMODULES: tuple[str, ...] = (
    "assembly", "chains", "charts", "cli", "cluster", "compare", "continuum", "crosscheck", "crystals", "dynamics",
    "generalized", "mechanics",
    "modes", "molecules", "networks", "pipeline", "response", "solvers", "sources", "spectra", "system", "units",
)


def __getattr__(name: str) -> _Any:
    if name in SUBMODULES:
        return _import_module(f"vibra.{name}")
    raise AttributeError(f"module 'vibra' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*__all__, *SUBMODULES, "SUBMODULES", "__version__"})
