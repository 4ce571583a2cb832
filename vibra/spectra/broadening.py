"""Line spectra: stick spectra (degenerate lines merged) and lines broadened on a grid."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import span
from vibra._results import Result, stored
from vibra.spectra.common import nonnegative_float

__all__ = ["StickSpectrum", "BroadenedSpectrum", "stick_spectrum", "broadened_spectrum"]

_SHAPES = ("lorentzian", "gaussian")
_BLOCK = 1 << 20   # entries of one profile block in broadened_spectrum (8 MiB)


@dataclass(frozen=True, eq=False, repr=False)
class StickSpectrum(Result):
    """Line positions and strengths, degenerate lines merged (a `vibra._results.Result` over the
    lines; `path` is the kind).

    Attributes
    ----------
    wavenumbers : (n_lines,) ndarray
        Line positions, ascending, in cm^-1.
    intensities : (n_lines,) ndarray
        Line strengths (summed over the modes of a degenerate line), in `unit`.
    unit : str
        Unit of the intensities (``"km/mol"``, ``"e^2/amu"``, ``"Angstrom^4/amu"``).
    kind : str
        ``"IR"``, ``"Raman"`` or a free label; charts use it for titles and axis direction.
    level : str
        The level of theory the lines were computed at (``"RHF/STO-3G"``; ``""`` for vibra's
        models); charts put it in their titles.
    """

    STORED = {"wavenumbers": stored(("n_lines",)), "intensities": stored(("n_lines",))}  # (vibra._results)
    AXIS, NOUNS, PATH_FIELD = "n_lines", ("line", "lines"), "kind"

    wavenumbers: NDArray[np.float64]
    intensities: NDArray[np.float64]
    unit: str
    kind: str
    level: str = ""

    def _repr_parts(self) -> tuple[str, ...]:
        return self._size(), f"{span(self.wavenumbers, 'cm^-1')}", f"intensities in {self.unit}"

    def broadened(self, grid: ArrayLike, width: float,
                  shape: Literal["lorentzian", "gaussian"] = "lorentzian") -> BroadenedSpectrum:
        """These lines broadened on `grid` (see `broadened_spectrum`)."""
        return broadened_spectrum(self.wavenumbers, self.intensities, grid, width, shape=shape,
                                  unit=self.unit, kind=self.kind, level=self.level)


@dataclass(frozen=True, eq=False, repr=False)
class BroadenedSpectrum(Result):
    """A spectrum on a wavenumber grid: each line a unit-area profile times its intensity (a
    `vibra._results.Result` over the grid; `path` is the line shape).

    Attributes
    ----------
    grid : (n_points,) ndarray
        Wavenumbers, in cm^-1.
    values : (n_points,) ndarray
        Spectral density, in `unit` per cm^-1: its integral over all wavenumbers is the sum
        of the line intensities.
    width : float
        Full width at half maximum of every line, in cm^-1.
    shape : str
        ``"lorentzian"`` or ``"gaussian"``.
    unit : str
        Unit of the line intensities.
    kind : str
        ``"IR"``, ``"Raman"`` or a free label.
    level : str
        The level of theory of the lines (``""`` for vibra's models).
    """

    STORED = {"grid": stored(("n_points",)), "values": stored(("n_points",))}  # (vibra._results)
    AXIS, NOUNS, PATH_FIELD = "n_points", ("point", "points"), "shape"

    grid: NDArray[np.float64]
    values: NDArray[np.float64]
    width: float
    shape: str
    unit: str
    kind: str
    level: str = ""

    def _repr_parts(self) -> tuple[str, ...]:
        return (self._size(), f"{span(self.grid, 'cm^-1')}", f"{self.kind}", f"FWHM {self.width:.4g} cm^-1",
                f"values in {self.unit} per cm^-1")


def stick_spectrum(wavenumbers: NDArray[np.float64], values: NDArray[np.float64], merge_cm1: float,
            unit: str, kind: str, level: str = "") -> StickSpectrum:
    merge_cm1 = nonnegative_float(merge_cm1, "merge_cm1")
    order = np.argsort(wavenumbers, kind="stable")
    positions, strengths = wavenumbers[order], values[order]
    if positions.size == 0:
        return StickSpectrum(np.zeros(0), np.zeros(0), unit, kind, level)
    starts = np.concatenate([[True], np.diff(positions) > merge_cm1])
    group = np.cumsum(starts) - 1
    total = np.asarray(np.bincount(group, weights=strengths), dtype=float)
    mean = np.asarray(np.bincount(group, weights=positions), dtype=float) / np.bincount(group)
    return StickSpectrum(wavenumbers=mean, intensities=total, unit=unit, kind=kind, level=level)



def broadened_spectrum(
    wavenumbers: ArrayLike,
    intensities: ArrayLike,
    grid: ArrayLike,
    width: float,
    shape: Literal["lorentzian", "gaussian"] = "lorentzian",
    *,
    unit: str = "arb. units",
    kind: str = "IR",
    level: str = "",
) -> BroadenedSpectrum:
    """Lines broadened into a spectral density on a wavenumber grid.

    Each line k contributes I_k g(nu - nu_k) with g a unit-area profile of full width at half
    maximum `width`: the Lorentzian g = (w/2) / pi / ((nu - nu_k)^2 + (w/2)^2) or the Gaussian
    of standard deviation w / (2 sqrt(2 ln 2)). The integral of the result over all
    wavenumbers is sum_k I_k; on a finite grid the tails outside it are missing (for a
    Lorentzian a fraction of about w / (pi d) at distance d from the edge).

    Parameters
    ----------
    wavenumbers : (n_lines,) array_like
        Line positions, in cm^-1.
    intensities : (n_lines,) array_like
        Line strengths (>= 0), in `unit`.
    grid : (n_points,) array_like
        Wavenumbers at which to evaluate, in cm^-1.
    width : float
        Full width at half maximum, in cm^-1 (> 0).
    shape : {"lorentzian", "gaussian"}
        Line profile.
    unit : str
        Unit of `intensities`, carried for labels.
    kind : str
        Label of the spectrum (``"IR"``, ``"Raman"``).
    level : str
        The level of theory of the lines, carried for chart titles.

    Returns
    -------
    BroadenedSpectrum
        values in `unit` per cm^-1.

    Raises
    ------
    ValueError
        Arrays of the wrong dimension or lengths, non-finite values, negative intensities,
        a width that is not positive, an unknown shape.

    Examples
    --------
    >>> import numpy as np
    >>> s = broadened_spectrum([1000.0], [2.0], np.array([1000.0]), 10.0, "lorentzian")
    >>> round(float(s.values[0] * np.pi * 5.0), 12)   # peak height 2 / (pi w/2)
    2.0
    """
    positions = _validate.real_array(wavenumbers, "wavenumbers", ndim=1)
    strengths = _validate.real_array(intensities, "intensities", ndim=1)
    if strengths.shape != positions.shape:
        raise ValueError(
            f"intensities must have {positions.shape[0]} entries (one per wavenumber), "
            f"got {strengths.shape[0]}"
        )
    _validate.nonnegative(strengths, "intensities", "intensity")
    points = _validate.real_array(grid, "grid", ndim=1)
    if points.shape[0] == 0:
        raise ValueError("grid must hold at least one wavenumber, got none")
    width = _validate.positive_scalar(width, "width")
    _validate.choice(shape, "shape", _SHAPES)
    values = np.empty_like(points)
    half = 0.5 * width
    sigma = width / (2.0 * np.sqrt(2.0 * np.log(2.0)))
    # grid chunks keep the (points x lines) profile block near _BLOCK entries in memory
    rows = max(1, _BLOCK // max(positions.shape[0], 1))
    for start in range(0, points.shape[0], rows):
        offset = points[start:start + rows, None] - positions[None, :]
        if shape == "lorentzian":
            profile = (half / np.pi) / (offset**2 + half**2)
        else:
            profile = np.exp(-0.5 * (offset / sigma) ** 2) / (sigma * np.sqrt(2.0 * np.pi))
        values[start:start + rows] = profile @ strengths
    return BroadenedSpectrum(grid=points, values=values, width=width, shape=shape,
                             unit=str(unit), kind=str(kind), level=str(level))
