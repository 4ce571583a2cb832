"""Engines with electrons: Hessians, dipoles and polarisabilities from electronic-structure codes.

One small protocol (`Engine`, `protocol.py`) says what vibra asks of a code at one geometry:
energy and forces, optionally the dipole, the polarisability and an analytic Hessian, with the
level of theory and the noise of what it returns. Adapters:

- `PySCFEngine` (`pyscf_engine.py`, optional extra ``vibra[pyscf]``): Hartree-Fock and DFT in
  any basis PySCF ships; analytic gradients and Hessians, the dipole, and the polarisability by
  analytic linear response (CPHF / CPKS) or by finite field;
- `AseEngine` (`ase_engine.py`): any ASE calculator (and factory); its dipole where it gives one
  (xtb through tblite, ``vibra[xtb]``), so IR intensities but no Raman.

`electronic_structure` (`electronic.py`) runs the displacements on vibra's finite-difference
machinery (`vibra.molecules.finite_difference_hessian` with ``properties=``: one loop for the
forces, the dipole and the polarisability; cached, resumable, on Dask; Richardson and noise
error estimates for each) through `EngineCalculator` (`calculator.py`, an ASE calculator view
of any engine), adds the analytic Hessian where there is one, and returns an
`ElectronicStructure`. `vibra.spectra.electronic_ir_spectrum` and
`vibra.spectra.electronic_raman_spectrum` turn it into IR intensities (km/mol) and Raman
activities (Angstrom^4/amu), depolarisation ratios and cross sections, labelled with the level
of theory.

`check_engine_choice` (`choice.py`) validates an engine chosen by name (a scene's ``[system]
engine``, ``method``, ``basis``) without running anything, `engine_cost` estimates its time and
memory from sizes before any SCF, and `make_engine` builds it.

``import vibra.molecules.engines`` imports neither ASE nor PySCF: `EngineCalculator` (an ASE
``Calculator`` subclass) loads on first access, and PySCF when an engine is made.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from vibra.molecules.engines.ase_engine import AseEngine
from vibra.molecules.engines.choice import (ENGINES, EngineChoice, EngineChoiceError, EngineCost, EngineMissingError,
                                            check_engine_choice, engine_cost, make_engine)
from vibra.molecules.engines.electronic import HESSIAN_SOURCES, ElectronicStructure, electronic_structure
from vibra.molecules.engines.protocol import CAPABILITIES, Engine, EngineResult, engine_methods
from vibra.molecules.engines.pyscf_engine import BOHR_ANGSTROM, HARTREE_EV, PySCFEngine, require_pyscf

if TYPE_CHECKING:
    from vibra.molecules.engines.calculator import EngineCalculator

__all__ = ["Engine", "EngineResult", "CAPABILITIES", "engine_methods", "AseEngine", "PySCFEngine",
           "EngineCalculator", "ElectronicStructure", "electronic_structure", "HESSIAN_SOURCES",
           "HARTREE_EV", "BOHR_ANGSTROM", "require_pyscf", "ENGINES", "EngineChoice", "EngineChoiceError",
           "EngineMissingError", "EngineCost", "check_engine_choice", "engine_cost", "make_engine"]

_LAZY = {"EngineCalculator": "vibra.molecules.engines.calculator"}


def __getattr__(name: str) -> Any:
    """Load `EngineCalculator` (and with it ASE) on first access."""
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'vibra.molecules.engines' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
