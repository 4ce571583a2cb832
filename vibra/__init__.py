"""vibra: normal-mode and vibration analysis.

Two kinds of public names, listed in one place each below:

- ``__all__``: the core API, `normal_modes` and `Modes` (vibra.modes), `System` (vibra.system),
  `GeneralizedSystem` (vibra.generalized), the unit systems (vibra.units), bound on first access
  (``vibra.System``, ``from vibra import System``): ``import vibra`` alone imports no numpy, so
  ``vibra --help`` starts as fast as Python does (issue 45). ``from vibra import *`` binds
  these and nothing else (numpy and scipy, no heavier module).
- ``SUBMODULES``: every public submodule (`vibra.chains`, `vibra.molecules`,
  `vibra.response`, `vibra.continuum`, `vibra.dynamics`, `vibra.mechanics`, `vibra.pipeline`, ...). Those not
  already imported load on first attribute access (``vibra.chains.linear_chain``), so that
  ``import vibra`` stays light: no pyvista, ase, phonopy or matplotlib. Import them by name
  (``from vibra import chains``).

``dir(vibra)`` lists both, plus ``__version__``.
"""

from __future__ import annotations

from importlib import import_module as _import_module
from typing import TYPE_CHECKING
from typing import Any as _Any

import vibra._core as _core  # noqa: F401  (stdlib only: it notes when this process imported vibra)

if TYPE_CHECKING:  # bound on first access (`__getattr__`): ``import vibra`` itself imports no numpy
    from vibra.generalized import GeneralizedSystem
    from vibra.modes import Modes, normal_modes
    from vibra.system import System
    from vibra.units import ASE, DIMENSIONLESS, SI, UnitSystem

__version__ = "0.1.0"

#: Where each name of `__all__` is defined.
_HOMES = {"ASE": "units", "DIMENSIONLESS": "units", "SI": "units", "UnitSystem": "units",
          "GeneralizedSystem": "generalized", "Modes": "modes", "normal_modes": "modes", "System": "system"}

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
    if name in _HOMES:
        value = getattr(_import_module(f"vibra.{_HOMES[name]}"), name)
        globals()[name] = value  # bound once: later accesses are plain attribute reads
        return value
    if name in SUBMODULES:
        return _import_module(f"vibra.{name}")
    raise AttributeError(f"module 'vibra' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*__all__, *SUBMODULES, "SUBMODULES", "__version__"})
