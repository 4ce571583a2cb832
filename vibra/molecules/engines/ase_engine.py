"""`AseEngine`: any ASE calculator as an engine (energy and forces; the dipole where the calculator
gives one, e.g. xtb through tblite: IR intensities, no Raman)."""

from __future__ import annotations

import functools
from typing import Any, Collection, Mapping

import numpy as np
from numpy.typing import NDArray

from vibra._core import validate as _validate
from vibra.molecules.displacements import CalculatorOption, CalculatorSource, is_calculator, is_factory
from vibra.molecules.engines.protocol import EngineResult

__all__ = ["AseEngine"]


class AseEngine:
    """An ASE calculator (an instance or a factory, as `vibra.molecules.finite_difference_hessian`
    takes it) behind the `vibra.molecules.engines.Engine` protocol.

    Parameters
    ----------
    calculator : ASE calculator or callable
        An instance (used as it is, in this process) or a factory (a class or a callable with no
        arguments returning a new calculator, called for every geometry, e.g.
        ``functools.partial(TBLite, method="GFN2-xTB")``: needed on a Dask cluster for
        calculators that cannot be pickled).
    level : str, optional
        The level of theory for charts and tables (default: the calculator's ``method``
        parameter where it has one, else its class name).
    noise : mapping, optional
        Noise of one component of ``"forces"`` (eV / Angstrom) or ``"dipole"`` (e Angstrom),
        where known; left out, the forces are probed and the dipole taken at the rounding level.

    Raises
    ------
    TypeError
        `calculator` is neither a calculator nor a factory; `level` not a str.
    ValueError
        A noise that is negative or not finite, or of another property.
    """

    def __init__(self, calculator: CalculatorOption, *, level: str | None = None,
                 noise: Mapping[str, float] | None = None) -> None:
        if not is_calculator(calculator) and not is_factory(calculator):
            raise TypeError(f"calculator must be an ASE calculator or a factory returning one, got "
                            f"{type(calculator).__name__}")
        if level is not None and not isinstance(level, str):
            raise TypeError(f"level must be a str, got {type(level).__name__}")
        self.calculator = calculator
        self._level = level if level else _level_of(calculator)
        given = dict(noise or {})
        for name, value in given.items():
            if name not in ("forces", "dipole"):
                raise ValueError(f"noise[{name!r}]: an ASE calculator's noise is given for 'forces' or 'dipole'")
            given[name] = _validate.nonnegative_scalar(value, f"noise[{name!r}]")
        self._noise = given
        self._source = CalculatorSource(calculator)

    @property
    def level(self) -> str:
        """The level of theory (see the class docstring)."""
        return self._level

    @property
    def capabilities(self) -> frozenset[str]:
        """``{"dipole"}`` when the calculator lists ``dipole`` among its implemented properties."""
        calc = self.calculator
        if is_factory(calc) and not isinstance(calc, type):
            calc = self._source.make()
        listed = getattr(calc, "implemented_properties", ())
        return frozenset({"dipole"}) if "dipole" in listed else frozenset()

    @property
    def noise(self) -> Mapping[str, float]:
        """The given noise, by property."""
        return dict(self._noise)

    def compute(self, numbers: NDArray[np.int_], positions: NDArray[np.float64],
                properties: Collection[str] = ()) -> EngineResult:
        """Energy (eV), forces (eV / Angstrom) and, when asked, the dipole (e Angstrom)."""
        from ase import Atoms

        wrong = [name for name in properties if name != "dipole"]
        if wrong:
            raise ValueError(f"an ASE calculator gives no {wrong[0]!r} here; only 'dipole'")
        atoms = Atoms(numbers=np.asarray(numbers), positions=np.asarray(positions, dtype=float))
        atoms.calc = self._source.make()
        forces = np.asarray(atoms.get_forces(), dtype=float)
        energy = float(atoms.get_potential_energy())
        dipole = np.asarray(atoms.get_dipole_moment(), dtype=float) if "dipole" in properties else None
        return EngineResult(energy=energy, forces=forces, dipole=dipole)

    def hessian(self, numbers: NDArray[np.int_], positions: NDArray[np.float64]) -> NDArray[np.float64]:
        """Not available: an ASE calculator has no analytic Hessian here."""
        raise NotImplementedError(f"{self.level}: no analytic Hessian; use finite differences")

    def __repr__(self) -> str:
        return f"AseEngine({self.level!r})"


def _level_of(calculator: Any) -> str:
    target = calculator
    while isinstance(target, functools.partial):
        method = target.keywords.get("method")
        if isinstance(method, str):
            return method
        target = target.func
    parameters = getattr(calculator, "parameters", None)
    if isinstance(parameters, Mapping) and isinstance(parameters.get("method"), str):
        return str(parameters["method"])
    cls = target if isinstance(target, type) else type(target)
    return cls.__name__
