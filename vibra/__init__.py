"""vibra: normal-mode and vibration analysis.

Library entry points: `normal_modes` and `Modes` (vibra.modes), `System` (vibra.system),
and the submodules `chains`, `molecules`, `response`, `continuum`, `lagrangian`, loaded on
first access so that ``import vibra`` stays light (no pyvista, ase or phonopy).
"""

from __future__ import annotations

import importlib
from typing import Any

from vibra.modes import Modes, normal_modes
from vibra.system import System
from vibra.units import ASE, DIMENSIONLESS, SI, UnitSystem

__version__ = "0.1.0"

__all__ = [
    "ASE", "DIMENSIONLESS", "Modes", "SI", "System", "UnitSystem", "normal_modes",
    "chains", "continuum", "lagrangian", "molecules", "response", "rigid", "pendulum",
    "spectra", "crosscheck", "scene", "report",
]

_SUBMODULES = {
    "chains", "continuum", "lagrangian", "molecules", "response", "rigid", "pendulum",
    "spectra", "crosscheck", "scene", "report", "charts", "render", "solvers", "units",
}


def __getattr__(name: str) -> Any:
    if name in _SUBMODULES:
        return importlib.import_module(f"vibra.{name}")
    raise AttributeError(f"module 'vibra' has no attribute {name!r}")
