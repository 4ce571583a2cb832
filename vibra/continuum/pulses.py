"""A Gaussian pulse on a long uniform chain against d'Alembert's solution (Kneller, Mécanique analytique, eq. 165).

The chain is propagated exactly in its own Fourier basis (FFT, DCT or DST), so the
difference from the wave equation is the chain's dispersion.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
import scipy.fft
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import Frozen
from vibra.chains import ENDS
from vibra.chains.builders import Ends
from vibra.continuum.convergence import power_law_fit

__all__ = ["PulseResult", "gaussian_pulse", "PulseStudy", "pulse_study"]



@dataclass(frozen=True, eq=False)
class PulseResult(Frozen):
    """A Gaussian pulse on a uniform chain against d'Alembert's solution of eq. 165.

    Attributes
    ----------
    x : (n_sites,) ndarray
        Site positions in the continuum's frame [0, L], in length units.
    t : (n_t,) ndarray
        Times, in time units.
    chain : (n_t, n_sites) ndarray
        Displacements of the chain (exact modal propagation), in the pulse's amplitude unit.
    continuum : (n_t, n_sites) ndarray
        d'Alembert's solution at the sites (images for the ends).
    error : (n_t,) ndarray
        max |chain - continuum| / amplitude at each time (dimensionless).
    spacing : float
        dx, in length units.
    length : float
        L, in length units.
    wave_speed : float
        c, in length per time unit.
    width : float
        Standard deviation sigma of the Gaussian, in length units.
    center : float
        Initial centre x0, in length units.
    amplitude : float
        Peak displacement at t = 0.
    ends : str
        End conditions.
    """

    x: NDArray[np.float64]
    t: NDArray[np.float64]
    chain: NDArray[np.float64]
    continuum: NDArray[np.float64]
    error: NDArray[np.float64]
    spacing: float
    length: float
    wave_speed: float
    width: float
    center: float
    amplitude: float
    ends: str

    @property
    def n_sites(self) -> int:
        """Number of sites of the chain."""
        return int(self.x.shape[0])


def _gaussian(y: NDArray[np.float64], width: float) -> NDArray[np.float64]:
    return np.exp(-0.5 * (y / width) ** 2)


def _images(x: NDArray[np.float64], shift: float, center: float, width: float, L: float, ends: str
            ) -> NDArray[np.float64]:
    """d'Alembert's right-moving pulse f(x - c t) with the images that enforce the ends."""
    period = L if ends == "periodic" else 2.0 * L
    total = np.zeros_like(x)
    for m in range(-2, 3):  # a pulse of width <= L / 10 needs only the nearest images
        total += _gaussian(x - shift - center + m * period, width)
        if ends != "periodic":
            mirror = _gaussian(-x - shift - center + m * period, width)
            total += mirror if ends == "free" else -mirror
    return total


def gaussian_pulse(
    n_sites: int,
    times: ArrayLike,
    *,
    width: float,
    center: float | None = None,
    length: float = 1.0,
    wave_speed: float = 1.0,
    amplitude: float = 1.0,
    ends: Ends = "periodic",
) -> PulseResult:
    """Launch a right-moving Gaussian pulse on a uniform chain and compare with d'Alembert.

    The chain has n_sites unit masses with dx = L / n (free, periodic) or L / (n + 1)
    (fixed) and Omega = c / dx; site i sits at x_i = i dx (periodic), (i + 1/2) dx (free) or
    (i + 1) dx (fixed) in the continuum's frame [0, L]. Initial data u_i = f(x_i),
    u_i' = -c f'(x_i) with f(x) = amplitude exp(-(x - x0)^2 / 2 sigma^2): the continuum
    solution is f(x - c t) (with mirror images at free or fixed ends). The chain is
    propagated exactly in its own normal modes (FFT for periodic ends, DCT-II for free,
    DST-I for fixed: O(N log N) per time), so the difference is the chain's dispersion,
    to leading order -(c t dx^2 / 24) f'''(x - c t) + (dx^2 / 48)(f''(x + c t) - f''(x - c t)).

    Parameters
    ----------
    n_sites : int
        Number of masses, >= 2.
    times : float or (n_t,) array_like
        Times >= 0, in time units.
    width : float
        sigma, in length units, at most L / 10 (so that its images are negligible).
    center : float, optional
        x0 in [0, L], in length units; L / 4 by default.
    length : float
        L, in length units.
    wave_speed : float
        c, in length per time unit.
    amplitude : float
        Peak displacement at t = 0.
    ends : {"periodic", "free", "fixed"}
        End conditions.

    Returns
    -------
    PulseResult

    Raises
    ------
    ValueError
        n_sites < 2, negative times, width not in (0, L / 10], center outside [0, L], a
        non-positive length, speed or amplitude, unknown ends.

    Examples
    --------
    >>> pulse = gaussian_pulse(400, [0.0, 0.5], width=0.05)
    >>> pulse.chain.shape, pulse.error.round(4).tolist()  # the chain lags: dispersion
    ((2, 400), [0.0, 0.0014])
    """
    n = _validate.min_count(n_sites, "n_sites", low=2, what="a chain")
    t = np.atleast_1d(_validate.real_values(times, "times"))
    if (t < 0).any():
        i = int(np.argmax(t < 0))
        raise ValueError(f"times[{i}] is {float(t[i])!r}; every time must be >= 0")
    L = _validate.positive_scalar(length, "length", "length")
    sigma = _validate.positive_scalar(width, "width", "width")
    if sigma > 0.1 * L:
        raise ValueError(f"width is {sigma!r}; it must be <= length / 10 = {0.1 * L!r}")
    x0 = 0.25 * L if center is None else _validate.real_scalar(center, "center")
    if not 0.0 <= x0 <= L:
        raise ValueError(f"center is {x0!r}; it must lie in [0, length] = [0, {L!r}]")
    c = _validate.positive_scalar(wave_speed, "wave_speed", "speed")
    amp = _validate.positive_scalar(amplitude, "amplitude", "amplitude")
    _validate.choice(ends, "ends", ENDS)
    dx = L / (n + 1) if ends == "fixed" else L / n
    offset = {"periodic": 0.0, "free": 0.5, "fixed": 1.0}[ends]
    x = ((np.arange(n) + offset) * dx).astype(np.float64)
    u0 = amp * _images(x, 0.0, x0, sigma, L, ends)
    # v0 = -c f'(x) of the same image sum: f' of a Gaussian is -(y / sigma^2) f.
    v0 = np.zeros(n)
    period = L if ends == "periodic" else 2.0 * L
    for m in range(-2, 3):
        y = x - x0 + m * period
        v0 += c * amp * y / sigma**2 * _gaussian(y, sigma)
        if ends != "periodic":
            y_mirror = -x - x0 + m * period
            # mirror image g(x) = +-f(-x) moves left: its velocity is +c g'(x) = -+c f'(-x),
            # and -c f'(-x) = c (y_mirror / sigma^2) f(-x) with y_mirror = -x - x0.
            mirror_velocity = c * amp * y_mirror / sigma**2 * _gaussian(y_mirror, sigma)
            v0 += mirror_velocity if ends == "free" else -mirror_velocity
    Omega = c / dx
    index = np.arange(n)
    if ends == "periodic":
        omega = 2.0 * Omega * np.sin(np.pi * np.minimum(index, n - index) / n)
        forward, backward = (lambda v: scipy.fft.rfft(v)), (lambda v: scipy.fft.irfft(v, n))
        omega = omega[: n // 2 + 1]
    elif ends == "free":
        omega = 2.0 * Omega * np.sin(index * np.pi / (2 * n))
        forward = lambda v: scipy.fft.dct(v, type=2, norm="ortho")  # noqa: E731
        backward = lambda v: scipy.fft.idct(v, type=2, norm="ortho")  # noqa: E731
    else:
        omega = 2.0 * Omega * np.sin((index + 1) * np.pi / (2 * (n + 1)))
        forward = lambda v: scipy.fft.dst(v, type=1, norm="ortho")  # noqa: E731
        backward = lambda v: scipy.fft.idst(v, type=1, norm="ortho")  # noqa: E731
    u_hat, v_hat = forward(u0), forward(v0)
    chain = np.empty((t.size, n))
    continuum = np.empty((t.size, n))
    for row, time in enumerate(t):
        # sin(w t) / w = t sinc(w t / pi): continuous at the zero mode.
        chain[row] = backward(u_hat * np.cos(omega * time) + v_hat * time * np.sinc(omega * time / np.pi))
        continuum[row] = amp * _images(x, c * time, x0, sigma, L, ends)
    error = np.max(np.abs(chain - continuum), axis=1) / amp
    return PulseResult(x=x, t=t, chain=chain, continuum=continuum, error=error, spacing=dx, length=L,
                       wave_speed=c, width=sigma, center=x0, amplitude=amp, ends=ends)


@dataclass(frozen=True, eq=False)
class PulseStudy(Frozen):
    """Pulse error against d'Alembert for several chain sizes and pulse widths.

    Attributes
    ----------
    n_sites : (n_N,) ndarray of int
        Chain sizes.
    widths : (n_w,) ndarray
        Pulse widths sigma, in length units.
    time : float
        The time of the comparison, in time units.
    errors : (n_N, n_w) ndarray
        max |chain - continuum| / amplitude at `time` (dimensionless).
    order_in_n : (n_w,) ndarray
        p of a log-log fit error ~ N^-p at each width (expected 2).
    order_in_width : (n_N,) ndarray
        s of a log-log fit error ~ sigma^-s at each N (expected 3 while c t >> sigma).
    ends : str
        End conditions.
    """

    n_sites: NDArray[np.int64]
    widths: NDArray[np.float64]
    time: float
    errors: NDArray[np.float64]
    order_in_n: NDArray[np.float64]
    order_in_width: NDArray[np.float64]
    ends: str


def pulse_study(n_sites: Sequence[int] | ArrayLike, widths: Sequence[float] | ArrayLike, *, time: float,
                length: float = 1.0, wave_speed: float = 1.0, ends: Ends = "periodic") -> PulseStudy:
    """`gaussian_pulse` error at one time for every (N, width), with fitted orders.

    Parameters
    ----------
    n_sites : (n_N,) sequence of int
        Chain sizes, at least two, strictly increasing.
    widths : (n_w,) array_like
        Pulse widths sigma, at least two, strictly increasing, each <= length / 10, in
        length units.
    time : float
        Time of the comparison, > 0, in time units.
    length : float
        L, in length units.
    wave_speed : float
        c, in length per time unit.
    ends : {"periodic", "free", "fixed"}
        End conditions.

    Returns
    -------
    PulseStudy

    Raises
    ------
    ValueError
        Fewer than two sizes or two widths, sizes or widths not increasing, time not
        positive, or any argument `gaussian_pulse` rejects.

    Examples
    --------
    >>> import numpy as np
    >>> np.round(pulse_study([200, 400], [0.05, 0.1], time=0.5).order_in_n, 1)  # error ~ N^-2
    array([2., 2.])
    """
    sizes = _validate.increasing_counts(n_sites, "n_sites")
    sigma = _validate.real_array(widths, "widths", ndim=1)
    if sigma.size < 2:
        raise ValueError(f"widths must hold at least two widths, got {sigma.size}")
    _validate.increasing(sigma, "widths", "widths")
    time = _validate.positive_scalar(time, "time", "comparison time")  # the error at t = 0 is 0: no fit
    errors = np.array([[gaussian_pulse(int(n), [time], width=float(s), length=length, wave_speed=wave_speed,
                                       ends=ends).error[0] for s in sigma] for n in sizes])
    order_n = np.array([power_law_fit(sizes.astype(float), errors[:, j])[0] for j in range(sigma.size)])
    order_w = np.array([power_law_fit(sigma, errors[i, :])[0] for i in range(sizes.size)])
    return PulseStudy(n_sites=sizes.astype(np.int64), widths=sigma, time=float(time), errors=errors,
                      order_in_n=order_n, order_in_width=order_w, ends=ends)
