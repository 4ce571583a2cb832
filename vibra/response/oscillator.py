"""The single forced, damped oscillator (Kneller, Mécanique analytique, section 5.1, eqs. 114-131).

    u'' + gamma u' + w0^2 u = F(t) / m,

with friction -m gamma u' (Kneller, Mécanique analytique, eq. 61). For a harmonic force F(t) = Re{F0 exp(i w t)}
(eq. 118) the steady state is u_p(t) = Re{u0(w) exp(i w t)} with the complex amplitude
u0(w) = (F0/m) / (w0^2 - w^2 + i gamma w) (eq. 120); the full motion adds the homogeneous
part fixed by the initial conditions (eqs. 126-129), which dies out for t >> 1/gamma
(eqs. 130-131). `Oscillator` holds these formulas in forms that keep their digits at the
extremes (near resonance, near critical damping gamma = 2 w0, gamma >> w0, w -> 0 and
w -> infinity). `oscillator_state` and `receptance_denominator` are the same formulas on
arrays, for the modal superposition of `vibra.response.transient`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate


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


def receptance_denominator(w0: float | NDArray[np.float64], gamma: float | NDArray[np.float64],
                           omega: float | NDArray[np.float64]) -> NDArray[np.complex128]:
    """w0^2 - w^2 + i gamma w, with w0^2 - w^2 written as (w0 - w)(w0 + w)."""
    return (w0 - omega) * (w0 + omega) + 1j * (gamma * omega)


@dataclass(frozen=True, eq=False)
class Oscillator:
    """The forced, damped oscillator u'' + gamma u' + w0^2 u = F(t)/m (Kneller, Mécanique analytique, eq. 115).

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
        w0 = _validate.real_scalar(self.w0, "w0")
        gamma = _validate.real_scalar(self.gamma, "gamma")
        m = _validate.real_scalar(self.m, "m")
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
        """sqrt(w0^2 - gamma^2/4), in rad per time unit: Kneller's eq. (122).

        This is the angular frequency of the free damped oscillation (the imaginary part of
        the roots, eq. 126). None when gamma >= 2 w0: then the free motion does not oscillate.
        Note: Kneller's notes call it the resonance frequency, but the amplitude (121) peaks at
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
        resonance. (Kneller's eq. 122, sqrt(w0^2 - gamma^2/4) with the bound gamma < 2 w0,
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
        denominator = receptance_denominator(self.w0, self.gamma, w)
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
        as w -> infinity (Kneller's arctan(gamma w / (w^2 - w0^2)) with the quadrant fixed).
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
        denominator = complex(receptance_denominator(self.w0, self.gamma, w))
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
        start = _validate.real_scalar(u0, "u0")
        speed = _validate.real_scalar(v0, "v0")
        force = _complex_scalar(F0, "F0")
        w = float(_frequencies(omega, "omega"))
        amplitude = self._particular_amplitude(force, w)
        value = oscillator_state(
            times, self.w0, self.gamma, start, speed, amplitude, w, derivative=derivative,
        )
        return float(value) if np.ndim(value) == 0 else value


def oscillator_state(
    t: NDArray[np.float64], w0: float | NDArray[np.float64], gamma: float | NDArray[np.float64],
    u0: float | NDArray[np.float64], v0: float | NDArray[np.float64], amplitude: complex | NDArray[np.complex128],
    omega: float,
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

