"""Choosing an engine by name (what a scene's ``[system] engine``, ``method`` and ``basis`` say),
validating the choice without running anything, and estimating what it will cost from sizes.

`ENGINES` is the fixed table of engines a name may select: ``"forcefield"`` (vibra's bundled
valence force field, no electrons: the default), ``"pyscf"`` (`PySCFEngine`, Hartree-Fock or any
functional libxc knows, in any basis PySCF ships; extra ``vibra[pyscf]``) and ``"xtb"`` (tblite's
ASE calculator behind `AseEngine`, GFN1-xTB / GFN2-xTB / IPEA1-xTB; extra ``vibra[xtb]``).

`check_engine_choice(engine, method, basis)` returns an `EngineChoice` or raises `EngineChoiceError`
(a ValueError naming the key, ``"engine"``, ``"method"`` or ``"basis"``, with the accepted values
and the close matches): a method is checked against libxc's functional names
(``pyscf.dft.libxc.parse_xc``) and a basis against PySCF's basis library (its alias table and
its Pople-name parser): no molecule is built and no SCF runs. A missing package is
`EngineMissingError` (an ImportError naming the extra to install).

`engine_cost(choice, numbers)` is the estimate a scene is refused on before any SCF: the
calculations the scene runs (the optimisation to the engine's own minimum, the displaced
geometries of the finite differences, the analytic Hessian), each timed by a model of the sizes
(basis functions counted by building PySCF's ``Mole``, which runs no integral, electrons, atoms,
the kind of method), calibrated on measured runs (`_TIME_MODEL`: see there) and checked against
measured runs in ``benchmarks/bench_engines.py``.
"""

from __future__ import annotations

import difflib
import functools
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np
from numpy.typing import ArrayLike

if TYPE_CHECKING:
    from vibra.molecules.engines.protocol import Engine

__all__ = ["ENGINES", "XTB_METHODS", "EngineChoice", "EngineChoiceError", "EngineMissingError",
           "check_engine_choice", "require_engine", "make_engine", "EngineCost", "engine_cost",
           "fd_calculations", "OPTIMISATION_STEPS", "cheaper_choices"]

#: engine name -> (what it is, the Python package it needs, the extra that installs it).
ENGINES: dict[str, tuple[str, str | None, str | None]] = {
    "forcefield": ("vibra's bundled valence force field (no electrons: model IR and Raman intensities)", None, None),
    "pyscf": ("PySCF: Hartree-Fock or DFT, analytic Hessians, dipoles and polarisabilities", "pyscf", "pyscf"),
    "xtb": ("GFN-xTB tight binding through tblite's ASE calculator: dipoles (IR), no Raman", "tblite", "xtb"),
}
#: The tblite methods.
XTB_METHODS = ("GFN2-xTB", "GFN1-xTB", "IPEA1-xTB")
#: Methods that are Hartree-Fock (the rest of a PySCF method is a functional).
_HF_NAMES = ("hf", "rhf")
#: Bases proposed when a choice is over its limit (cheapest first).
_CHEAPER_BASES = ("sto-3g", "3-21g", "6-31g*", "def2-svp", "cc-pvdz")


class EngineChoiceError(ValueError):
    """An unknown engine, method or basis; `key` is the scene key (``"engine"``, ``"method"``, ``"basis"``)."""

    def __init__(self, key: str, message: str) -> None:
        super().__init__(message)
        self.key = key


class EngineMissingError(ImportError):
    """The engine's package is not installed; the message names the extra (`extra`)."""

    def __init__(self, engine: str, package: str, extra: str) -> None:
        super().__init__(f"engine {engine!r} needs the package {package!r}, which is not installed; "
                         f"install the extra: pip install 'vibra[{extra}]'")
        self.engine, self.package, self.extra = engine, package, extra


@dataclass(frozen=True)
class EngineChoice:
    """A validated engine choice: ``engine`` (a key of `ENGINES`), ``method`` and ``basis``
    (normalised: ``"hf"`` for Hartree-Fock; None where the engine takes none)."""

    engine: str
    method: str | None = None
    basis: str | None = None

    @property
    def electronic(self) -> bool:
        """Whether the engine has electrons (anything but the bundled force field)."""
        return self.engine != "forcefield"

    @property
    def hartree_fock(self) -> bool:
        """Whether the method is Hartree-Fock (PySCF)."""
        return self.engine == "pyscf" and self.method == "hf"

    @property
    def level(self) -> str:
        """The level of theory in words, as the engine will report it (``"RHF/6-31G*"``)."""
        if self.engine == "forcefield":
            return "valence force field"
        if self.engine == "xtb":
            return str(self.method)
        from vibra.molecules.engines.pyscf_engine import PySCFEngine

        return PySCFEngine(method=str(self.method), basis=str(self.basis)).level


def _close(value: str, allowed: Sequence[str]) -> str:
    close = difflib.get_close_matches(value, list(allowed), n=3, cutoff=0.6)
    return f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""


def require_engine(engine: str) -> None:
    """Raise `EngineMissingError` when the package of `engine` cannot be imported."""
    _, package, extra = ENGINES[engine]
    if package is None or extra is None:
        return
    import importlib.util

    try:
        found = importlib.util.find_spec(package) is not None
    except (ImportError, ValueError):  # a package set to None in sys.modules, or half installed
        found = False
    if found:
        try:
            importlib.import_module(package)
        except ImportError:
            found = False
    if not found:
        raise EngineMissingError(engine, package, extra)


def _check_functional(method: str) -> str:
    from pyscf.dft import libxc

    try:
        libxc.parse_xc(method)
    except (KeyError, ValueError) as error:
        examples = "'hf', 'b3lyp', 'pbe', 'pbe0', 'blyp', 'm06-2x', 'wb97x-d', 'lda'"
        raise EngineChoiceError("method", f"is {method!r}: neither Hartree-Fock ('hf' or 'rhf') nor a functional "
                                f"PySCF's libxc knows ({error}); for example {examples}") from None
    return method.lower()


def _check_basis(basis: str) -> str:
    from pyscf.gto import basis as library

    # PySCF's own name normalisation and Pople parser (private names: a plain fallback if they move)
    normalise = getattr(library, "_format_basis_name",
                        lambda text: text.lower().replace("-", "").replace("_", "").replace(" ", ""))
    name = normalise(basis)
    pople = getattr(library, "_is_pople_basis", lambda _: False)
    if name in library.ALIAS or pople(name):
        return basis
    known = sorted(library.ALIAS)
    raise EngineChoiceError("basis", f"is {basis!r}, not a basis set PySCF ships{_close(name, known)} (names as "
                            f"PySCF writes them: 'sto-3g', '6-31g*', '6-311+g(2d,p)', 'def2-svp', 'def2-tzvp', "
                            f"'cc-pvdz', 'aug-cc-pvtz'; {len(known)} in its library)")


def check_engine_choice(engine: Any = None, method: Any = None, basis: Any = None, *,
                        require: bool = True) -> EngineChoice:
    """Validate an engine choice by name, running nothing.

    Parameters
    ----------
    engine : str, optional
        A key of `ENGINES` (None: ``"forcefield"``).
    method : str, optional
        PySCF: ``"hf"`` / ``"rhf"`` or a functional libxc knows (required); xtb: one of
        `XTB_METHODS` (default ``"GFN2-xTB"``); the force field takes none.
    basis : str, optional
        PySCF: a basis set PySCF ships (required); the others take none.
    require : bool
        Also check that the engine's package is installed (`EngineMissingError`); the method
        and basis of PySCF need it either way.

    Raises
    ------
    EngineChoiceError
        An unknown engine, method or basis, or one given to an engine that takes none (``key``
        names which).
    EngineMissingError
        The engine's package is missing (the extra to install named).
    """
    engine = "forcefield" if engine is None else engine
    if not isinstance(engine, str) or engine not in ENGINES:
        raise EngineChoiceError("engine", f"is {engine!r}{_close(str(engine), list(ENGINES))}; expected one of "
                                + ", ".join(f"{name!r} ({what})" for name, (what, _, _) in ENGINES.items()))
    for key, value in (("method", method), ("basis", basis)):
        if value is not None and (not isinstance(value, str) or not value.strip()):
            raise EngineChoiceError(key, f"is {value!r}; expected a non-empty string")
    if engine == "forcefield":
        for key, value in (("method", method), ("basis", basis)):
            if value is not None:
                raise EngineChoiceError(key, f"is {value!r}, but the bundled force field takes no {key}; set "
                                        "engine = \"pyscf\" or \"xtb\" for an electronic-structure level")
        return EngineChoice("forcefield")
    if engine == "xtb":
        if basis is not None:
            raise EngineChoiceError("basis", f"is {basis!r}, but xtb has its own minimal basis; remove basis")
        chosen = XTB_METHODS[0] if method is None else method
        by_lower = {m.lower(): m for m in XTB_METHODS}
        if chosen.lower() not in by_lower:
            raise EngineChoiceError("method", f"is {chosen!r}{_close(chosen, XTB_METHODS)}; xtb takes one of "
                                    f"{', '.join(repr(m) for m in XTB_METHODS)}")
        if require:
            require_engine("xtb")
        return EngineChoice("xtb", by_lower[chosen.lower()])
    if method is None:
        raise EngineChoiceError("method", "is required with engine = \"pyscf\": 'hf' (Hartree-Fock) or a functional "
                                "such as 'b3lyp'")
    if basis is None:
        raise EngineChoiceError("basis", "is required with engine = \"pyscf\": a basis set PySCF ships, such as "
                                "'6-31g*' or 'def2-svp'")
    require_engine("pyscf")  # the names are checked against PySCF's own tables
    name = "hf" if method.lower() in _HF_NAMES else _check_functional(method)
    return EngineChoice("pyscf", name, _check_basis(basis))


def make_engine(choice: EngineChoice) -> Engine | None:
    """The `vibra.molecules.engines.Engine` of a choice (None for the force field)."""
    if choice.engine == "forcefield":
        return None
    if choice.engine == "xtb":
        require_engine("xtb")
        from tblite.ase import TBLite

        from vibra.molecules.engines.ase_engine import AseEngine

        return AseEngine(functools.partial(TBLite, method=choice.method, verbosity=0), level=str(choice.method))
    from vibra.molecules.engines.pyscf_engine import PySCFEngine

    return PySCFEngine(method=str(choice.method), basis=str(choice.basis))


# ------------------------------------------------------------------------------ cost
#: Optimisation steps assumed before the finite differences (ASE's BFGS from a textbook
#: geometry to the engine's minimum; 6-9 measured for H2O, CO2, CH4 at HF and B3LYP).
OPTIMISATION_STEPS = 12

#: The time model, in seconds, fitted to single-core runs (OPENBLAS_NUM_THREADS=1) of H2O, CO2
#: and CH4 at RHF/STO-3G, RHF/6-31G* and B3LYP/6-31G* on the shared 2-core development machine
#: (PySCF 2.14): one geometry (SCF + gradient + dipole + polarisability) takes
#: a + b nbf^2 + g n_atoms nbf (g: the DFT grid, 0 for Hartree-Fock), the analytic Hessian
#: h0 + h1 n_atoms nbf^3 + h2 n_atoms^2 nbf (h2: DFT only); xtb a + c n_atoms per geometry.
_TIME_MODEL = {"point": {"a": 0.04, "b": 3.5e-4, "g": 0.018},
               "hessian": {"h0": 0.08, "h1": 1.9e-5, "h2": 0.017},
               "xtb": {"a": 2e-3, "c": 3e-4}}
#: PySCF's memory: the process with PySCF loaded (about 200 MiB), the in-core two-electron
#: integrals (nbf^4 / 8 doubles, 8-fold symmetry) three times over in the Hessian, and a DFT
#: grid block (PySCF caps its blocks at ``max_memory``, 4000 MB by default).
_BASE_MEMORY = 200 * 2**20
_PYSCF_MAX_MEMORY = 4000e6


@dataclass(frozen=True)
class EngineCost:
    """What running an engine on one molecule will take, estimated from sizes before any SCF.

    Attributes
    ----------
    seconds : float
        Estimated wall time on one core, in s.
    memory : int
        Estimated peak memory, in bytes.
    calculations : int
        Engine calculations (geometries) the scene runs: optimisation plus finite differences.
    n_basis : int
        Basis functions (PySCF), 0 for xtb.
    n_electrons : int
        Electrons.
    n_atoms : int
        Atoms.
    level : str
        The level of theory.
    detail : str
        The estimate in words (what is counted).
    """

    seconds: float
    memory: int
    calculations: int
    n_basis: int
    n_electrons: int
    n_atoms: int
    level: str
    detail: str


def fd_calculations(n_atoms: int, *, richardson: bool = True) -> int:
    """Geometries of `electronic_structure`'s central differences: the reference plus +-h along
    every Cartesian coordinate, and +-2h too for the Richardson error estimate."""
    return 1 + 2 * 3 * int(n_atoms) * (2 if richardson else 1)


def _basis_count(choice: EngineChoice, numbers: Sequence[int]) -> tuple[int, int]:
    """(basis functions, electrons), from PySCF's ``Mole`` with the atoms 3 bohr apart on a line
    (the count depends on the elements only; building it evaluates no integral)."""
    from pyscf import gto

    atom = [(int(z), (3.0 * i, 0.0, 0.0)) for i, z in enumerate(numbers)]
    spin = int(sum(int(z) for z in numbers) % 2)
    try:
        mol = gto.M(atom=atom, basis=choice.basis, unit="Bohr", spin=spin, verbose=0)
    except (KeyError, RuntimeError, ValueError) as error:
        raise EngineChoiceError("basis", f"is {choice.basis!r}: PySCF has no such basis for every element of the "
                                f"molecule ({type(error).__name__}: {error})") from None
    return int(mol.nao_nr()), int(mol.nelectron)


def engine_cost(choice: EngineChoice, numbers: ArrayLike, *, richardson: bool = True,
                optimise: bool = True, polarizability: bool = True) -> EngineCost:
    """Estimate the time and memory of an engine's spectra of one molecule, before any SCF.

    Parameters
    ----------
    choice : EngineChoice
        A validated choice (not the force field).
    numbers : (n_atoms,) array_like of int
        Atomic numbers.
    richardson : bool
        Whether the finite differences take the coarser step for their error estimate.
    optimise : bool
        Whether the geometry is optimised first (`OPTIMISATION_STEPS` calculations).
    polarizability : bool
        Whether each geometry computes the polarisability too (PySCF: Raman).

    Raises
    ------
    EngineChoiceError
        A PySCF basis that lacks one of the molecule's elements (at ``"basis"``).
    """
    numbers = [int(z) for z in np.asarray(numbers).ravel()]
    n_atoms = len(numbers)
    points = fd_calculations(n_atoms, richardson=richardson) + (OPTIMISATION_STEPS if optimise else 0)
    if choice.engine == "xtb":
        model = _TIME_MODEL["xtb"]
        seconds = points * (model["a"] + model["c"] * n_atoms)
        return EngineCost(seconds=seconds, memory=_BASE_MEMORY, calculations=points, n_basis=0,
                          n_electrons=sum(numbers), n_atoms=n_atoms, level=choice.level,
                          detail=f"{points} xtb calculations of {n_atoms} atoms")
    n_basis, n_electrons = _basis_count(choice, numbers)
    point, hess = _TIME_MODEL["point"], _TIME_MODEL["hessian"]
    dft = 0.0 if choice.hartree_fock else 1.0
    one = point["a"] + point["b"] * n_basis**2 * (1.0 if polarizability else 0.7) + dft * point["g"] * n_atoms * n_basis
    hessian = hess["h0"] + hess["h1"] * n_atoms * n_basis**3 + dft * hess["h2"] * n_atoms**2 * n_basis
    seconds = points * one + hessian
    integrals = 3.0 * n_basis**4
    grid = dft * n_atoms * 2e4 * n_basis * 8 * 4
    memory = int(_BASE_MEMORY + min(integrals + grid, _PYSCF_MAX_MEMORY))
    kind = "Hartree-Fock" if choice.hartree_fock else "DFT"
    detail = (f"{points} SCF+gradient calculations ({kind}, {n_basis} basis functions, {n_electrons} electrons, "
              f"{n_atoms} atoms; about {one:.2g} s each) and one analytic Hessian (about {hessian:.2g} s)")
    return EngineCost(seconds=seconds, memory=memory, calculations=points, n_basis=n_basis,
                      n_electrons=n_electrons, n_atoms=n_atoms, level=choice.level, detail=detail)


def cheaper_choices(choice: EngineChoice, numbers: ArrayLike, seconds: float, memory: float) -> list[str]:
    """Levels that fit within `seconds` and `memory` (bytes) for this molecule, cheapest basis
    first: the same method in smaller bases, then Hartree-Fock, then xtb, in words."""
    fits: list[str] = []
    if choice.engine == "pyscf":
        for method in dict.fromkeys((str(choice.method), "hf")):
            for basis in _CHEAPER_BASES:
                other = EngineChoice("pyscf", method, basis)
                try:
                    cost = engine_cost(other, numbers)
                except EngineChoiceError:
                    continue
                if cost.seconds <= seconds and cost.memory <= memory:
                    fits.append(f"method = {method!r}, basis = {basis!r} (about {cost.seconds:.2g} s)")
    xtb = engine_cost(EngineChoice("xtb", XTB_METHODS[0]), numbers)
    if xtb.seconds <= seconds:
        fits.append(f"engine = \"xtb\" (about {xtb.seconds:.2g} s)")
    return fits[:4]
