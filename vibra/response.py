"""Forced, damped response: the single oscillator and multi-dof frequency response.

The single oscillator (seed 003 section 5.1, eqs. 114-131) is

    u'' + gamma u' + w0^2 u = F(t) / m,

with friction -m gamma u' (seed eq. 61). For a harmonic force F(t) = Re{F0 exp(i w t)}
(eq. 118) the steady state is u_p(t) = Re{u0(w) exp(i w t)} with the complex amplitude
u0(w) = (F0/m) / (w0^2 - w^2 + i gamma w) (eq. 120); the full motion adds the homogeneous
part fixed by the initial conditions (eqs. 126-129), which dies out for t >> 1/gamma
(eqs. 130-131). `Oscillator` holds these formulas in forms that keep their digits at the
extremes (near resonance, near critical damping gamma = 2 w0, gamma >> w0, w -> 0 and
w -> infinity).

For many degrees of freedom, M u'' + C u' + K u = Re{f exp(i w t)} has the steady state
Re{x(w) exp(i w t)} with the receptance response x(w) = (K - w^2 M + i w C)^-1 f.
`frf` returns it as an (n_freq, n_dof) complex array; `frequency_response` returns a
`FrequencyResponse` with the method, the solver and the estimated truncation error.
Three methods:

- ``"direct"``: one factorisation per frequency, tridiagonal (LAPACK gttrf/gttrs) or banded
  (gbtrf/gbtrs) when K, M and C are, sparse LU otherwise, dense LU for small dense input.
- ``"modal"``: superposition of the lowest `n_modes` normal modes (`vibra.normal_modes`),
  for damping that the modes diagonalise (friction C = eta M, seed eq. 66; Rayleigh
  C = a M + b K; modal damping ratios). The error of the dropped modes is estimated, and a
  residual (static) correction for them is offered.
- ``"state_space"``: complex modes of the first-order form, for any symmetric C (dense; all
  modes).

`transient_response` gives the motion of a multi-dof system under a harmonic (or constant)
force from given initial conditions by modal superposition, each normal coordinate moving as
one `Oscillator`.

Free structures (rigid-body modes, omega_k = 0): their receptance -1/w^2 is unbounded as
w -> 0, so w = 0 is refused with an error naming the frequency; for w > 0 the rigid-body
terms are included. The residual correction uses the static response of the flexible modes
only (the pseudo-inverse of K on the M-orthogonal complement of the rigid-body modes).

Units: every quantity is in the unit system of K, M and C (rad per time unit for
frequencies; force / stiffness = length for the response).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import lapack

from vibra import _validate
from vibra.modes import Modes, normal_modes
from vibra._frozen import _freeze_arrays
from vibra.units import DIMENSIONLESS, UnitSystem, unit_system

__all__ = [
    "Oscillator", "FrequencyResponse", "Transient", "frf", "frequency_response",
    "transient_response", "friction_damping", "rayleigh_damping", "rayleigh_damping_ratio",
    "rayleigh_coefficients", "METHODS",
]

#: Methods accepted by `frf` and `frequency_response`.
METHODS = ("direct", "modal", "state_space")

#: Largest half-bandwidth for which the direct method uses the banded LAPACK solver
#: (cost n * b^2 per frequency); wider matrices go to sparse (or dense) LU.
BANDED_MAX_HALF_WIDTH = 16

#: Relative size of the off-diagonal part of Phi^T C Phi up to which damping counts as
#: diagonal in the modal basis (proportional damping leaves round-off of a few ulps there).
MODAL_DIAGONAL_RTOL = 1e-8

_EPS = float(np.finfo(float).eps)


# ====================================================================== the single oscillator
_scalar = _validate.real_scalar


def _complex_scalar(value: Any, name: str) -> complex:
    if isinstance(value, bool) or not isinstance(
        value, (int, float, complex, np.integer, np.floating, np.complexfloating)
    ):
        raise TypeError(f"{name} must be a (complex) number, got {type(value).__name__}")
    number = complex(value)
    if not (math.isfinite(number.real) and math.isfinite(number.imag)):
        raise ValueError(f"{name} is {number!r}; it must be finite")
    return number


def _frequencies(value: ArrayLike, name: str) -> NDArray[np.float64]:
    array = _validate.real_array(value, name, ndim=(0, 1))
    _validate.nonnegative(np.atleast_1d(array), name, "angular frequency")
    return array


def _times(value: ArrayLike, name: str = "t") -> NDArray[np.float64]:
    array = _validate.real_array(value, name, ndim=(0, 1))
    _validate.nonnegative(np.atleast_1d(array), name, "time")
    return array


def _homogeneous_basis(
    t: NDArray[np.float64], w0: NDArray[np.float64] | float, gamma: NDArray[np.float64] | float,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The two solutions c(t), s(t) of u'' + gamma u' + w0^2 u = 0 with c(0)=1, c'(0)=-gamma/2
    and s(0)=0, s'(0)=1, in a form continuous across critical damping (eqs. 126-128).

    c = exp(-gamma t/2) cos(s t), s = exp(-gamma t/2) sin(s t)/s with s^2 = w0^2 - gamma^2/4,
    computed as (w0 - gamma/2)(w0 + gamma/2) so that no digits cancel near gamma = 2 w0. For
    s^2 < 0 (overdamped) the same functions are written with the two real roots, the slow one
    as -w0^2 / (gamma/2 + q) (no cancellation for gamma >> w0) and exp(-2 q t) in place of a
    cosh that would overflow. At s^2 = 0 both forms give exp(-gamma t/2) (1, t) (eq. 128).
    """
    half = 0.5 * np.asarray(gamma, dtype=float)
    w0 = np.asarray(w0, dtype=float)
    sigma = (w0 - half) * (w0 + half)
    under = sigma >= 0.0
    s = np.sqrt(np.where(under, sigma, 0.0))
    q = np.sqrt(np.where(under, 0.0, -sigma))
    damp = np.exp(-half * t)
    c_under = damp * np.cos(s * t)
    s_under = damp * t * np.sinc(s * t / np.pi)          # sin(s t)/s, -> t as s -> 0
    denominator = np.where(under, 1.0, half + q)          # > 0 on the overdamped branch
    slow = -(w0 * w0) / denominator                       # = -gamma/2 + q, without cancellation
    slow_decay = np.exp(slow * t)
    x = 2.0 * q * t
    tail = np.exp(-x)
    small = x < 1e-300
    ratio = np.where(small, 1.0, -np.expm1(-x) / np.where(small, 1.0, x))  # (1 - e^-x)/x
    c_over = slow_decay * 0.5 * (1.0 + tail)
    s_over = slow_decay * t * ratio
    return np.where(under, c_under, c_over), np.where(under, s_under, s_over)


def _denominator(w0: Any, gamma: Any, omega: Any) -> NDArray[np.complex128]:
    """w0^2 - w^2 + i gamma w, with w0^2 - w^2 written as (w0 - w)(w0 + w)."""
    return (w0 - omega) * (w0 + omega) + 1j * (gamma * omega)


@dataclass(frozen=True, eq=False)
class Oscillator:
    """The forced, damped oscillator u'' + gamma u' + w0^2 u = F(t)/m (seed 003 eq. 115).

    Attributes
    ----------
    w0 : float
        Natural angular frequency sqrt(K/m) > 0, in rad per time unit.
    gamma : float
        Friction rate >= 0 (friction force -m gamma u', eq. 61), in 1 / time unit.
    m : float
        Mass > 0, in mass units. Forces are divided by it.

    Raises
    ------
    TypeError
        A parameter that is not a real number.
    ValueError
        w0 <= 0, gamma < 0, m <= 0, or a value that is not finite.

    Examples
    --------
    >>> osc = Oscillator(w0=1.0, gamma=0.5)
    >>> round(osc.amplitude(1.0), 12)      # |u0(w0)| = F0 / (m gamma w0)
    2.0
    >>> round(osc.phase(1.0) / 3.141592653589793, 12)
    -0.5
    """

    w0: float
    gamma: float
    m: float = 1.0

    def __post_init__(self) -> None:
        w0 = _scalar(self.w0, "w0")
        gamma = _scalar(self.gamma, "gamma")
        m = _scalar(self.m, "m")
        if w0 <= 0:
            raise ValueError(f"w0 is {w0!r}; the natural angular frequency must be positive")
        if gamma < 0:
            raise ValueError(f"gamma is {gamma!r}; the friction rate must be >= 0 (no negative damping)")
        if m <= 0:
            raise ValueError(f"m is {m!r}; the mass must be positive")
        object.__setattr__(self, "w0", w0)
        object.__setattr__(self, "gamma", gamma)
        object.__setattr__(self, "m", m)

    # ------------------------------------------------------------------ regime
    @property
    def regime(self) -> Literal["undamped", "underdamped", "critical", "overdamped"]:
        """Which form the homogeneous motion takes (eqs. 126-128): gamma vs 2 w0."""
        if self.gamma == 0:
            return "undamped"
        if self.gamma < 2 * self.w0:
            return "underdamped"
        return "critical" if self.gamma == 2 * self.w0 else "overdamped"

    @property
    def quality_factor(self) -> float:
        """Q = w0 / gamma (dimensionless); inf without damping."""
        return math.inf if self.gamma == 0 else self.w0 / self.gamma

    @property
    def damping_ratio(self) -> float:
        """zeta = gamma / (2 w0) (dimensionless); 1 at critical damping."""
        return self.gamma / (2.0 * self.w0)

    def roots(self) -> NDArray[np.complex128]:
        """(2,) roots lambda of lambda^2 + gamma lambda + w0^2 (eq. 126), in 1 / time unit.

        The slow one first. Computed without cancellation: s^2 = (w0 - gamma/2)(w0 + gamma/2)
        and, when overdamped, the slow root as -w0^2 / (gamma/2 + sqrt(-s^2)).
        """
        half = 0.5 * self.gamma
        sigma = (self.w0 - half) * (self.w0 + half)
        if sigma >= 0:
            s = math.sqrt(sigma)
            return np.array([complex(-half, s), complex(-half, -s)])
        q = math.sqrt(-sigma)
        return np.array([complex(-self.w0**2 / (half + q), 0.0), complex(-(half + q), 0.0)])

    def damped_frequency(self) -> float | None:
        """sqrt(w0^2 - gamma^2/4), in rad per time unit: the seed's eq. (122).

        This is the angular frequency of the free damped oscillation (the imaginary part of
        the roots, eq. 126). None when gamma >= 2 w0: then the free motion does not oscillate.
        Note: the seed calls it the resonance frequency, but the amplitude (121) peaks at
        `resonance_frequency` = sqrt(w0^2 - gamma^2/2); the two agree as gamma -> 0.
        """
        half = 0.5 * self.gamma
        sigma = (self.w0 - half) * (self.w0 + half)
        return math.sqrt(sigma) if sigma > 0 else None

    def resonance_frequency(self) -> float | None:
        """Angular frequency at which the amplitude (121) peaks, in rad per time unit.

        d|u0|^2/d(w^2) = 0 gives w_res = sqrt(w0^2 - gamma^2/2), computed as
        sqrt((w0 - gamma/sqrt2)(w0 + gamma/sqrt2)). Returns None when gamma >= sqrt(2) w0:
        the amplitude then falls monotonically from its static value and there is no
        resonance. (The seed's eq. 122, sqrt(w0^2 - gamma^2/4) with the bound gamma < 2 w0,
        is the free damped frequency: see `damped_frequency`.)
        """
        r = self.gamma / math.sqrt(2.0)
        value = (self.w0 - r) * (self.w0 + r)
        return math.sqrt(value) if value > 0 else None

    def peak_amplitude(self, F0: complex = 1.0) -> float:
        """Largest steady-state amplitude max_w |u0(w)| for force amplitude |F0|, in length.

        |F0| / (m gamma sqrt(w0^2 - gamma^2/4)) at `resonance_frequency`; the static value
        |F0| / (m w0^2) when there is no resonance; inf when gamma = 0.
        """
        force = abs(_complex_scalar(F0, "F0"))
        if self.resonance_frequency() is None:
            return force / (self.m * self.w0**2)
        if self.gamma == 0:
            return math.inf if force > 0 else 0.0
        damped = self.damped_frequency()
        assert damped is not None  # gamma < sqrt2 w0 < 2 w0
        return force / (self.m * self.gamma * damped)

    def half_power_frequencies(self) -> tuple[float, float] | None:
        """(w1, w2): the angular frequencies where |u0|^2 falls to half its peak, in rad/time.

        With x = w^2, |u0|^-2 (m/F0)^2 = (x - x_res)^2 + gamma^2 (w0^2 - gamma^2/4), so the
        half-power points are x = x_res -+ gamma sqrt(w0^2 - gamma^2/4). None when the lower
        one does not exist (heavy damping: the amplitude never falls to half power below the
        peak) or there is no resonance.
        """
        w_res = self.resonance_frequency()
        if w_res is None:
            return None
        damped = self.damped_frequency()
        assert damped is not None
        spread = self.gamma * damped
        x_low = w_res * w_res - spread
        if x_low <= 0:
            return None
        w_low = math.sqrt(x_low)
        w_high = math.sqrt(w_res * w_res + spread)
        return w_low, w_high

    def half_power_bandwidth(self) -> float | None:
        """w2 - w1 between the half-power points, in rad per time unit (-> gamma as gamma -> 0).

        Computed as 2 gamma sqrt(w0^2 - gamma^2/4) / (w1 + w2), free of cancellation. 0 without
        damping; None when `half_power_frequencies` is None.
        """
        points = self.half_power_frequencies()
        if points is None:
            return None
        damped = self.damped_frequency()
        assert damped is not None
        return 2.0 * self.gamma * damped / (points[0] + points[1])

    def decay_rate(self) -> float:
        """Rate at which the transient dies out, -max Re(lambda) (eq. 126), in 1 / time unit.

        gamma/2 up to critical damping (at gamma = 2 w0 the transient is t exp(-gamma t/2),
        eq. 128); w0^2 / (gamma/2 + sqrt(gamma^2/4 - w0^2)) (-> w0^2/gamma) when overdamped.
        The steady state (eq. 131) is reached once t >> 1 / decay_rate. 0 without damping.
        """
        return float(-self.roots()[0].real)

    # ------------------------------------------------------------------ steady state
    def complex_amplitude(self, omega: ArrayLike, F0: complex = 1.0) -> complex | NDArray[np.complex128]:
        """Complex amplitude u0(w) = (F0/m) / (w0^2 - w^2 + i gamma w) (eq. 120).

        Parameters
        ----------
        omega : float or (n,) array_like
            Driving angular frequencies >= 0, in rad per time unit.
        F0 : complex
            Complex force amplitude (force F(t) = Re{F0 exp(i w t)}, eq. 118), in force units.

        Returns
        -------
        complex or (n,) ndarray
            u0, in length. w0^2 - w^2 is formed as (w0 - w)(w0 + w), so the relative accuracy
            is a few ulps for every w, including w = w0 with tiny gamma. For gamma = 0 at
            w = w0 the value is the limit gamma -> 0+: an explicit infinity in the direction
            -i F0 (real part 0 where that direction has none), never NaN.

        Raises
        ------
        ValueError
            omega negative or not finite; F0 not finite.
        """
        w = _frequencies(omega, "omega")
        force = _complex_scalar(F0, "F0")
        denominator = _denominator(self.w0, self.gamma, w)
        zero = denominator == 0
        with np.errstate(divide="ignore", invalid="ignore"):
            value = (force / self.m) / np.where(zero, 1.0, denominator)
        if zero.any():
            direction = -1j * force
            limit = complex(
                math.copysign(math.inf, direction.real) if direction.real else 0.0,
                math.copysign(math.inf, direction.imag) if direction.imag else 0.0,
            )
            value = np.where(zero, limit, value)
        return complex(value) if value.ndim == 0 else value

    def amplitude(self, omega: ArrayLike, F0: complex = 1.0) -> float | NDArray[np.float64]:
        """|u0(w)| = (|F0|/m) / sqrt((w^2 - w0^2)^2 + gamma^2 w^2) (eq. 121), in length.

        Formed with hypot and (w0 - w)(w0 + w): no overflow or cancellation for w from 1e-8 w0
        to 1e8 w0. inf for gamma = 0 at w = w0. Same arguments as `complex_amplitude`.
        """
        w = _frequencies(omega, "omega")
        force = abs(_complex_scalar(F0, "F0"))
        size = np.hypot((self.w0 - w) * (self.w0 + w), self.gamma * w)
        with np.errstate(divide="ignore"):
            value = np.where(size == 0, math.inf if force else 0.0, (force / self.m) / size)
        return float(value) if np.ndim(value) == 0 else value

    def phase(self, omega: ArrayLike) -> float | NDArray[np.float64]:
        """Phase lag phi(w) of u behind F (eq. 123), in rad, on the branch [-pi, 0].

        phi = -atan2(gamma w, w0^2 - w^2): 0 at w = 0, -pi/2 at w0 for every gamma > 0, -> -pi
        as w -> infinity (the seed's arctan(gamma w / (w^2 - w0^2)) with the quadrant fixed).
        For gamma = 0: 0 below w0, -pi above, and the limit -pi/2 at w = w0 exactly.

        Parameters
        ----------
        omega : float or (n,) array_like
            Driving angular frequencies >= 0, in rad per time unit.
        """
        w = _frequencies(omega, "omega")
        stiffness = (self.w0 - w) * (self.w0 + w)
        value = -np.arctan2(self.gamma * w, stiffness)
        value = np.where((stiffness == 0) & (self.gamma * w == 0) & (w > 0), -0.5 * np.pi, value)
        return float(value) if np.ndim(value) == 0 else value

    def steady_state(self, t: ArrayLike, F0: complex = 1.0, omega: float = 1.0) -> float | NDArray[np.float64]:
        """u_p(t) = Re{u0(w) exp(i w t)} = |u0| cos(w t + alpha + phi) (eqs. 119, 124), in length.

        Parameters
        ----------
        t : float or (n_t,) array_like
            Times >= 0, in time units.
        F0 : complex
            Complex force amplitude |F0| exp(i alpha), in force units.
        omega : float
            Driving angular frequency >= 0, in rad per time unit.

        Raises
        ------
        ValueError
            t or omega negative or not finite; gamma = 0 and omega = w0 (no steady state: the
            undamped resonance grows without bound).
        """
        times = _times(t)
        w = float(_frequencies(omega, "omega"))
        amplitude = self._particular_amplitude(_complex_scalar(F0, "F0"), w)
        value = np.real(amplitude * np.exp(1j * w * times))
        return float(value) if np.ndim(value) == 0 else value

    def _particular_amplitude(self, force: complex, w: float) -> complex:
        if force == 0:
            return 0j
        denominator = complex(_denominator(self.w0, self.gamma, w))
        if denominator == 0:
            raise ValueError(
                f"omega is {w!r} = w0 and gamma = 0: an undamped oscillator driven at its natural "
                "frequency has no steady state (the amplitude grows without bound); use gamma > 0"
            )
        return (force / self.m) / denominator

    # ------------------------------------------------------------------ full motion
    def motion(self, t: ArrayLike, u0: float = 0.0, v0: float = 0.0, *, F0: complex = 0.0,
               omega: float = 0.0) -> float | NDArray[np.float64]:
        """Displacement u(t) = u_p(t) + u_h(t) from u(0) = u0, u'(0) = v0 (eq. 129).

        The force is F(t) = Re{F0 exp(i w t)} (eq. 118): F0 = 0 gives the free damped motion,
        omega = 0 a constant force. The homogeneous part u_h is the combination of the two
        basis solutions that matches the initial conditions, written in one form for the
        underdamped, critical (t exp(-gamma t/2), eq. 128) and overdamped regimes, continuous
        across gamma = 2 w0 with no loss of digits there (see `roots`).

        Parameters
        ----------
        t : float or (n_t,) array_like
            Times >= 0, in time units.
        u0 : float
            Initial displacement, in length.
        v0 : float
            Initial velocity, in length per time unit.
        F0 : complex
            Complex force amplitude, in force units.
        omega : float
            Driving angular frequency >= 0, in rad per time unit.

        Returns
        -------
        float or (n_t,) ndarray
            u(t), in length.

        Raises
        ------
        ValueError
            Negative or non-finite t or omega, non-finite u0, v0, F0; an undamped oscillator
            driven at w0 (see `steady_state`).
        """
        return self._state(t, u0, v0, F0, omega, derivative=False)

    def velocity(self, t: ArrayLike, u0: float = 0.0, v0: float = 0.0, *, F0: complex = 0.0,
                 omega: float = 0.0) -> float | NDArray[np.float64]:
        """Velocity u'(t) of the motion of `motion` (same arguments), in length per time unit."""
        return self._state(t, u0, v0, F0, omega, derivative=True)

    def energy(self, u: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
        """E = T + V = m v^2 / 2 + m w0^2 u^2 / 2, in energy units (dE/dt = -2 gamma T, eq. 63)."""
        displacement = _validate.real_array(u, "u")
        speed = _validate.real_array(v, "v")
        return 0.5 * self.m * (speed * speed + self.w0**2 * displacement * displacement)

    def _state(self, t: ArrayLike, u0: float, v0: float, F0: complex, omega: float, *,
               derivative: bool) -> float | NDArray[np.float64]:
        times = _times(t)
        start = _scalar(u0, "u0")
        speed = _scalar(v0, "v0")
        force = _complex_scalar(F0, "F0")
        w = float(_frequencies(omega, "omega"))
        amplitude = self._particular_amplitude(force, w)
        value = _oscillator_state(
            times, self.w0, self.gamma, start, speed, amplitude, w, derivative=derivative,
        )
        return float(value) if np.ndim(value) == 0 else value


def _oscillator_state(
    t: NDArray[np.float64], w0: Any, gamma: Any, u0: Any, v0: Any, amplitude: Any, omega: float,
    *, derivative: bool,
) -> NDArray[np.float64]:
    """u(t) (or u'(t) with `derivative`) of the oscillator whose steady state is Re{amplitude e^{iwt}}.

    `amplitude` is the particular solution's complex amplitude u0(w); w0, gamma, u0, v0 and
    amplitude broadcast against t (e.g. t of shape (n_t, 1) and the rest (n_modes,)).
    """
    amplitude = np.asarray(amplitude, dtype=complex)
    phase = np.exp(1j * omega * t)
    a = u0 - amplitude.real                              # u_h(0)
    b = v0 + omega * amplitude.imag                      # u_h'(0) = v0 - Re{i w u0}
    c, s = _homogeneous_basis(t, w0, gamma)
    if not derivative:
        return np.real(amplitude * phase) + a * c + (b + 0.5 * gamma * a) * s
    w0 = np.asarray(w0, dtype=float)
    return np.real(1j * omega * amplitude * phase) + b * c - (w0 * w0 * a + 0.5 * gamma * b) * s


# ====================================================================== damping models
def friction_damping(M: ArrayLike, eta: float) -> NDArray[np.float64] | sp.csr_matrix:
    """The seed's friction damping C = eta M (eqs. 64-66), in mass per time unit.

    Parameters
    ----------
    M : (n_dof,) or (n_dof, n_dof) array_like
        Diagonal masses (gives a sparse diagonal C) or a dense SPD mass matrix.
    eta : float
        Friction rate >= 0, in 1 / time unit. Each mode's damping ratio is eta / (2 omega_k).

    Raises
    ------
    ValueError
        eta negative or not finite; M not positive.
    """
    rate = _scalar(eta, "eta")
    if rate < 0:
        raise ValueError(f"eta is {rate!r}; the friction rate must be >= 0 (no negative damping)")
    mass = _validate.real_array(M, "M", ndim=(1, 2))
    mass = _validate.mass_argument(mass, mass.shape[0], "M")
    if mass.ndim == 1:
        return sp.diags(rate * mass, format="csr")
    return rate * mass


def rayleigh_damping(K: ArrayLike | sp.spmatrix, M: ArrayLike, a: float, b: float,
                     ) -> NDArray[np.float64] | sp.csr_matrix:
    """Rayleigh damping C = a M + b K, in mass per time unit.

    Parameters
    ----------
    K : (n_dof, n_dof) array_like or scipy.sparse matrix
        Stiffness, in force per length.
    M : (n_dof,) or (n_dof, n_dof) array_like
        Masses or mass matrix.
    a : float
        Mass-proportional coefficient >= 0, in 1 / time unit.
    b : float
        Stiffness-proportional coefficient >= 0, in time unit.

    Returns
    -------
    (n_dof, n_dof) CSR matrix when K is sparse or M a vector, dense ndarray otherwise. The
    damping ratio of a mode of angular frequency w is `rayleigh_damping_ratio` (w, a, b).

    Raises
    ------
    ValueError
        a or b negative or not finite; K not square; M not matching K.
    """
    alpha = _scalar(a, "a")
    beta = _scalar(b, "b")
    for name, value in (("a", alpha), ("b", beta)):
        if value < 0:
            raise ValueError(f"{name} is {value!r}; Rayleigh coefficients must be >= 0 (no negative damping)")
    stiffness = _validate.square_matrix(K, "K")
    mass = _validate.mass_argument(M, stiffness.shape[0], "M")
    if sp.issparse(stiffness) or mass.ndim == 1:
        mass_matrix = sp.diags(mass) if mass.ndim == 1 else sp.csr_matrix(mass)
        return sp.csr_matrix(alpha * mass_matrix + beta * sp.csr_matrix(stiffness))
    return alpha * mass + beta * stiffness


def rayleigh_damping_ratio(omega: ArrayLike, a: float, b: float) -> NDArray[np.float64]:
    """zeta(w) = a / (2 w) + b w / 2 of Rayleigh damping C = a M + b K (dimensionless).

    The mode of angular frequency w_k has exactly this damping ratio, since
    phi_k^T C phi_k = a + b w_k^2 = 2 zeta_k w_k.

    Parameters
    ----------
    omega : float or (n,) array_like
        Angular frequencies > 0, in rad per time unit.
    a, b : float
        Rayleigh coefficients >= 0 (1 / time unit, time unit).
    """
    w = _validate.real_array(omega, "omega", ndim=(0, 1))
    _validate.positive(np.atleast_1d(w), "omega", "angular frequency")
    alpha = _scalar(a, "a")
    beta = _scalar(b, "b")
    for name, coefficient in (("a", alpha), ("b", beta)):
        if coefficient < 0:
            raise ValueError(f"{name} is {coefficient!r}; Rayleigh coefficients must be >= 0 (no negative damping)")
    ratio = alpha / (2.0 * w) + 0.5 * beta * w
    return ratio[()] if np.ndim(ratio) == 0 else ratio


def rayleigh_coefficients(omega_1: float, omega_2: float, zeta_1: float, zeta_2: float,
                          ) -> tuple[float, float]:
    """(a, b) of the Rayleigh damping with ratio zeta_1 at omega_1 and zeta_2 at omega_2.

    Solves a / (2 w_i) + b w_i / 2 = zeta_i for i = 1, 2 (a in 1/time unit, b in time unit).

    Raises
    ------
    ValueError
        Frequencies not positive or equal; ratios negative; a solution with a < 0 or b < 0
        (no Rayleigh damping passes through those two points).
    """
    w1, w2 = _scalar(omega_1, "omega_1"), _scalar(omega_2, "omega_2")
    z1, z2 = _scalar(zeta_1, "zeta_1"), _scalar(zeta_2, "zeta_2")
    for name, value in (("omega_1", w1), ("omega_2", w2)):
        if value <= 0:
            raise ValueError(f"{name} is {value!r}; it must be positive")
    for name, value in (("zeta_1", z1), ("zeta_2", z2)):
        if value < 0:
            raise ValueError(f"{name} is {value!r}; a damping ratio must be >= 0")
    if w1 == w2:
        raise ValueError(f"omega_1 and omega_2 are both {w1!r}; they must differ")
    # [1/(2w1), w1/2; 1/(2w2), w2/2] [a; b] = [z1; z2]
    determinant = 0.25 * (w2 / w1 - w1 / w2)
    a = (0.5 * w2 * z1 - 0.5 * w1 * z2) / determinant
    b = (z2 / (2.0 * w1) - z1 / (2.0 * w2)) / determinant
    if a < 0 or b < 0:
        raise ValueError(
            f"the Rayleigh coefficients through (omega_1, zeta_1) = ({w1!r}, {z1!r}) and "
            f"(omega_2, zeta_2) = ({w2!r}, {z2!r}) are a = {a:.6g}, b = {b:.6g}: one is negative"
        )
    return float(a), float(b)


# ====================================================================== results
@dataclass(frozen=True, eq=False)
class FrequencyResponse:
    """Steady-state response x(w) = (K - w^2 M + i w C)^-1 f over many frequencies.

    Attributes
    ----------
    omegas : (n_freq,) ndarray
        Driving angular frequencies, in rad per time unit of `units`.
    response : (n_freq, n_dof) complex ndarray
        Complex displacement amplitudes x(w) (the force is Re{f exp(i w t)}), in length.
    force : (n_dof,) ndarray
        The force amplitudes f, in force units.
    method : str
        ``"direct"``, ``"modal"`` or ``"state_space"``.
    solver : str
        What ran: ``"tridiagonal"``, ``"banded"``, ``"sparse LU"``, ``"dense LU"`` (direct),
        ``"modal"`` or ``"state space"``.
    n_modes : int or None
        Modes superposed (modal: real normal modes; state space: complex mode pairs); None for
        the direct method.
    residual_correction : bool
        Whether the static contribution of the dropped modes was added (modal method).
    truncation_error : (n_freq,) ndarray
        Estimated relative error ||x - x_exact||_M / ||x||_M from the dropped modes
        (M-norm ||x||_M = sqrt(x^H M x)); 0 where nothing was dropped (direct, state space,
        all modes). See `frequency_response` for how it is estimated.
    natural_frequencies : (n_modes,) ndarray or None
        omega_k of the modes used (modal), or |Im s| of the complex modes (state space),
        in rad per time unit; None for the direct method.
    units : UnitSystem
        Unit system of the inputs.
    """

    omegas: NDArray[np.float64]
    response: NDArray[np.complex128]
    force: NDArray[np.float64]
    method: str
    solver: str
    n_modes: int | None
    residual_correction: bool
    truncation_error: NDArray[np.float64]
    natural_frequencies: NDArray[np.float64] | None
    units: UnitSystem = DIMENSIONLESS

    def __post_init__(self) -> None:
        _freeze_arrays(self)

    @property
    def n_dof(self) -> int:
        """Number of degrees of freedom."""
        return int(self.response.shape[1])

    def amplitude(self) -> NDArray[np.float64]:
        """(n_freq, n_dof) |x(w)|, in length."""
        return np.abs(self.response)

    def phase(self) -> NDArray[np.float64]:
        """(n_freq, n_dof) arg x(w) in (-pi, pi], in rad (lag of each dof behind the force)."""
        return np.angle(self.response)


@dataclass(frozen=True, eq=False)
class Transient:
    """Motion of a multi-dof system under a harmonic force, by modal superposition.

    Attributes
    ----------
    t : (n_t,) ndarray
        Times, in time units.
    displacement : (n_t, n_dof) ndarray
        u(t), in length.
    velocity : (n_t, n_dof) ndarray
        u'(t), in length per time unit.
    n_modes : int
        Number of normal modes superposed.
    """

    t: NDArray[np.float64]
    displacement: NDArray[np.float64]
    velocity: NDArray[np.float64]
    n_modes: int

    def __post_init__(self) -> None:
        _freeze_arrays(self)


# ====================================================================== input checks
def _structure(K: Any, M: Any, C: Any, force: Any) -> tuple[Any, NDArray[np.float64], Any, NDArray[np.float64]]:
    stiffness = _validate.square_matrix(K, "K")
    stiffness = _validate.symmetric(stiffness, "K")
    n_dof = stiffness.shape[0]
    mass = _validate.mass_argument(M, n_dof, "M")
    damping = None
    if C is not None:
        damping = _validate.square_matrix(C, "C")
        if damping.shape[0] != n_dof:
            raise ValueError(f"C must be ({n_dof}, {n_dof}) to match K, got shape {damping.shape}")
        damping = _validate.symmetric(damping, "C")
        diagonal = damping.diagonal()
        bad = np.flatnonzero(diagonal < 0)
        if bad.size:
            i = int(bad[0])
            raise ValueError(
                f"C[{i},{i}] is {diagonal[i]!r}; a damping matrix must have a non-negative "
                "diagonal (no negative damping)"
            )
    loads = _validate.real_array(force, "force", ndim=1)
    if loads.shape[0] != n_dof:
        raise ValueError(f"force must have {n_dof} entries to match K, got shape {loads.shape}")
    return stiffness, mass, damping, loads


def _half_bandwidth(matrix: Any) -> int:
    if matrix is None:
        return 0
    if sp.issparse(matrix):
        coo = sp.coo_matrix(matrix)
        nonzero = coo.data != 0
        if not nonzero.any():
            return 0
        return int(np.max(np.abs(coo.row[nonzero] - coo.col[nonzero])))
    if matrix.ndim == 1:
        return 0
    rows, cols = np.nonzero(matrix)
    return int(np.max(np.abs(rows - cols))) if rows.size else 0


def _diagonal_band(matrix: Any, n_dof: int, offset: int) -> NDArray[np.float64]:
    """Diagonal `offset` (>= 0 above, < 0 below) of a dense/sparse matrix or mass vector."""
    length = n_dof - abs(offset)
    if matrix is None:
        return np.zeros(length)
    if not sp.issparse(matrix) and matrix.ndim == 1:
        return matrix.astype(float) if offset == 0 else np.zeros(length)
    return np.asarray(matrix.diagonal(offset), dtype=float)


def _as_operator(matrix: Any, n_dof: int) -> Any:
    if matrix is None:
        return sp.csr_matrix((n_dof, n_dof))
    if not sp.issparse(matrix) and matrix.ndim == 1:
        return sp.diags(matrix, format="csr")
    return matrix


def _singular(pivots: NDArray[Any], scale: float, n_dof: int) -> bool:
    # An exactly singular matrix (undamped resonance, rigid-body modes at w = 0) leaves an
    # LU pivot of round-off size, about eps * ||A||; n_dof * eps * ||A|| is well above that
    # and far below the smallest pivot of a lightly damped system at resonance (~ w c).
    return bool(np.min(np.abs(pivots)) <= 8.0 * n_dof * _EPS * scale)


def _singular_error(i: int, w: float) -> ValueError:
    return ValueError(
        f"omegas[{i}] is {w!r}: K - w^2 M + i w C is singular there (an undamped resonance, "
        "or w = 0 for a free structure whose rigid-body modes have an unbounded static "
        "response); add damping or leave out that frequency"
    )


# ====================================================================== direct method
def _direct(K: Any, mass: NDArray[np.float64], C: Any, omegas: NDArray[np.float64],
            force: NDArray[np.float64]) -> tuple[NDArray[np.complex128], str]:
    n_dof = K.shape[0]
    width = max(_half_bandwidth(K), _half_bandwidth(mass), _half_bandwidth(C))
    response = np.empty((omegas.size, n_dof), dtype=complex)
    scale_base = (_max_abs(K), _max_abs(mass), _max_abs(C))
    rhs = force.astype(complex)
    if n_dof >= 3 and width <= 1:  # scipy's tridiagonal wrappers reject n = 2
        # One LAPACK zgtsv per frequency (LU with partial pivoting, then the solve); on exit
        # its `d` holds the diagonal of U, which gives the singularity check for free. The
        # diagonals of A(w) are written straight into the real and imaginary parts of fresh
        # complex buffers (three passes, no temporaries): assembly costs ~10 % of the solve.
        parts = {
            offset: [_diagonal_band(A, n_dof, offset) for A in (K, mass, C)]
            for offset in (-1, 0, 1)
        }
        gtsv = lapack.zgtsv
        for i, w in enumerate(omegas):
            w2 = w * w
            bands = []
            for offset in (-1, 0, 1):
                k_part, m_part, c_part = parts[offset]
                band = np.empty(n_dof - abs(offset), dtype=complex)
                pair = band.view(float).reshape(-1, 2)
                if m_part.any():
                    np.multiply(m_part, -w2, out=pair[:, 0])
                    pair[:, 0] += k_part
                else:
                    pair[:, 0] = k_part
                np.multiply(c_part, w, out=pair[:, 1])
                bands.append(band)
            _, pivots, _, x, info = gtsv(bands[0], bands[1], bands[2], rhs.copy(),
                                         overwrite_dl=1, overwrite_d=1, overwrite_du=1, overwrite_b=1)
            if info > 0 or _singular(pivots, _scale(scale_base, w), n_dof):
                raise _singular_error(i, float(w))
            response[i] = x.ravel()
        return response, "tridiagonal"
    if n_dof >= 2 and width <= BANDED_MAX_HALF_WIDTH:
        kl = ku = width
        storage = [_band_storage(A, n_dof, width) for A in (K, mass, C)]
        gbsv = lapack.zgbsv
        for i, w in enumerate(omegas):
            ab = np.zeros((2 * kl + ku + 1, n_dof), dtype=complex, order="F")
            ab[kl:] = storage[0] - (w * w) * storage[1] + (1j * w) * storage[2]
            lu, _, x, info = gbsv(kl, ku, ab, rhs.copy(), overwrite_ab=1, overwrite_b=1)
            if info > 0 or _singular(lu[kl + ku], _scale(scale_base, w), n_dof):
                raise _singular_error(i, float(w))
            response[i] = x.ravel()
        return response, "banded"
    if sp.issparse(K) or sp.issparse(C) or n_dof > 1000:
        K_op, M_op, C_op = (sp.csc_matrix(_as_operator(A, n_dof)) for A in (K, mass, C))
        for i, w in enumerate(omegas):
            A = sp.csc_matrix(K_op - (w * w) * M_op + (1j * w) * C_op)
            try:
                lu = spla.splu(A)
            except RuntimeError:  # "Factor is exactly singular"
                raise _singular_error(i, float(w)) from None
            if _singular(lu.U.diagonal(), _scale(scale_base, w), n_dof):
                raise _singular_error(i, float(w))
            response[i] = lu.solve(rhs)
        return response, "sparse LU"
    K_dense = _dense(K, n_dof)
    M_dense = _dense(mass, n_dof)
    C_dense = _dense(C, n_dof)
    for i, w in enumerate(omegas):
        A = K_dense - (w * w) * M_dense + (1j * w) * C_dense
        lu, piv = la.lu_factor(A, check_finite=False)
        if _singular(np.diagonal(lu), _scale(scale_base, w), n_dof):
            raise _singular_error(i, float(w))
        response[i] = la.lu_solve((lu, piv), rhs, check_finite=False)
    return response, "dense LU"


def _max_abs(matrix: Any) -> float:
    if matrix is None:
        return 0.0
    if sp.issparse(matrix):
        return float(abs(matrix).max()) if matrix.nnz else 0.0
    return float(np.max(np.abs(matrix))) if matrix.size else 0.0


def _scale(base: tuple[float, float, float], w: float) -> float:
    return max(base[0], w * w * base[1], w * base[2], 1e-300)


def _dense(matrix: Any, n_dof: int) -> NDArray[np.float64]:
    if matrix is None:
        return np.zeros((n_dof, n_dof))
    if sp.issparse(matrix):
        return matrix.toarray()
    if matrix.ndim == 1:
        return np.diag(matrix)
    return np.asarray(matrix, dtype=float)


def _band_storage(matrix: Any, n_dof: int, width: int) -> NDArray[np.float64]:
    """LAPACK band storage (2 width + 1, n_dof): row width + i - j holds A[i, j]."""
    band = np.zeros((2 * width + 1, n_dof))
    for offset in range(-width, width + 1):
        diagonal = _diagonal_band(matrix, n_dof, offset)
        row = width - offset
        if offset >= 0:
            band[row, offset:] = diagonal
        else:
            band[row, :offset] = diagonal
    return band


# ====================================================================== modal method
def _mass_times(mass: NDArray[np.float64], x: NDArray[Any]) -> NDArray[Any]:
    if mass.ndim == 1:
        return mass[:, None] * x if x.ndim == 2 else mass * x
    return mass @ x


def _m_norm_rows(mass: NDArray[np.float64], rows: NDArray[np.complex128]) -> NDArray[np.float64]:
    """sqrt(x^H M x) of each row x of `rows`."""
    if mass.ndim == 1:
        return np.sqrt(np.einsum("fi,i,fi->f", rows.conj(), mass, rows).real)
    return np.sqrt(np.einsum("fi,fi->f", rows.conj(), rows @ mass).real.clip(min=0.0))


def _static_flexible(K: Any, mass: NDArray[np.float64], rigid: NDArray[np.float64],
                     force: NDArray[np.float64]) -> NDArray[np.float64]:
    """x with K x = f - M R R^T f and R^T M x = 0 (R: M-orthonormal rigid-body modes).

    The bordered system [[K, M R], [R^T M, 0]] is solved; without rigid-body modes it is K x = f.
    This is K's pseudo-inverse on the flexible subspace: sum over flexible modes of
    phi_k phi_k^T f / omega_k^2.
    """
    n_dof = K.shape[0]
    n_rigid = rigid.shape[1]
    MR = _mass_times(mass, rigid) if n_rigid else np.zeros((n_dof, 0))
    if sp.issparse(K) or n_dof > 2000:
        border = sp.csr_matrix(MR)
        system = sp.bmat([[sp.csr_matrix(K), border], [border.T, None]], format="csc")
        rhs = np.concatenate([force, np.zeros(n_rigid)])
        try:
            solution = spla.splu(system).solve(rhs)
        except RuntimeError:
            raise ValueError(
                "K is singular beyond its computed rigid-body modes: the static (residual) "
                "correction needs every zero mode among the kept ones; raise n_modes"
            ) from None
    else:
        system = np.block([[_dense(K, n_dof), MR], [MR.T, np.zeros((n_rigid, n_rigid))]])
        rhs = np.concatenate([force, np.zeros(n_rigid)])
        solution = la.solve(system, rhs, assume_a="sym")
    if not np.all(np.isfinite(solution)):
        raise ValueError("the static (residual) correction failed: K is singular beyond its rigid-body modes")
    return solution[:n_dof]


def _modal(K: Any, mass: NDArray[np.float64], C: Any, omegas: NDArray[np.float64],
           force: NDArray[np.float64], n_modes: int | None, damping_ratios: Any,
           residual_correction: bool, modes: Modes | None,
           ) -> tuple[NDArray[np.complex128], NDArray[np.float64], int, NDArray[np.float64]]:
    n_dof = K.shape[0]
    wanted = n_dof if n_modes is None else n_modes
    if modes is None:
        # One extra mode, when there is one, tells how far the first dropped mode lies.
        modes = normal_modes(K, mass, n_modes=min(wanted + 1, n_dof))
    else:
        if not isinstance(modes, Modes):
            raise TypeError(f"modes must be a vibra.Modes, got {type(modes).__name__}")
        if modes.shapes is None:
            raise ValueError("modes has no shapes (computed with vectors=False); the modal method needs them")
        if modes.n_dof != n_dof:
            raise ValueError(f"modes has {modes.n_dof} dofs; K has {n_dof}")
        if modes.n_modes < wanted:
            raise ValueError(f"modes holds {modes.n_modes} modes; n_modes asks for {wanted}")
    shapes_all = np.asarray(modes.shapes)
    omega_all = np.asarray(modes.omega)
    shapes = shapes_all[:, :wanted]
    # Rigid-body modes come out of the eigensolver as round-off (~1e-8 omega_max); they are
    # exactly 0, so that w = 0 is refused for them rather than answered with ~1e16 f.
    rigid_mask = np.asarray(modes.zero_modes())[:wanted]
    omega = np.where(rigid_mask, 0.0, omega_all[:wanted])
    dropped = wanted < n_dof

    # Modal damping c_k (the modal equations are q'' + c_k q' + omega_k^2 q = phi_k^T f).
    modal_c = _modal_damping(shapes, omega, C, damping_ratios, "use method='direct' or method='state_space'")
    if damping_ratios is not None:
        next_c = modal_c[-1] * abs(omega_all[wanted]) / max(abs(omega[-1]), 1e-300) if (
            dropped and omega_all.size > wanted) else (modal_c[-1] if modal_c.size else 0.0)
    elif C is None:
        next_c = 0.0
    else:
        if dropped and omega_all.size > wanted:
            extra = shapes_all[:, wanted]
            next_c = float(extra @ (_as_operator(C, n_dof) @ extra))
        else:
            next_c = float(modal_c[-1]) if modal_c.size else 0.0

    loads = shapes.T @ force                                           # phi_k^T f
    w = omegas[:, None]
    stable = omega >= 0
    stiffness_term = np.where(stable, (np.abs(omega) - w) * (np.abs(omega) + w), -(omega**2) - w * w)
    denominators = stiffness_term + 1j * w * modal_c
    zero = denominators == 0
    if (zero & (loads != 0)).any():
        first = int(np.argwhere(zero & (loads != 0))[0, 0])
        raise _singular_error(first, float(omegas[first]))
    with np.errstate(divide="ignore", invalid="ignore"):
        coefficients = np.where(zero, 0.0, loads / np.where(zero, 1.0, denominators))
    response = coefficients.real @ shapes.T + 1j * (coefficients.imag @ shapes.T)

    error = np.zeros(omegas.size)
    if dropped:
        rigid = shapes[:, rigid_mask]
        flexible = ~rigid_mask
        static = _static_flexible(K, mass, rigid, force)
        kept_static = shapes[:, flexible] @ (loads[flexible] / omega[flexible] ** 2 * np.sign(omega[flexible]))
        residual = static - kept_static                                # sum over dropped modes
        if residual_correction:
            response = response + residual[None, :]
        lam = float(omega_all[wanted] * abs(omega_all[wanted])) if omega_all.size > wanted else float(
            omega[-1] * abs(omega[-1]))
        factor = _dropped_factor(omegas, lam, next_c, residual_correction)
        residual_norm = float(np.sqrt(residual @ _mass_times(mass, residual)))
        norms = _m_norm_rows(mass, response)
        with np.errstate(divide="ignore", invalid="ignore"):
            error = np.where(norms > 0, factor * residual_norm / norms,
                             np.where(factor * residual_norm > 0, np.inf, 0.0))
    return response, error, wanted, omega


def _modal_damping(shapes: NDArray[np.float64], omega: NDArray[np.float64], C: Any, damping_ratios: Any,
                   remedy: str) -> NDArray[np.float64]:
    """(n_modes,) modal damping c_k (q'' + c_k q' + omega_k^2 q = phi_k^T f), in 1 / time unit.

    2 zeta_k |omega_k| from `damping_ratios`, else diag(Phi^T C Phi) when C is diagonal in
    the modal basis (within MODAL_DIAGONAL_RTOL), zero without C; `remedy` ends the error.
    """
    n_dof, wanted = shapes.shape
    if damping_ratios is not None:
        ratios = _validate.real_array(damping_ratios, "damping_ratios", ndim=(0, 1))
        ratios = np.broadcast_to(ratios, (wanted,)) if ratios.ndim == 0 else ratios
        if ratios.shape != (wanted,):
            raise ValueError(f"damping_ratios must have {wanted} entries (one per mode), got shape {ratios.shape}")
        _validate.nonnegative(ratios, "damping_ratios", "damping ratio")
        return 2.0 * ratios * np.abs(omega)
    if C is None:
        return np.zeros(wanted)
    projected = shapes.T @ (_as_operator(C, n_dof) @ shapes)
    modal_c = np.diagonal(projected).copy()
    off = projected - np.diag(modal_c)
    size = float(np.max(np.abs(projected))) if projected.size else 0.0
    gap = float(np.max(np.abs(off))) if off.size else 0.0
    if gap > MODAL_DIAGONAL_RTOL * size:
        i, j = np.unravel_index(int(np.argmax(np.abs(off))), off.shape)
        raise ValueError(
            f"C is not diagonal in the modal basis (non-proportional damping): "
            f"|Phi^T C Phi|[{i},{j}] = {gap:.3g} > {MODAL_DIAGONAL_RTOL:g} * {size:.3g}; {remedy}"
        )
    return modal_c


def _dropped_factor(omegas: NDArray[np.float64], lam: float, c: float, corrected: bool,
                    ) -> NDArray[np.float64]:
    """sup over dropped modes (lambda_k = omega_k^2 >= lam, damping c) of |g(lambda, w)|.

    The error of the modal sum is sum_dropped phi_k (phi_k^T f / lambda_k) g_k with
    g = lambda / (lambda - w^2 + i w c) (no correction) or (w^2 - i w c) / (lambda - w^2 + i w c)
    (with the static correction), so ||error||_M <= sup |g| * ||r||_M. The sup is taken over a
    geometric grid of lambda >= lam, plus lambda = w^2 when a dropped mode may resonate there.
    """
    grid = lam * np.geomspace(1.0, 1e8, 80)
    w2 = omegas * omegas
    candidates = np.broadcast_to(grid, (omegas.size, grid.size))
    candidates = np.concatenate([candidates, np.maximum(w2, lam)[:, None]], axis=1)
    w = omegas[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        near = candidates - w * w + 1j * w * c
        if corrected:
            values = np.abs((w * w - 1j * w * c) / near)
        else:
            values = np.abs(candidates / near)
    values = np.where(np.isnan(values), np.inf, values)
    return values.max(axis=1)


# ====================================================================== state-space method
def _state_space(K: Any, mass: NDArray[np.float64], C: Any, omegas: NDArray[np.float64],
                 force: NDArray[np.float64]) -> tuple[NDArray[np.complex128], NDArray[np.float64]]:
    n_dof = K.shape[0]
    if n_dof > 2000:
        raise ValueError(f"method='state_space' is dense (2 n_dof = {2 * n_dof}); use method='direct' for n_dof > 2000")
    K_dense, M_dense, C_dense = _dense(K, n_dof), _dense(mass, n_dof), _dense(C, n_dof)
    zero = np.zeros((n_dof, n_dof))
    # First-order form with z = (u, u'): A z' + B z = (f, 0), both symmetric.
    A = np.block([[C_dense, M_dense], [M_dense, zero]])
    B = np.block([[K_dense, zero], [zero, -M_dense]])
    eigenvalues, left, right = la.eig(-B, A, left=True, right=True)
    if not np.all(np.isfinite(eigenvalues)):
        raise RuntimeError("the state-space eigenproblem returned infinite eigenvalues")
    loads = np.concatenate([force, np.zeros(n_dof)])
    modal_mass = np.einsum("ir,ij,jr->r", left.conj(), A, right)       # y_r^H A x_r
    participation = (left.conj().T @ loads) / modal_mass               # y_r^H F / (y_r^H A x_r)
    denominators = 1j * omegas[:, None] - eigenvalues[None, :]
    if (denominators == 0).any():
        i = int(np.argwhere(denominators == 0)[0, 0])
        raise _singular_error(i, float(omegas[i]))
    response = (participation / denominators) @ right[:n_dof].T
    natural = np.sort(np.abs(eigenvalues.imag))[::2]
    return response, natural


# ====================================================================== public functions
def frequency_response(
    K: ArrayLike | sp.spmatrix,
    M: ArrayLike,
    C: ArrayLike | sp.spmatrix | None,
    omegas: ArrayLike,
    force: ArrayLike,
    *,
    method: Literal["direct", "modal", "state_space"] = "direct",
    n_modes: int | None = None,
    damping_ratios: ArrayLike | None = None,
    residual_correction: bool = False,
    modes: Modes | None = None,
    units: str | UnitSystem = DIMENSIONLESS,
) -> FrequencyResponse:
    """Receptance response x(w) = (K - w^2 M + i w C)^-1 f at many frequencies.

    Parameters
    ----------
    K : (n_dof, n_dof) array_like or scipy.sparse matrix
        Symmetric stiffness, in force per length.
    M : (n_dof,) or (n_dof, n_dof) array_like
        Diagonal masses or an SPD mass matrix, as in `vibra.normal_modes`.
    C : (n_dof, n_dof) array_like or scipy.sparse matrix, or None
        Symmetric damping matrix with a non-negative diagonal, in mass per time unit
        (`friction_damping`, `rayleigh_damping`, or any); None for no damping matrix.
    omegas : (n_freq,) array_like
        Driving angular frequencies >= 0, in rad per time unit.
    force : (n_dof,) array_like
        Force amplitudes f (force Re{f exp(i w t)}), in force units.
    method : {"direct", "modal", "state_space"}
        ``"direct"``: one LU per frequency, tridiagonal or banded when K, M and C are (half
        bandwidth <= `BANDED_MAX_HALF_WIDTH`), sparse LU otherwise (dense LU for small dense
        input); exact to round-off times the conditioning. ``"modal"``: superposition of the
        lowest `n_modes` normal modes; C must be diagonal in the modal basis (friction,
        Rayleigh) or replaced by `damping_ratios`. ``"state_space"``: complex modes of the
        first-order form (dense, all modes), for non-proportional C.
    n_modes : int, optional
        Modal method: how many of the lowest modes to keep (all by default).
    damping_ratios : float or (n_modes,) array_like, optional
        Modal method only, instead of C: damping ratio zeta_k >= 0 of each kept mode
        (modal damping c_k = 2 zeta_k omega_k).
    residual_correction : bool
        Modal method: add the static response of the dropped modes,
        sum_{k dropped} phi_k phi_k^T f / omega_k^2, computed as K^+ f minus the kept modes'
        share (K^+ the pseudo-inverse on the flexible subspace, so rigid-body modes are left
        to the modal sum).
    modes : Modes, optional
        Modal method: normal modes of (K, M) already computed (at least `n_modes`; one more
        sharpens the error estimate). Computed with `vibra.normal_modes` otherwise.
    units : str or UnitSystem
        Unit system of K, M, C, carried by the result.

    Returns
    -------
    FrequencyResponse
        With `truncation_error`: for the modal method with dropped modes, an estimate of
        ||x - x_exact||_M / ||x||_M taken from the first dropped mode (omega_d, c_d) and
        the static residual r = sum_dropped phi_k phi_k^T f / omega_k^2:
        max(1, |omega_d^2 / (omega_d^2 - w^2 + i w c_d)|) ||r||_M / ||x||_M without the
        correction (an upper bound below the first dropped mode), and
        |(w^2 - i w c_d) / (omega_d^2 - w^2 + i w c_d)| ||r||_M / ||x||_M with it (its
        leading term). 0 elsewhere.

    Raises
    ------
    ValueError
        K not square/symmetric/finite; M, C or force not matching K; C with a negative
        diagonal; omegas negative; unknown method; n_modes out of range or given to a
        method without modes; damping_ratios with C or outside the modal method; C not
        diagonal in the modal basis (modal method); a frequency where the system is singular
        (undamped resonance, or w = 0 with rigid-body modes).
    TypeError
        Arguments of the wrong kind.

    Examples
    --------
    >>> import numpy as np
    >>> K = np.array([[2.0, -1.0], [-1.0, 2.0]])
    >>> x = frequency_response(K, [1.0, 1.0], None, [0.0], [1.0, 0.0]).response
    >>> np.round(x.real, 12)           # K^-1 f
    array([[0.66666667, 0.33333333]])
    """
    _validate.choice(method, "method", METHODS)
    stiffness, mass, damping, loads = _structure(K, M, C, force)
    n_dof = stiffness.shape[0]
    frequencies = _validate.real_array(omegas, "omegas", ndim=1)
    _validate.nonnegative(frequencies, "omegas", "angular frequency")
    if n_modes is not None:
        if method != "modal":
            raise ValueError(f"n_modes is {n_modes!r}; it applies to method='modal' only")
        n_modes = _validate.count(n_modes, "n_modes", low=1, high=n_dof)
    if damping_ratios is not None:
        if method != "modal":
            raise ValueError("damping_ratios applies to method='modal' only")
        if damping is not None:
            raise ValueError("give either C or damping_ratios, not both")
    if not isinstance(residual_correction, (bool, np.bool_)):
        raise TypeError(f"residual_correction must be a bool, got {type(residual_correction).__name__}")
    if modes is not None and method != "modal":
        raise ValueError("modes applies to method='modal' only")
    unit = unit_system(units)

    error = np.zeros(frequencies.size)
    natural: NDArray[np.float64] | None = None
    used: int | None = None
    if method == "direct":
        response, solver = _direct(stiffness, mass, damping, frequencies, loads)
    elif method == "modal":
        response, error, used, natural = _modal(
            stiffness, mass, damping, frequencies, loads, n_modes, damping_ratios,
            bool(residual_correction), modes,
        )
        solver = "modal"
    else:
        response, natural = _state_space(stiffness, mass, damping, frequencies, loads)
        used = n_dof
        solver = "state space"
    return FrequencyResponse(
        omegas=frequencies, response=response, force=loads, method=method, solver=solver,
        n_modes=used, residual_correction=bool(residual_correction) and method == "modal",
        truncation_error=error, natural_frequencies=natural, units=unit,
    )


def frf(
    K: ArrayLike | sp.spmatrix,
    M: ArrayLike,
    C: ArrayLike | sp.spmatrix | None,
    omegas: ArrayLike,
    force: ArrayLike,
    *,
    method: Literal["direct", "modal", "state_space"] = "direct",
    n_modes: int | None = None,
) -> NDArray[np.complex128]:
    """(n_freq, n_dof) complex receptance response (K - w^2 M + i w C)^-1 f, in length.

    The array of `frequency_response` (same arguments and errors), without the residual
    correction; use `frequency_response` for the solver used, the truncation error estimate
    and the other options.

    Examples
    --------
    >>> import numpy as np
    >>> x = frf(np.array([[1.0]]), [1.0], np.array([[0.5]]), [1.0], [1.0])
    >>> np.round(x, 12)                # 1 / (1 - 1 + 0.5 i)
    array([[0.-2.j]])
    """
    return np.array(
        frequency_response(K, M, C, omegas, force, method=method, n_modes=n_modes).response
    )


def transient_response(
    K: ArrayLike | sp.spmatrix,
    M: ArrayLike,
    C: ArrayLike | sp.spmatrix | None,
    t: ArrayLike,
    force: ArrayLike,
    *,
    omega: float = 0.0,
    u0: ArrayLike | None = None,
    v0: ArrayLike | None = None,
    n_modes: int | None = None,
    damping_ratios: ArrayLike | None = None,
    modes: Modes | None = None,
) -> Transient:
    """Motion of M u'' + C u' + K u = Re{f exp(i w t)} by modal superposition.

    Each normal coordinate q_k = phi_k^T M u obeys q'' + c_k q' + omega_k^2 q = phi_k^T f
    Re{exp(i w t)} and moves as one `Oscillator` (eq. 129, continuous across critical
    damping); u = sum_k phi_k q_k (eq. 150). Rigid-body modes (omega_k = 0) move as damped
    free masses. With n_modes < n_dof the result is the motion of the kept modes (the
    initial conditions and the force projected on them). A constant force (omega = 0) on a
    free structure makes its rigid-body modes drift: q = q0 + v0 t + f_k t^2 / 2 without
    damping, terminal velocity f_k / c_k with it (f_k = phi_k^T f).

    Parameters
    ----------
    K, M, C :
        As in `frequency_response` (C diagonal in the modal basis, or None).
    t : (n_t,) array_like
        Times >= 0, in time units.
    force : (n_dof,) array_like
        Force amplitudes f, in force units; omega = 0 gives a constant force switched on at
        t = 0 (a step), F0 = 0 the free damped motion.
    omega : float
        Driving angular frequency >= 0, in rad per time unit.
    u0, v0 : (n_dof,) array_like, optional
        Initial displacement (length) and velocity (length per time unit); zero by default.
    n_modes : int, optional
        How many of the lowest modes to superpose (all by default).
    damping_ratios : float or (n_modes,) array_like, optional
        Modal damping ratios instead of C.
    modes : Modes, optional
        Normal modes of (K, M) already computed.

    Returns
    -------
    Transient

    Raises
    ------
    ValueError
        As `frequency_response`; t negative; u0, v0 of the wrong length; a flexible mode
        with no damping driven exactly at its frequency, whose amplitude grows without bound.
    """
    stiffness, mass, damping, loads = _structure(K, M, C, force)
    n_dof = stiffness.shape[0]
    times = _validate.real_array(t, "t", ndim=1)
    _validate.nonnegative(times, "t", "time")
    w = _scalar(omega, "omega")
    if w < 0:
        raise ValueError(f"omega is {w!r}; the driving angular frequency must be >= 0")
    starts = []
    for name, value in (("u0", u0), ("v0", v0)):
        array = np.zeros(n_dof) if value is None else _validate.real_array(value, name, ndim=1)
        if array.shape[0] != n_dof:
            raise ValueError(f"{name} must have {n_dof} entries to match K, got shape {array.shape}")
        starts.append(array)
    if n_modes is not None:
        n_modes = _validate.count(n_modes, "n_modes", low=1, high=n_dof)
    if damping_ratios is not None and damping is not None:
        raise ValueError("give either C or damping_ratios, not both")
    wanted = n_dof if n_modes is None else n_modes
    if modes is None:
        modes = normal_modes(stiffness, mass, n_modes=wanted)
    elif not isinstance(modes, Modes):
        raise TypeError(f"modes must be a vibra.Modes, got {type(modes).__name__}")
    elif modes.shapes is None or modes.n_dof != n_dof or modes.n_modes < wanted:
        raise ValueError(f"modes must hold shapes of at least {wanted} modes of {n_dof} dofs")
    shapes = np.asarray(modes.shapes)[:, :wanted]
    # Rigid-body modes come out of the eigensolver as round-off (+-1e-8 omega_max); they are
    # exactly 0 (as in the modal FRF), so that a constant force drives them as free masses.
    omega_k = np.where(np.asarray(modes.zero_modes())[:wanted], 0.0, np.asarray(modes.omega)[:wanted])
    if np.any(omega_k < 0):
        raise ValueError("K has imaginary (unstable) modes; transient_response needs K positive semi-definite")
    modal_c = _modal_damping(shapes, omega_k, damping, damping_ratios,
                             "transient_response superposes real normal modes and needs friction, "
                             "Rayleigh or modal damping")
    loads_q = shapes.T @ loads
    q0 = shapes.T @ _mass_times(mass, starts[0])
    qd0 = shapes.T @ _mass_times(mass, starts[1])
    denominators = _denominator(omega_k, modal_c, w)
    zero = (denominators == 0) & (loads_q != 0)
    # omega = 0 makes the denominator vanish only for rigid-body modes (omega_k = 0): a
    # constant force on a free mass has no steady state but a well-defined drift.
    drift = zero & (omega_k == 0)
    if (zero & ~drift).any():
        k = int(np.flatnonzero(zero & ~drift)[0])
        raise ValueError(
            f"mode {k} (omega_k = {float(omega_k[k])!r}) has no damping and is driven at omega = {w!r}: "
            "its amplitude grows without bound; add damping"
        )
    with np.errstate(divide="ignore", invalid="ignore"):
        amplitude = np.where(denominators == 0, 0.0, loads_q / np.where(denominators == 0, 1.0, denominators))
    column = times[:, None]
    q = _oscillator_state(column, omega_k, modal_c, q0, qd0, amplitude, w, derivative=False)
    qd = _oscillator_state(column, omega_k, modal_c, q0, qd0, amplitude, w, derivative=True)
    if drift.any():
        q[:, drift], qd[:, drift] = _pushed_free_mass(column, modal_c[drift], q0[drift], qd0[drift],
                                                      loads_q[drift])
    return Transient(t=times, displacement=q @ shapes.T, velocity=qd @ shapes.T, n_modes=wanted)


def _phi(x: NDArray[np.float64], order: int) -> NDArray[np.float64]:
    """phi_1(x) = (1 - e^-x) / x or phi_2(x) = (x - 1 + e^-x) / x^2, x >= 0, without cancellation.

    Both are sum_n (-x)^n / (n + order)!; the series (25 terms, remainder < 1e-27) is used for
    x <= 1, the closed form (with expm1, cancelling at most a factor e) above.
    """
    x = np.asarray(x, dtype=float)
    small = x <= 1.0
    series = np.zeros_like(x)
    term = np.full_like(x, 1.0 / math.factorial(order))
    for n in range(25):
        series += term
        term = term * (-x) / (n + 1 + order)
    safe = np.where(small, 1.0, x)
    closed = -np.expm1(-safe) / safe if order == 1 else (safe + np.expm1(-safe)) / (safe * safe)
    return np.where(small, series, closed)


def _pushed_free_mass(t: NDArray[np.float64], c: NDArray[np.float64], q0: NDArray[np.float64],
                      v0: NDArray[np.float64], load: NDArray[np.float64],
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """q(t), q'(t) of q'' + c q' = load (constant), q(0) = q0, q'(0) = v0, c >= 0.

    q = q0 + v0 t phi_1(c t) + load t^2 phi_2(c t), q' = v0 e^(-c t) + load t phi_1(c t):
    uniform acceleration q0 + v0 t + load t^2 / 2 for c = 0, drift at load / c for c t >> 1.
    """
    x = c * t
    phi_1, phi_2 = _phi(x, 1), _phi(x, 2)
    return q0 + v0 * t * phi_1 + load * t * t * phi_2, v0 * np.exp(-x) + load * t * phi_1
