"""Derivatives of the dipole and the polarisability along Cartesian displacements, from the very
geometries of a finite-difference Hessian (`finite_difference_hessian(..., properties=...)`), with
the same stencils and the same error estimate (Richardson truncation + noise / step).

The central-difference arithmetic itself (`central_difference`: the 2- and 4-point stencils and
their Richardson estimates) is shared with the Hessian, so that both are computed alike.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from vibra._core.frozen import Frozen
from vibra.molecules.displacement_symmetry import Reduction
from vibra.molecules.displacements import PROPERTY_ROWS, Displacement
from vibra.molecules.noise import rounding_noise

__all__ = ["PropertyDerivatives", "central_difference", "check_properties", "property_derivatives",
           "PROPERTY_UNITS"]

#: Unit of each property value (its noise is given in it too).
PROPERTY_UNITS = {"dipole": "e Angstrom", "polarizability": "Angstrom^3"}


@dataclass(frozen=True, eq=False)
class PropertyDerivatives(Frozen):
    """The dipole and polarisability derivatives of one finite-difference run, with error estimates.

    Attributes
    ----------
    dipole : (3 n_atoms, 3) ndarray or None
        d mu_a / d x_ib at row 3 i + b, column a, in e (e Angstrom per Angstrom); None when the
        dipole was not asked for.
    dipole_error : (3 n_atoms, 3) ndarray or None
        Estimated absolute error of each entry (truncation + round-off), in e.
    polarizability : (3 n_atoms, 3, 3) ndarray or None
        d alpha_ac / d x_ib at [3 i + b, a, c], in Angstrom^2 (Angstrom^3 per Angstrom; alpha is
        a polarisability volume, alpha_SI / (4 pi epsilon_0)).
    polarizability_error : (3 n_atoms, 3, 3) ndarray or None
        Estimated absolute error of each entry, in Angstrom^2.
    reference_dipole : (3,) ndarray or None
        The dipole at the reference geometry, in e Angstrom.
    reference_polarizability : (3, 3) ndarray or None
        The polarisability at the reference geometry, in Angstrom^3.
    noise : tuple of (str, float) pairs
        Noise of one component of each property behind its round-off part, in its unit
        (`PROPERTY_UNITS`): the given value, or the rounding level (8 machine epsilons of the
        largest value).
    noise_source : tuple of (str, str) pairs
        ``"given"`` or ``"rounding"`` for each property.
    error_method : str
        ``"richardson"`` (a coarser step was evaluated) or ``"none"`` (round-off only).
    """

    dipole: NDArray[np.float64] | None
    dipole_error: NDArray[np.float64] | None
    polarizability: NDArray[np.float64] | None
    polarizability_error: NDArray[np.float64] | None
    reference_dipole: NDArray[np.float64] | None
    reference_polarizability: NDArray[np.float64] | None
    noise: tuple[tuple[str, float], ...]
    noise_source: tuple[tuple[str, str], ...]
    error_method: str


def check_properties(properties: object, noise: object) -> tuple[tuple[str, ...], dict[str, float]]:
    """The property names (validated, in order) and their given noise (validated) for a run."""
    if isinstance(properties, str) or not isinstance(properties, (list, tuple)):
        raise TypeError(f"properties must be a list or tuple of names among {sorted(PROPERTY_ROWS)}, "
                        f"got {type(properties).__name__}")
    names: list[str] = []
    for i, name in enumerate(properties):
        if name not in PROPERTY_ROWS or name in names:
            raise ValueError(f"properties[{i}] is {name!r}; expected distinct names among {sorted(PROPERTY_ROWS)}")
        names.append(name)
    given: dict[str, float] = {}
    if noise is not None:
        if not isinstance(noise, Mapping):
            raise TypeError(f"property_noise must be a mapping of property name to noise, got {type(noise).__name__}")
        for name, value in noise.items():
            if name not in names:
                raise ValueError(f"property_noise[{name!r}] is given but {name!r} is not among properties {names}")
            number = float(value) if isinstance(value, (int, float, np.integer, np.floating)) \
                and not isinstance(value, bool) else float("nan")
            if not (number >= 0 and np.isfinite(number)):
                raise ValueError(f"property_noise[{name!r}] is {value!r}; expected a number >= 0 "
                                 f"({PROPERTY_UNITS[name]})")
            given[name] = number
    return tuple(names), given


def central_difference(quotients: Mapping[int, NDArray[np.float64]], stencil: int,
                       estimate_error: bool) -> tuple[NDArray[np.float64], NDArray[np.float64] | None, float]:
    """The stencil's derivative from the difference quotients D(m h) of each step multiple m.

    2-point: D(h), Richardson truncation |D(h) - D(2h)| / 3; 4-point: R(h) = (4 D(h) - D(2h)) / 3,
    truncation |R(h) - R(2h)| / 15. Returns the derivative, the truncation estimate (None without
    `estimate_error`) and the noise gain g: a noise sigma per value gives a round-off g sigma / h.
    """
    if stencil == 2:
        truncation = np.abs(quotients[1] - quotients[2]) / 3.0 if estimate_error else None
        return quotients[1], truncation, float(np.sqrt(2.0) / 2.0)
    raw = (4.0 * quotients[1] - quotients[2]) / 3.0
    truncation = None
    if estimate_error:
        coarse = (4.0 * quotients[2] - quotients[4]) / 3.0
        truncation = np.abs(raw - coarse) / 15.0
    return raw, truncation, float(np.sqrt(2.0 * 64.0 + 2.0) / 12.0)


def property_derivatives(samples: Sequence[NDArray[np.float64]], plan: Sequence[Displacement],
                         multiples: Sequence[int], h: float, stencil: int, properties: Sequence[str],
                         noise: Mapping[str, float], estimate_error: bool,
                         symmetry: Reduction | None = None) -> PropertyDerivatives:
    """The derivatives from the property rows of every geometry (`samples[k]`: the rows below the
    forces of plan entry k, `property_rows(properties)` of them), assembled as the Hessian is.

    With a symmetry-reduced plan (`symmetry`, `vibra.molecules.displacement_symmetry`) the rows
    of the dofs not displaced are rebuilt from the others, each difference quotient rotated as
    the property transforms (R mu; R alpha R^T), before the stencil and its error estimate."""
    n_dof = symmetry.n_dof if symmetry is not None else (len(plan) - 1) // (2 * len(multiples))
    values: dict[str, Any] = {"dipole": None, "dipole_error": None, "polarizability": None,
                              "polarizability_error": None, "reference_dipole": None,
                              "reference_polarizability": None}
    noise_used: list[tuple[str, float]] = []
    sources: list[tuple[str, str]] = []
    start = 0
    for name in properties:
        rows = PROPERTY_ROWS[name]
        block = [np.asarray(sample[start:start + rows], dtype=float).ravel() for sample in samples]
        start += rows
        width = block[0].size
        quotient = {int(m): np.empty((n_dof, width)) for m in multiples}
        for d_plus, d_minus in zip(plan[1::2], plan[2::2]):
            m = d_plus.multiple
            quotient[m][d_plus.dof] = (block[d_plus.index] - block[d_minus.index]) / (2.0 * m * h)
        if symmetry is not None:
            quotient = {m: symmetry.complete(q, name) for m, q in quotient.items()}
        derivative, truncation, gain = central_difference(quotient, stencil, estimate_error)
        if name in noise:
            sigma, source = noise[name], "given"
        else:
            sigma, source = rounding_noise(max(float(np.abs(b).max()) for b in block)), "rounding"
        error = (np.zeros_like(derivative) if truncation is None else truncation) + gain * sigma / h
        if symmetry is not None:  # the operations' miss, on the rebuilt rows
            error = error + symmetry.geometry_error(block, plan, h)
        shape = (n_dof, 3) if rows == 1 else (n_dof, 3, 3)
        values[name] = derivative.reshape(shape)
        values[f"{name}_error"] = error.reshape(shape)
        values[f"reference_{name}"] = block[0].reshape(shape[1:])
        noise_used.append((name, float(sigma)))
        sources.append((name, source))
    return PropertyDerivatives(**values, noise=tuple(noise_used), noise_source=tuple(sources),
                               error_method="richardson" if estimate_error else "none")
