"""Harmonic thermal properties of a crystal from its phonons on a mesh.

Per unit cell, with x = hbar omega / k_B T and the mesh average <.> = sum_q w_q (.) / sum_q w_q:

    F   = sum_nu < hbar omega / 2 + k_B T ln(1 - e^-x) >        (Helmholtz free energy)
    S   = k_B sum_nu < x / (e^x - 1) - ln(1 - e^-x) >            (entropy)
    C_v = k_B sum_nu < x^2 e^x / (e^x - 1)^2 >                   (heat capacity)
    E_0 = sum_nu < hbar omega / 2 >                              (zero-point energy)

as phonopy's ``run_thermal_properties``. Modes whose omega is not certainly positive (omega
<= omega_error: the acoustic modes at Gamma, and imaginary modes) are left out of the sums,
as phonopy does with ``exclude_gamma_acoustic=True`` and its default cutoff 0.

Units: the fields are per unit cell in the crystal's energy unit (J for SI, eV for ASE) and
energy per kelvin; the methods ``*_kj_mol`` / ``*_j_k_mol`` give phonopy's units, per mole of
unit cells (kJ/mol, J/K/mol). Constants from scipy.constants (CODATA); phonopy's defaults are
older (its k_B and h differ by ~1e-7), so the two agree to that unless phonopy is given the
same constants (``phonopy.physical_units.set_physical_units``; the tests do).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import constants

from vibra._core import validate as _validate
from vibra._core.frozen import span
from vibra._results import Result, stored
from vibra.crystals.dynamical import phonons
from vibra.crystals.mesh import mesh_points
from vibra.units import UnitSystem

if TYPE_CHECKING:
    from vibra.crystals.force_constants import CrystalLike as Crystal  # the protocol: no import cycle

__all__ = ["ThermalProperties", "thermal_properties"]

#: Entries of the (temperatures x modes) temporaries per chunk (8 MiB each): thermal sums in chunks
#: of temperatures, so memory stays bounded whatever the number of temperatures and mesh points.
THERMAL_CHUNK = 1 << 20
#: A mode with hbar omega / kT above this contributes nothing in double precision (e^-x < 1e-300):
#: it is frozen, and x is capped there so that x e^-x stays 0 instead of inf * 0 = NaN.
FROZEN_X = 690.0


@dataclass(frozen=True, eq=False, repr=False)
class ThermalProperties(Result):
    """Harmonic thermal properties per unit cell against temperature (a `vibra._results.Result` over
    the temperatures).

    Attributes
    ----------
    temperatures : (n_t,) ndarray
        In K.
    free_energy : (n_t,) ndarray
        Helmholtz free energy (zero-point energy included), in the energy unit of `units`.
    entropy : (n_t,) ndarray
        In energy unit per K.
    heat_capacity : (n_t,) ndarray
        At constant volume, in energy unit per K.
    zero_point_energy : float
        In the energy unit.
    excluded : int
        Modes of the mesh (over all grid points) left out as not certainly positive.
    mesh : (3,) ndarray of int
        The mesh.
    units : UnitSystem
        The crystal's units.
    path : str
        How the mesh's frequencies were solved (`Phonons.path`).
    """

    STORED = {"temperatures": stored(("n_t",)), "free_energy": stored(("n_t",)),  # how save / load check them
              "entropy": stored(("n_t",)), "heat_capacity": stored(("n_t",)), "mesh": stored((3,), kind="int")}
    AXIS, NOUNS = "n_t", ("temperature", "temperatures")

    temperatures: NDArray[np.float64]
    free_energy: NDArray[np.float64]
    entropy: NDArray[np.float64]
    heat_capacity: NDArray[np.float64]
    zero_point_energy: float
    excluded: int
    mesh: NDArray[np.int64]
    units: UnitSystem
    path: str = "hermitian-eigh"

    def _repr_parts(self) -> tuple[str, ...]:
        mesh = "x".join(str(int(n)) for n in self.mesh)
        return (f"{self._size()} {span(self.temperatures, 'K')}", f"mesh {mesh}",
                f"zero-point energy {self.zero_point_energy:.6g} {self.units.energy}",
                f"{self.excluded} excluded" if self.excluded else "")

    def _per_mole(self) -> float:
        return energy_unit_joule(self.units) * constants.Avogadro

    def free_energy_kj_mol(self) -> NDArray[np.float64]:
        """(n_t,) free energy per mole of unit cells, in kJ/mol (phonopy's unit)."""
        return self.free_energy * self._per_mole() / constants.kilo

    def entropy_j_k_mol(self) -> NDArray[np.float64]:
        """(n_t,) entropy per mole of unit cells, in J/K/mol."""
        return self.entropy * self._per_mole()

    def heat_capacity_j_k_mol(self) -> NDArray[np.float64]:
        """(n_t,) heat capacity per mole of unit cells, in J/K/mol."""
        return self.heat_capacity * self._per_mole()

    def zero_point_energy_kj_mol(self) -> float:
        """Zero-point energy per mole of unit cells, in kJ/mol."""
        return self.zero_point_energy * self._per_mole() / constants.kilo


def energy_unit_joule(units: UnitSystem) -> float:
    """One energy unit of `units` in J (SI: 1, ASE: the electronvolt); refused when dimensionless."""
    if units.name == "SI":
        return 1.0
    if units.name == "ASE":
        return constants.electron_volt
    raise ValueError(f"thermal properties need physical units (hbar and k_B); the crystal is {units.name}: "
                     "build it with units='SI' or 'ASE'")


def thermal_properties(crystal: Crystal, temperatures: ArrayLike, *, mesh: int | Sequence[int], symmetry: bool = True
                       ) -> ThermalProperties:
    """Free energy, entropy, heat capacity and zero-point energy per unit cell (module docstring).

    Parameters
    ----------
    crystal : Crystal
        With force constants, in SI or ASE units.
    temperatures : (n_t,) array_like
        Temperatures >= 0, in K.
    mesh : int or 3 ints
        Gamma-centred q-point mesh (as `vibra.crystals.dos.dos`).
    symmetry : bool
        Reduce the mesh by symmetry (spglib).

    Raises
    ------
    ValueError
        Negative or non-finite temperatures; a bad mesh; dimensionless units.
    """
    joule = energy_unit_joule(crystal.units)
    t = _validate.real_array(temperatures, "temperatures", ndim=(0, 1))
    t = np.atleast_1d(t)
    if (t < 0).any():
        i = int(np.argmax(t < 0))
        raise ValueError(f"temperatures[{i}] is {float(t[i])!r}; temperatures must be >= 0 K")
    crystal.require_force_constants()
    points = mesh_points(crystal, mesh, symmetry=symmetry)
    result = phonons(crystal, points.qpoints)
    keep = result.omega > result.omega_error
    weights = np.broadcast_to(points.weights[:, None], keep.shape)[keep].astype(float)
    total = float(points.weights.sum())
    energy = crystal.units.omega_to_rad_per_s(result.omega[keep]) * constants.hbar / joule  # hbar omega
    kb = constants.k / joule
    zero_point = float(weights @ (energy / 2.0)) / total
    free = np.full(t.shape, zero_point)
    entropy = np.zeros(t.shape)
    heat = np.zeros(t.shape)
    hot = np.nonzero(t > 0)[0]
    step = max(1, THERMAL_CHUNK // max(1, energy.size))  # temperatures per chunk: memory bounded whatever n_t
    for start in range(0, hot.size, step):
        rows = hot[start:start + step]
        kt = kb * t[rows][:, None]
        with np.errstate(over="ignore"):  # x = E / kT overflows at kT ~ 1e-300 K: the mode is frozen
            x = energy[None, :] / kt
        frozen = x > FROZEN_X
        x = np.where(frozen, FROZEN_X, x)
        em = np.where(frozen, 0.0, np.exp(-x))
        om = -np.expm1(-x)  # 1 - e^-x without cancellation
        free[rows] = zero_point + (kt[:, 0] * (np.log(om) @ weights)) / total
        entropy[rows] = kb * ((x * em / om - np.log(om)) @ weights) / total
        heat[rows] = kb * ((x ** 2 * em / om ** 2) @ weights) / total
    excluded = int(np.broadcast_to(points.weights[:, None], keep.shape)[~keep].sum())
    return ThermalProperties(temperatures=t, free_energy=free, entropy=entropy, heat_capacity=heat,
                             zero_point_energy=zero_point, excluded=excluded, mesh=points.size, units=crystal.units,
                             path=result.path)
