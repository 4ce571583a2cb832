"""Thermochemistry of independent harmonic oscillators (ZPE, q, U, C_v, S, F), as ASE's
``HarmonicThermo``."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import constants

from vibra.spectra.scale_factors import scale_factor as level_factor
from vibra._core import validate as _validate
from vibra._core.frozen import span
from vibra._results import Result, stored
from vibra.modes import Modes
from vibra.molecules import VibrationalAnalysis
from vibra.spectra.common import ZERO_RTOL, nonnegative_float, vibrational_mask

__all__ = ["BOLTZMANN_EV_PER_K", "GRIMME_BAV", "LOW_FREQUENCY", "Thermochemistry", "thermochemistry", "check_finite",
           "warn_negative_entropy"]

#: Boltzmann's constant in eV/K (CODATA 2018 via scipy; ase.units.kB is CODATA 2014 and
#: differs by 3.4e-7 relative).
BOLTZMANN_EV_PER_K = constants.k / constants.e

#: E = h c nu~ : eV per cm^-1.
_EV_PER_CM1 = constants.h * constants.c / constants.centi / constants.e

#: The treatments of low frequencies (`thermochemistry`'s `low_frequency`).
LOW_FREQUENCY = (None, "grimme", "truhlar")

#: Grimme's average moment of inertia B_av of the free rotor his interpolation tends to, kg m^2
#: (S. Grimme, Chem. Eur. J. 18, 9955 (2012); GoodVibes' default).
GRIMME_BAV = 1.0e-44


class LowModes:
    """The `path` of a thermochemistry result (`Thermochemistry`, `vibra.spectra.ideal_gas.IdealGasThermochemistry`,
    listed before `Result` among its bases): the treatment of its low modes, its `low_frequency` field."""

    low_frequency: str | None

    @property
    def path(self) -> str:
        """How the low modes were treated: ``"harmonic"`` (none), ``"grimme"`` or ``"truhlar"``."""
        return self.low_frequency or "harmonic"


@dataclass(frozen=True, eq=False, repr=False)
class Thermochemistry(LowModes, Result):
    """Harmonic vibrational thermochemistry at several temperatures (a `vibra._results.Result` over
    the temperatures; `path` is the treatment of the low modes, ``"harmonic"`` when none).

    Energies are measured from the bottom of the potential well (as ASE's HarmonicThermo
    does with potentialenergy=0) unless stated otherwise.

    Attributes
    ----------
    temperatures : (n_T,) ndarray
        Temperatures, in K.
    wavenumbers : (n_vib,) ndarray
        Wavenumbers of the modes counted, ascending, in cm^-1.
    vibrational_energies : (n_vib,) ndarray
        Quanta hbar omega_k = h c nu~_k, in eV.
    zero_point_energy : float
        sum_k hbar omega_k / 2, in eV.
    log_partition_function : (n_T,) ndarray
        ln q_ZPE = -sum_k ln(1 - exp(-x_k)), x_k = hbar omega_k / kT: the partition function
        with energies counted from the ground state (the zero-point level); q_ZPE -> 1 as
        T -> 0. Kept as a logarithm so that its tiny low-T values keep their digits
        (`partition_function` gives q_ZPE itself).
    log_partition_function_bottom : (n_T,) ndarray
        ln q_BOT = ln q_ZPE - ZPE / kT: energies counted from the bottom of the well (q_BOT
        itself underflows at low T).
    internal_energy : (n_T,) ndarray
        U = ZPE + sum_k hbar omega_k / (exp(x_k) - 1), in eV.
    heat_capacity : (n_T,) ndarray
        C_v = k sum_k x_k^2 e^x_k / (e^x_k - 1)^2, in eV/K.
    entropy : (n_T,) ndarray
        S = k sum_k [x_k / (e^x_k - 1) - ln(1 - e^-x_k)], in eV/K.
    helmholtz_energy : (n_T,) ndarray
        F = U - T S = ZPE + kT sum_k ln(1 - e^-x_k) = -kT ln q_BOT, in eV.
    n_imaginary : int
        Imaginary modes left out.
    low_frequency : {None, "grimme", "truhlar"}
        How the low modes were treated (see `thermochemistry`); None: every mode harmonic.
    scale_factor : float
        The factor every frequency was multiplied by first (1: none).
    internal_energy_error, entropy_error, helmholtz_energy_error : (n_T,) ndarray
        Bounds on U, S and F propagated from each frequency's own bound (`Modes.omega_error`,
        which holds the solver's bound and, for finite-difference Hessians, what the analysis put
        there): sum_k |dQ/d nu_k| error_k, a worst case (errors of the same sign). Zero for
        wavenumbers given as numbers.
    """

    STORED = {"temperatures": stored(("n_T",)), "wavenumbers": stored(("n_vib",)),  # (vibra._results)
              "vibrational_energies": stored(("n_vib",)), "log_partition_function": stored(("n_T",)),
              **dict.fromkeys(("log_partition_function_bottom", "internal_energy", "heat_capacity", "entropy",
                               "helmholtz_energy"), stored(("n_T",))),
              **dict.fromkeys(("internal_energy_error", "entropy_error", "helmholtz_energy_error"),
                              stored(("n_T",), optional=True))}
    AXIS, NOUNS = "n_T", ("temperature", "temperatures")

    temperatures: NDArray[np.float64]
    wavenumbers: NDArray[np.float64]
    vibrational_energies: NDArray[np.float64]
    zero_point_energy: float
    log_partition_function: NDArray[np.float64]
    log_partition_function_bottom: NDArray[np.float64]
    internal_energy: NDArray[np.float64]
    heat_capacity: NDArray[np.float64]
    entropy: NDArray[np.float64]
    helmholtz_energy: NDArray[np.float64]
    n_imaginary: int
    low_frequency: str | None = None
    scale_factor: float = 1.0
    internal_energy_error: NDArray[np.float64] | None = None
    entropy_error: NDArray[np.float64] | None = None
    helmholtz_energy_error: NDArray[np.float64] | None = None

    def _repr_parts(self) -> tuple[str, ...]:
        return (f"{self._size()} {span(self.temperatures, 'K')}", f"{self.wavenumbers.size} modes",
                f"ZPE {self.zero_point_energy:.6g} eV", f"{self.n_imaginary} imaginary left out" if self.n_imaginary
                else "", f"scaled by {self.scale_factor:g}" if self.scale_factor != 1.0 else "")

    @property
    def partition_function(self) -> NDArray[np.float64]:
        """(n_T,) q_ZPE = exp(log_partition_function), dimensionless."""
        return np.exp(self.log_partition_function)

    def heat_capacity_j_per_mol_k(self) -> NDArray[np.float64]:
        """(n_T,) C_v per mole, in J/(mol K)."""
        return self.heat_capacity * constants.e * constants.N_A

    def entropy_j_per_mol_k(self) -> NDArray[np.float64]:
        """(n_T,) S per mole, in J/(mol K)."""
        return self.entropy * constants.e * constants.N_A

    def table(self) -> str:
        """Text table: T (K), U (eV), C_v and S (J/(mol K)), F (eV), q_ZPE."""
        lines = [
            f"harmonic vibrations: {len(self.wavenumbers)} modes, ZPE = {self.zero_point_energy:.6f} eV"
            + (f", {self.n_imaginary} imaginary mode(s) left out" if self.n_imaginary else ""),
            "      T/K        U/eV   Cv/(J/mol/K)    S/(J/mol/K)        F/eV        q_ZPE",
        ]
        cv, s = self.heat_capacity_j_per_mol_k(), self.entropy_j_per_mol_k()
        for i, t in enumerate(self.temperatures):
            lines.append(
                f"{t:9.2f}  {self.internal_energy[i]:10.6f}  {cv[i]:13.5f}  {s[i]:13.5f}  "
                f"{self.helmholtz_energy[i]:10.6f}  {self.partition_function[i]:11.6g}"
            )
        return "\n".join(lines)



def thermochemistry(
    modes: Modes | VibrationalAnalysis | ArrayLike,
    temperatures: ArrayLike,
    *,
    zero_rtol: float = ZERO_RTOL,
    low_frequency: str | None = None,
    cutoff: float = 100.0,
    scale_factor: float = 1.0,
    bav: float = GRIMME_BAV,
) -> Thermochemistry:
    """Vibrational ZPE, partition function, U, C_v, S and F of independent harmonic modes.

    With x_k = hbar omega_k / kT: q_ZPE = prod 1/(1 - e^-x_k),
    U = ZPE + sum hbar omega_k / (e^x_k - 1), C_v = k sum x_k^2 e^x_k / (e^x_k - 1)^2,
    S = k sum [x_k / (e^x_k - 1) - ln(1 - e^-x_k)], F = U - T S. These are the formulas of
    ASE's HarmonicThermo (and the vibrational part of IdealGasThermo); k is CODATA 2018.

    Parameters
    ----------
    modes : Modes or VibrationalAnalysis or (n_modes,) array_like
        Normal modes in physical units, a molecule's `VibrationalAnalysis` (its rigid-body
        modes are left out exactly), or signed wavenumbers in cm^-1 (negative = imaginary).
    temperatures : float or (n_T,) array_like
        Temperatures, in K (> 0).
    zero_rtol : float
        Modes with |omega| <= zero_rtol * max|omega| (rigid-body motion) are left out.
        Imaginary modes are left out with a RuntimeWarning (a transition state's one imaginary
        mode, the reaction coordinate, is not a vibration: `n_imaginary` says it was left out).
    low_frequency : {None, "grimme", "truhlar"}
        The soft modes that the harmonic model overcounts (its entropy diverges as nu -> 0):
        ``"grimme"``, the quasi-RRHO model: per mode, S = w S_harmonic + (1 - w) S_free-rotor
        with w = 1 / (1 + (cutoff / nu)^4) (S. Grimme, Chem. Eur. J. 18, 9955 (2012); the free
        rotor of moment mu' = mu B_av / (mu + B_av), mu = h / (8 pi^2 nu)), and the internal
        energy interpolated the same way towards kT / 2 (Y.-P. Li, J. Gomes, S. M. Sharada, A. T.
        Bell, M. Head-Gordon, J. Phys. Chem. C 119, 1840 (2015)), C_v with it: GoodVibes'
        ``QS="grimme", QH=True``; ``"truhlar"``, frequencies below the cutoff raised to it for
        the entropy (R. F. Ribeiro, A. V. Marenich, C. J. Cramer, D. G. Truhlar, J. Phys. Chem.
        B 115, 14556 (2011)), U and C_v harmonic: GoodVibes' ``QS="truhlar"``.
    cutoff : float
        nu_0 of the treatment, in cm^-1 (> 0; 100 by default, as both papers).
    scale_factor : float or str
        Every frequency is multiplied by it first (> 0): the empirical scale factor of the
        level of theory the Hessian came from, 1 for none; or that level's name
        (``"B3LYP/6-31G(d)"``) for its factor in `vibra.spectra.SCALE_FACTORS` (Alecu, Zheng,
        Zhao and Truhlar 2010).
    bav : float
        Grimme's B_av, kg m^2 (> 0).

    Returns
    -------
    Thermochemistry

    Raises
    ------
    TypeError
        `modes` neither a Modes nor an array of numbers.
    ValueError
        Dimensionless modes; wavenumbers or temperatures not 1-D, not finite, or
        temperatures not positive; an unknown `low_frequency`; a cutoff, scale factor or B_av
        not positive and finite; a temperature at which a result is not a finite float (k_B T
        near the smallest float, ~1e-304 K and below, or T near the largest): the message names
        the temperature, the quantity and the mode. Down to there the limits are exact: at
        T = 1e-300 K, C_v = S = 0 and U = F = ZPE.

    Warns
    -----
    RuntimeWarning
        Imaginary modes left out; with ``"grimme"``, a negative total entropy (its classical free
        rotors do not hold below ~0.01 K), naming the temperatures and the mode.

    Examples
    --------
    >>> thermo = thermochemistry([1000.0], [300.0])       # one mode at 1000 cm^-1
    >>> round(thermo.zero_point_energy, 6)                  # h c (1000 cm^-1) / 2, in eV
    0.061992
    """
    zero_rtol = nonnegative_float(zero_rtol, "zero_rtol")
    _validate.choice(low_frequency, "low_frequency", LOW_FREQUENCY)
    cutoff = _validate.positive_scalar(cutoff, "cutoff", "cutoff (cm^-1)")
    scale_factor = _validate.positive_scalar(level_factor(scale_factor), "scale_factor", "frequency scale factor")
    bav = _validate.positive_scalar(bav, "bav", "average moment of inertia (kg m^2)")
    rigid = None
    if isinstance(modes, VibrationalAnalysis):
        rigid = np.asarray(modes.rigid)
        modes = modes.modes
    if isinstance(modes, Modes):
        if modes.units.time_s is None:
            raise ValueError("modes are dimensionless; thermochemistry needs units 'SI' or 'ASE'")
        keep = vibrational_mask(modes, zero_rtol, "thermochemistry", rigid)
        order = np.argsort(modes.wavenumbers_cm1()[keep], kind="stable")
        wavenumbers = modes.wavenumbers_cm1()[keep][order]
        bounds = np.abs(modes.units.omega_to_cm1(modes.omega_error[keep]))[order]
        skipped = modes.zero_modes(zero_rtol) | (rigid if rigid is not None else False)
        n_imaginary = int(np.sum(modes.unstable & ~skipped))
    else:
        signed = _validate.real_array(modes, "modes", ndim=1)
        keep, n_imaginary = _vibrational_values(signed, zero_rtol, "thermochemistry")
        wavenumbers = np.sort(signed[keep])
        bounds = np.zeros_like(wavenumbers)
    temps = _validate.real_array(temperatures, "temperatures", ndim=(0, 1))
    temps = np.atleast_1d(temps)
    _validate.positive(temps, "temperatures", "temperature")
    wavenumbers = wavenumbers * scale_factor
    bounds = bounds * scale_factor

    energies = wavenumbers * _EV_PER_CM1                        # (n_vib,) eV
    kt = BOLTZMANN_EV_PER_K * temps                             # (n_T,) eV
    zpe = 0.5 * float(np.sum(energies))
    with np.errstate(all="ignore"):                             # each result checked below, by temperature and mode
        x = energies[None, :] / kt[:, None]
        log_q = -np.sum(_log_one_minus(x), axis=1)              # the harmonic partition function
        u, s, c = _per_mode(wavenumbers, temps, low_frequency, cutoff, bav)
        internal, entropy, heat_capacity = u.sum(axis=1), s.sum(axis=1), c.sum(axis=1)
        # each frequency's bound: every per-mode term evaluated at nu -+ its bound, the larger
        # change counted (the terms are monotonic in nu: the exact worst case of independent
        # errors, curvature included, where a first-order dQ/dnu would fall short)
        f = u - temps[:, None] * s
        changes = []
        for moved in (wavenumbers + bounds, np.maximum(wavenumbers - bounds, 1e-300)):
            mu, ms, _ = _per_mode(moved, temps, low_frequency, cutoff, bav)
            changes.append((np.abs(mu - u), np.abs(ms - s), np.abs(mu - temps[:, None] * ms - f)))
        u_error, s_error, f_error = (np.maximum(up, down).sum(axis=1) for up, down in zip(*changes))
        helmholtz = internal - temps * entropy
        log_q_bottom = log_q - zpe / kt
    check_finite("thermochemistry", temps, wavenumbers,
                 per_mode={"internal_energy": u, "entropy": s, "heat_capacity": c, "helmholtz_energy": f},
                 totals={"internal_energy": internal, "entropy": entropy, "heat_capacity": heat_capacity,
                         "helmholtz_energy": helmholtz, "log_partition_function": log_q,
                         "log_partition_function_bottom": log_q_bottom, "internal_energy_error": u_error,
                         "entropy_error": s_error, "helmholtz_energy_error": f_error})
    if low_frequency == "grimme" and np.any(entropy < 0):       # its free rotors are classical
        k = int(np.argmin(s[int(np.argmax(entropy < 0))]))
        warn_negative_entropy("thermochemistry", temps, entropy,
                              {f"Grimme's free rotor of the mode at {float(wavenumbers[k]):.6g} cm^-1": s[:, k]})
    return Thermochemistry(
        temperatures=temps, wavenumbers=wavenumbers, vibrational_energies=energies,
        zero_point_energy=zpe, log_partition_function=log_q,
        log_partition_function_bottom=log_q_bottom, internal_energy=internal,
        heat_capacity=heat_capacity, entropy=entropy, helmholtz_energy=helmholtz,
        n_imaginary=n_imaginary, low_frequency=low_frequency, scale_factor=scale_factor,
        internal_energy_error=u_error, entropy_error=s_error, helmholtz_energy_error=f_error,
    )


def _log_one_minus(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """ln(1 - e^-x): log1p keeps the digits when e^-x is tiny, log(-expm1) when x is small."""
    return np.where(x > np.log(2.0), np.log1p(-np.exp(-x)), np.log(-np.expm1(-x)))


def _harmonic(energies: NDArray[np.float64], kt: NDArray[np.float64]
              ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Per temperature (rows) and mode (columns): U = hbar omega (1/2 + 1 / (e^x - 1)), S and C_v."""
    x = energies[None, :] / kt[:, None]
    decay = np.exp(-x)
    one_minus = -np.expm1(-x)                                   # 1 - e^-x, accurate for small x
    occupation = decay / one_minus                              # 1 / (e^x - 1)
    u = energies[None, :] * (0.5 + occupation)
    s = BOLTZMANN_EV_PER_K * (x * occupation - _log_one_minus(x))
    # x^2 e^-x / (1 - e^-x)^2 as a square: x^2 alone overflows (T -> 0) or underflows with
    # (1 - e^-x)^2 (T -> infinity) where the quotient is 0 or 1
    c = BOLTZMANN_EV_PER_K * (x * np.exp(-0.5 * x) / one_minus) ** 2
    return u, s, c


def _per_mode(wavenumbers: NDArray[np.float64], temps: NDArray[np.float64], low_frequency: str | None,
              cutoff: float, bav: float) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """U, S, C_v per temperature and mode (eV, eV/K), with the low modes treated as asked."""
    kt = BOLTZMANN_EV_PER_K * temps
    u, s, c = _harmonic(wavenumbers * _EV_PER_CM1, kt)
    if low_frequency == "truhlar":
        s = _harmonic(np.maximum(wavenumbers, cutoff) * _EV_PER_CM1, kt)[1]
    elif low_frequency == "grimme":
        w = 1.0 / (1.0 + (cutoff / wavenumbers) ** 4)
        mu = constants.h / (8 * np.pi**2 * wavenumbers / constants.centi * constants.c)   # kg m^2
        reduced = bav / (1.0 + bav / mu)                        # mu B_av / (mu + B_av), finite as mu -> inf
        # ln(8 pi^3 mu' k T / h^2) as a sum: the product underflows at a tiny T where its log does not
        rotor = BOLTZMANN_EV_PER_K * (0.5 + 0.5 * (np.log(8 * np.pi**3 * reduced[None, :] * constants.k / constants.h**2)
                                                   + np.log(temps[:, None])))
        s = w * s + (1 - w) * rotor
        u = w * u + (1 - w) * 0.5 * kt[:, None]
        c = w * c + (1 - w) * 0.5 * BOLTZMANN_EV_PER_K
    return u, s, c


def check_finite(where: str, temperatures: NDArray[np.float64], wavenumbers: NDArray[np.float64], *,
                 per_mode: dict[str, NDArray[np.float64]], totals: dict[str, NDArray[np.float64]]) -> None:
    """Raise naming the first temperature (and mode) at which a result is not a finite float.

    `per_mode` arrays are (n_T, n_modes), `totals` (n_T,); `where` names the public function.
    The one check behind `thermochemistry` and `ideal_gas_thermochemistry`: a temperature so
    low (k_B T near the smallest float) or so high that a quantity leaves the floats is refused,
    never returned as NaN or inf.
    """
    for name, values in totals.items():
        bad = ~np.isfinite(values)
        if bad.any():
            i = int(np.argmax(bad))
            modes = per_mode.get(name)
            mode = ""
            if modes is not None and not np.isfinite(modes[i]).all():
                k = int(np.argmax(~np.isfinite(modes[i])))
                mode = f" (the mode at {float(wavenumbers[k]):.6g} cm^-1 gives {float(modes[i, k])!r})"
            kt = BOLTZMANN_EV_PER_K * float(temperatures[i])
            raise ValueError(f"{where}: temperatures[{i}] is {float(temperatures[i])!r} K, where {name} is "
                             f"{float(values[i])!r}{mode}; expected temperatures whose results are finite floats "
                             f"(k_B T = {kt:.3g} eV here)")


def warn_negative_entropy(where: str, temperatures: NDArray[np.float64], entropy: NDArray[np.float64],
                          parts: dict[str, NDArray[np.float64]]) -> None:
    """A RuntimeWarning naming the temperatures where the total `entropy` ((n_T,), eV/K) comes out
    negative, and the most negative of its classical `parts` ((n_T,) each) there: a model that does
    not hold that cold (an entropy is never negative)."""
    negative = entropy < 0
    if not negative.any():
        return
    i = int(np.argmax(negative))
    culprit = min(parts, key=lambda name: float(parts[name][i]))
    cold = np.asarray(temperatures)[negative]
    warnings.warn(f"{where}: the entropy is negative ({float(entropy[i]):.3g} eV/K) at temperatures[{i}] = "
                  f"{float(temperatures[i]):.6g} K ({cold.size} temperature(s) up to {float(cold.max()):.6g} K), "
                  f"from {culprit} ({float(parts[culprit][i]):.3g} eV/K): a classical model that does not hold this "
                  "cold; S, F and G there are not physical", RuntimeWarning, stacklevel=3)


def _vibrational_values(signed: NDArray[np.float64], zero_rtol: float, where: str
                        ) -> tuple[NDArray[np.bool_], int]:
    scale = float(np.abs(signed).max()) if signed.size else 0.0
    zero = np.abs(signed) <= zero_rtol * scale
    imaginary = (signed < 0) & ~zero
    if imaginary.any():
        warnings.warn(
            f"{where}: {int(imaginary.sum())} imaginary mode(s) left out "
            f"(wavenumbers {signed[imaginary].tolist()} cm^-1)", RuntimeWarning, stacklevel=3)
    return ~zero & ~imaginary, int(imaginary.sum())
