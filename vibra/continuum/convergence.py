"""Convergence of a uniform chain's lowest modes towards the rod or string (Kneller, Mécanique analytique, eq. 165)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import Frozen
from vibra.chains import ENDS, linear_chain, monatomic_frequencies, periodic_modes
from vibra.chains.builders import Ends

__all__ = ["ConvergenceStudy", "convergence_study", "power_law_fit"]



@dataclass(frozen=True, eq=False)
class ConvergenceStudy(Frozen):
    """The lowest modes of uniform chains of N sites against the continuum, L fixed.

    Attributes
    ----------
    modes : (n_k,) ndarray of int
        Continuum mode labels k (free and fixed ends: omega = k pi c / L; periodic:
        omega = 2 pi k c / L).
    n_sites : (n_N,) ndarray of int
        The chain sizes N.
    ends : str
        End conditions.
    length : float
        L, in length units.
    wave_speed : float
        c = Omega dx, in length per time unit.
    omega_chain : (n_N, n_k) ndarray
        The chains' frequencies, in rad per time unit.
    omega_continuum : (n_k,) ndarray
        The continuum frequencies, in rad per time unit.
    errors : (n_N, n_k) ndarray
        Signed relative errors omega_chain / omega_continuum - 1 (dimensionless).
    order : (n_k,) ndarray
        p from a least-squares fit log|error| = log C - p log(L / dx) (expected: 2), where
        L / dx is N (free, periodic) or N + 1 (fixed).
    coefficient : (n_k,) ndarray
        C of that fit (free and fixed ends: expected (k pi)^2 / 24).
    solver : str
        How the chains were solved: the `Modes.solver` of the runs, or "closed form".
    """

    modes: NDArray[np.int64]
    n_sites: NDArray[np.int64]
    ends: str
    length: float
    wave_speed: float
    omega_chain: NDArray[np.float64]
    omega_continuum: NDArray[np.float64]
    errors: NDArray[np.float64]
    order: NDArray[np.float64]
    coefficient: NDArray[np.float64]
    solver: str

    def expected_coefficient(self) -> NDArray[np.float64]:
        """(n_k,) leading coefficient of |error| N^2 from the small-angle expansion.

        Free and fixed ends (k pi)^2 / 24, periodic (2 k pi)^2 / 24, from
        sin(x) / x - 1 = -x^2 / 6 + ...; shown beside the measured `coefficient`.
        """
        factor = 2.0 if self.ends == "periodic" else 1.0
        return ((factor * self.modes * np.pi) ** 2 / 24.0).astype(np.float64)

    def n_for_error(self, target: float) -> NDArray[np.int64]:
        """(n_k,) smallest N the fit predicts for |error| <= target (dimensionless)."""
        goal = _validate.positive_scalar(target, "target", "error")
        resolution = np.ceil((self.coefficient / goal) ** (1.0 / self.order)).astype(np.int64)
        return resolution - (1 if self.ends == "fixed" else 0)


def power_law_fit(x: ArrayLike, errors: ArrayLike) -> tuple[float, float]:
    """(p, C) of the least-squares fit |error| = C x^-p in log-log.

    Parameters
    ----------
    x : (n,) array_like
        Positive abscissae (chain sizes N, pulse widths, ...), n >= 2, not all equal.
    errors : (n,) array_like
        Non-zero errors (their sign is ignored), dimensionless.

    Returns
    -------
    order, coefficient : float
        p (the convergence order) and C > 0.

    Raises
    ------
    ValueError
        x and errors of different or too short length, x not positive, an error that is
        zero or not finite.

    Examples
    --------
    >>> order, coefficient = power_law_fit([10, 20, 40], [0.03, 0.0075, 0.001875])
    >>> round(order, 12), round(coefficient, 12)
    (2.0, 3.0)
    """
    abscissa = _validate.real_array(x, "x", ndim=1)
    values = _validate.real_array(errors, "errors", ndim=1)
    if abscissa.shape != values.shape or abscissa.size < 2:
        raise ValueError(f"x and errors must be two 1-D arrays of the same length >= 2, got shapes "
                         f"{abscissa.shape} and {values.shape}")
    _validate.positive(abscissa, "x", "abscissa")
    zero = values == 0
    if zero.any():
        raise ValueError(f"errors[{int(np.argmax(zero))}] is 0.0; a power law needs non-zero errors")
    if (abscissa == abscissa[0]).all():
        raise ValueError("x holds one value only; a fit needs two distinct abscissae")
    slope, intercept = np.polyfit(np.log(abscissa), np.log(np.abs(values)), 1)
    return float(-slope), float(np.exp(intercept))


def convergence_study(
    modes: Sequence[int] | ArrayLike,
    n_sites: Sequence[int] | ArrayLike,
    *,
    ends: Ends = "free",
    length: float = 1.0,
    wave_speed: float = 1.0,
    method: Literal["modes", "closed form"] = "modes",
    accuracy: Literal["high", "fast"] = "high",
) -> ConvergenceStudy:
    """Error of a chain's lowest modes against the rod or string as N grows, L fixed.

    For each N the chain has spacing dx = L / N (free, periodic) or L / (N + 1) (fixed),
    Omega = c / dx and unit masses; its frequencies are computed by
    ``linear_chain(...).modes(n_modes, accuracy=accuracy)`` (free, fixed) or
    `vibra.chains.periodic_modes` (periodic), or by the closed form with
    ``method="closed form"``. The order is then fitted, not assumed.

    Parameters
    ----------
    modes : (n_k,) sequence of int
        Continuum mode labels k >= 1 (the zero mode of free and periodic chains has no
        relative error).
    n_sites : (n_N,) sequence of int
        Chain sizes, each >= 2 and large enough to hold mode k.
    ends : {"free", "fixed", "periodic"}
        End conditions of the chain and of the continuum.
    length : float
        L, in length units.
    wave_speed : float
        c, in length per time unit.
    method : {"modes", "closed form"}
        Solve the chains, or evaluate `vibra.chains.monatomic_frequencies`.
    accuracy : {"high", "fast"}
        Passed to `System.modes` for free and fixed chains.

    Returns
    -------
    ConvergenceStudy

    Raises
    ------
    ValueError
        A mode label < 1, fewer than two sizes, a size too small for the modes, bad length,
        speed, ends or method.

    Examples
    --------
    >>> import numpy as np
    >>> study = convergence_study([1, 2], [20, 40, 80])
    >>> np.round(study.order, 2), np.round(study.coefficient / study.expected_coefficient(), 2)
    (array([2., 2.]), array([1., 1.]))
    """
    ks = np.asarray(modes)
    if ks.ndim != 1 or ks.size == 0 or not np.issubdtype(ks.dtype, np.integer):
        raise ValueError(f"modes must be a 1-D sequence of int mode labels, got {modes!r}")
    if (ks < 1).any():
        i = int(np.argmax(ks < 1))
        raise ValueError(f"modes[{i}] is {ks[i]}; mode labels start at 1 (the zero mode has no relative error)")
    sizes = _validate.increasing_counts(n_sites, "n_sites")
    _validate.choice(ends, "ends", ENDS)
    L = _validate.positive_scalar(length, "length", "length")
    c = _validate.positive_scalar(wave_speed, "wave_speed", "speed")
    _validate.choice(method, "method", ("modes", "closed form"))
    _validate.choice(accuracy, "accuracy", ("high", "fast"))
    # Position of continuum mode k in the chain's ascending spectrum.
    position = 2 * ks - 1 if ends == "periodic" else (ks if ends == "free" else ks - 1)
    small = sizes < max(int(position.max()) + 1, 2)
    if small.any():
        i = int(np.argmax(small))
        raise ValueError(f"n_sites[{i}] is {sizes[i]}; it must be >= {max(int(position.max()) + 1, 2)} "
                         "to hold the requested modes")
    omega_continuum = ks * np.pi * c / L * (2.0 if ends == "periodic" else 1.0)
    omega_chain = np.empty((sizes.size, ks.size))
    solvers: set[str] = set()
    for row, n in enumerate(sizes):
        n = int(n)
        dx = L / (n + 1) if ends == "fixed" else L / n
        stiffness = (c / dx) ** 2  # unit masses: Omega = c / dx
        wanted = int(position.max()) + 1
        if method == "closed form":
            omega = monatomic_frequencies(n, 1.0, stiffness, ends=ends)[:wanted]
            solvers.add("closed form")
        else:
            system = linear_chain(n, mass=1.0, stiffness=stiffness, spacing=dx, ends=ends,
                                         units="dimensionless")
            if ends == "periodic":
                result = periodic_modes(system, n_modes=wanted, vectors=False)
            else:
                result = system.modes(n_modes=wanted, accuracy=accuracy, vectors=False)
            omega = result.omega
            solvers.add(result.solver)
        omega_chain[row] = omega[position]
    errors = omega_chain / omega_continuum[None, :] - 1.0
    resolution = sizes.astype(float) + (1.0 if ends == "fixed" else 0.0)  # L / dx
    fits = [power_law_fit(resolution, errors[:, i]) for i in range(ks.size)]
    return ConvergenceStudy(
        modes=ks.astype(np.int64), n_sites=sizes.astype(np.int64), ends=ends, length=L, wave_speed=c,
        omega_chain=omega_chain, omega_continuum=omega_continuum, errors=errors,
        order=np.array([f[0] for f in fits]), coefficient=np.array([f[1] for f in fits]),
        solver=", ".join(sorted(solvers)),
    )


