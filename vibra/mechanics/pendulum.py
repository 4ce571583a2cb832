"""The simple pendulum, exact versus harmonic (Kneller, Mécanique analytique, examples 3, 6 and 8, figure 2).

The exact motion theta'' + Omega^2 sin(theta) = 0 (Omega = sqrt(g/l)) released at rest
from the amplitude theta0 has the period

    T(theta0) = 4 K(k^2) / Omega,    k = sin(theta0 / 2),

(K the complete elliptic integral of the first kind in scipy's parameter convention
m = k^2), and the closed form sin(theta/2) = k cd(Omega t | k^2), with cd = cn / dn the
Jacobi elliptic functions.

Near the top (theta0 -> pi) everything depends on the small complementary parameter
m1 = 1 - m = cos^2(theta0 / 2), which is computed directly (never as 1 - sin^2): the period
is 4 K(m) = 4 ellipkm1(m1), and the motion uses Jacobi functions evaluated from m1 by the
arithmetic-geometric mean after reducing Omega t modulo the period, so both stay accurate
to a few ulps up to theta0 = pi. ``amplitude = np.pi`` is read as pi itself, the
separatrix: an infinite period, and a pendulum released at rest on top stays there;
`separatrix_motion` is the motion on the separatrix that takes infinite time to reach it,
theta = 2 arcsin(tanh(Omega t)). The harmonic approximation theta0 cos(Omega t) has the period
2 pi / Omega whatever the amplitude (Kneller, Mécanique analytique, section 2.5); its period error grows as
theta0^2 / 16 and its trajectory error over a fixed number of periods as theta0^3.

With linear friction (example 6, eqs. 63-66) theta'' + eta theta' + Omega^2 sin(theta) = 0,
and the energy decays as dE/dt = -2 eta T.

Energies here are per unit moment of inertia m l^2 (so in rad^2 per time unit squared):
E = theta'^2 / 2 + Omega^2 (1 - cos theta). Times are in the time unit of `omega`
(seconds when omega is in rad/s).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import special

from vibra._core import validate as _validate
from vibra._core.frozen import Frozen

__all__ = [
    "PendulumMotion",
    "HarmonicError",
    "exact_period",
    "separatrix_motion",
    "harmonic_period",
    "exact_motion",
    "harmonic_motion",
    "damped_motion",
    "harmonic_error",
]


@dataclass(frozen=True, eq=False)
class PendulumMotion(Frozen):
    """One motion theta(t) of the simple pendulum.

    Attributes
    ----------
    t : (n_t,) ndarray
        Times, in the time unit of `omega` (s for omega in rad/s).
    theta : (n_t,) ndarray
        Angle from the downward vertical, in rad.
    theta_dot : (n_t,) ndarray
        Its rate, in rad per time unit.
    omega : float
        Small-amplitude angular frequency Omega = sqrt(g / l), in rad per time unit.
    eta : float
        Linear friction rate (Kneller, Mécanique analytique, example 6), in 1 / time unit; 0 without friction.
    method : str
        ``"elliptic"`` (Jacobi closed form), ``"separatrix"`` (`separatrix_motion`),
        ``"harmonic"`` (theta0 cos(Omega t) and its damped counterpart) or ``"solve_ivp"``
        (DOP853 integration).
    """

    t: NDArray[np.float64]
    theta: NDArray[np.float64]
    theta_dot: NDArray[np.float64]
    omega: float
    eta: float
    method: str

    @property
    def kinetic(self) -> NDArray[np.float64]:
        """(n_t,) kinetic energy theta'^2 / 2 per unit m l^2, in rad^2 per time unit^2."""
        return 0.5 * self.theta_dot**2

    @property
    def energy(self) -> NDArray[np.float64]:
        """(n_t,) total energy theta'^2 / 2 + Omega^2 (1 - cos theta) per unit m l^2.

        For a ``"harmonic"`` motion the potential is the harmonic one, Omega^2 theta^2 / 2.
        """
        if self.method == "harmonic":
            potential = 0.5 * self.omega**2 * self.theta**2
        else:
            potential = self.omega**2 * (1.0 - np.cos(self.theta))
        return self.kinetic + potential


@dataclass(frozen=True, eq=False)
class HarmonicError(Frozen):
    """How far the harmonic approximation is from the exact pendulum, per amplitude.

    Attributes
    ----------
    amplitudes : (n,) ndarray
        Release angles theta0 (at rest), in rad.
    exact_period : (n,) ndarray
        4 K(sin^2(theta0/2)) / Omega, in time units.
    harmonic_period : float
        2 pi / Omega, in time units.
    period_error : (n,) ndarray
        Relative period error exact_period / harmonic_period - 1 (dimensionless, >= 0).
    trajectory_error : (n,) ndarray
        Largest |theta_harmonic - theta_exact| over `n_periods` harmonic periods, in rad.
    n_periods : float
        Length of the comparison window, in harmonic periods.
    omega : float
        Omega, in rad per time unit.
    """

    amplitudes: NDArray[np.float64]
    exact_period: NDArray[np.float64]
    harmonic_period: float
    period_error: NDArray[np.float64]
    trajectory_error: NDArray[np.float64]
    n_periods: float
    omega: float

    @property
    def relative_trajectory_error(self) -> NDArray[np.float64]:
        """(n,) trajectory_error / amplitudes (dimensionless)."""
        return self.trajectory_error / self.amplitudes


# ---------------------------------------------------------------------- checks
_real_scalar = _validate.real_scalar


def _omega(omega: float) -> float:
    value = _real_scalar(omega, "omega")
    if not value > 0:
        raise ValueError(f"omega is {value!r}; the pendulum's Omega = sqrt(g/l) must be positive")
    return value


def _amplitudes(amplitude: ArrayLike, name: str = "amplitude") -> NDArray[np.float64]:
    if np.ndim(amplitude) == 0:
        values = np.asarray(_real_scalar(amplitude, name))
    else:
        values = _validate.real_array(amplitude, name, ndim=1)
    bad = ~((values > 0) & (values <= np.pi))
    if bad.any():
        index = int(np.argmax(np.atleast_1d(bad)))
        shown = f"{name}[{index}]" if values.ndim else name
        raise ValueError(
            f"{shown} is {float(np.atleast_1d(values)[index])!r} rad; a release angle must lie in (0, pi] "
            "(a period depends on |theta0| only; pi itself is the separatrix, of infinite period)"
        )
    return values


def _release_angle(angle: float) -> float:
    """A starting angle of a motion released at rest: |theta0| <= pi (0 is the trivial rest)."""
    value = _real_scalar(angle, "amplitude")
    if not abs(value) <= np.pi:
        raise ValueError(
            f"amplitude is {value!r} rad; a release angle must lie in [-pi, pi] "
            "(beyond pi the same motion is released from theta0 - 2 pi)"
        )
    return value


def _complement(theta0: NDArray[np.float64]) -> NDArray[np.float64]:
    """m1 = cos^2(theta0 / 2) = 1 - sin^2(theta0 / 2), without cancellation; 0 at theta0 = np.pi."""
    half = np.cos(0.5 * np.abs(theta0))
    return np.where(np.abs(theta0) == np.pi, 0.0, half * half)


def jacobi_sn_cn_dn(u: ArrayLike, m: float, m1: float
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """sn, cn, dn(u | m), 0 <= m <= 1 given with its complement m1 = 1 - m (both accurate).

    For m < 1/2 scipy's `ellipj` (Cephes' arithmetic-geometric mean) is accurate. Nearer to
    1 the AGM's backward phase recursion takes arcsin of numbers close to 1 and loses digits,
    so the ascending Landen transformation (Abramowitz and Stegun 16.14) is applied instead:
    m -> mu = 4k / (1 + k)^2 with complement mu1 = ((1 - k) / (1 + k))^2, where
    1 - k = m1 / (1 + k) keeps the small quantity, until the complement is below 1e-18 of
    the first one; there sn, cn, dn are tanh, sech, sech plus their first-order terms in the
    complement (A&S 16.15). Accurate to a few ulps absolute for |u| <= K(m).

    Examples
    --------
    >>> sn, cn, dn = jacobi_sn_cn_dn(np.array([0.5]), 1.0 - 1e-20, 1e-20)
    >>> bool(abs(sn[0] - np.tanh(0.5)) < 1e-15)
    True
    """
    x = np.asarray(u, dtype=float)
    if m < 0.5:
        sn, cn, dn, _ = special.ellipj(x, m)
        return sn, cn, dn
    chain: list[float] = []   # sqrt(mu1) of each ascending step
    complement, root = m1, np.sqrt(m)
    while complement * 16.0 > 1e-18 * m1 and len(chain) < 64:
        one_minus_k = complement / (1.0 + root)
        ratio = one_minus_k / (1.0 + root)            # sqrt(mu1) = (1 - k) / (1 + k)
        chain.append(ratio)
        x = x / (1.0 + ratio)
        complement = ratio * ratio
        root = np.sqrt(4.0 * root) / (1.0 + root)     # sqrt(mu) = 2 sqrt(k) / (1 + k)
    tanh, sech = np.tanh(x), 1.0 / np.cosh(x)
    product = np.sinh(x) * np.cosh(x)
    sn = tanh + 0.25 * complement * (product - x) * sech * sech
    cn = sech - 0.25 * complement * (product - x) * tanh * sech
    dn = sech + 0.25 * complement * (product + x) * tanh * sech
    for ratio in reversed(chain):
        mu = (1.0 - ratio) * (1.0 + ratio)            # the parameter one level down: 1 - mu1
        sn, cn, dn = ((1.0 + ratio) * sn * cn / dn,
                      (1.0 + ratio) / mu * (dn * dn - ratio) / dn,
                      (1.0 - ratio) / mu * (dn * dn + ratio) / dn)
    return sn, cn, dn


_EPS = float(np.finfo(float).eps)


_times = _validate.increasing_times


_tolerances = _validate.integration_tolerances


# ---------------------------------------------------------------------- periods
def exact_period(amplitude: ArrayLike, omega: float = 1.0) -> NDArray[np.float64]:
    """Exact period 4 K(sin^2(theta0/2)) / Omega of the pendulum released at rest.

    Computed as 4 ellipkm1(cos^2(theta0/2)) / Omega, which keeps the small complement
    1 - sin^2(theta0/2): a few ulps relative up to theta0 = pi (inf at ``np.pi``, the
    separatrix).

    Parameters
    ----------
    amplitude : float or (n,) array_like
        Release angle theta0, in rad, in (0, pi] (np.pi: the separatrix).
    omega : float
        Omega = sqrt(g / l), in rad per time unit.

    Returns
    -------
    float ndarray, shape of `amplitude`
        Periods, in time units.

    Raises
    ------
    TypeError
        amplitude or omega not real numbers.
    ValueError
        An amplitude outside (0, pi] (a period depends on |theta0| only); omega not positive.

    Examples
    --------
    >>> import numpy as np
    >>> from vibra.mechanics.pendulum import exact_period

    At 90 degrees the period is 18 % longer than 2 pi / Omega:

    >>> round(float(exact_period(np.pi / 2) / (2 * np.pi)), 6)
    1.180341
    """
    theta0 = _amplitudes(amplitude)
    w = _omega(omega)
    with np.errstate(divide="ignore"):
        return 4.0 * special.ellipkm1(_complement(theta0)) / w


def harmonic_period(omega: float = 1.0) -> float:
    """2 pi / Omega, the period of the harmonic approximation, in time units.

    Examples
    --------
    >>> harmonic_period(2.0)  # 2 pi / Omega
    3.141592653589793
    """
    return 2.0 * np.pi / _omega(omega)


# ---------------------------------------------------------------------- motions
def exact_motion(amplitude: float, t: ArrayLike, omega: float = 1.0) -> PendulumMotion:
    """Exact motion from rest at theta0: sin(theta/2) = k cd(Omega t | k^2), k = sin(theta0/2).

    Parameters
    ----------
    amplitude : float
        Release angle theta0, in rad, in [-pi, pi] (negative: released on the other side;
        +-np.pi: at rest on the top, where it stays).
    t : (n_t,) array_like
        Increasing times, in time units (t = 0 is the release).
    omega : float
        Omega, in rad per time unit.

    Returns
    -------
    PendulumMotion
        method ``"elliptic"``. With v = K - Omega t (reduced modulo the period 4K), the
        motion is sin(theta/2) = k sn(v), cos(theta/2) = dn(v), theta' = -2 k Omega cn(v),
        with the Jacobi functions of parameter m = k^2 taken from m1 = cos^2(theta0/2)
        (`jacobi_sn_cn_dn`): a few ulps up to theta0 = pi.

    Raises
    ------
    TypeError
        amplitude or omega not a real number.
    ValueError
        |amplitude| > pi; omega not positive; t not 1-D, finite and increasing.

    Examples
    --------
    >>> motion = exact_motion(0.5, [0.0, 1.0])
    >>> motion.theta.round(6).tolist()
    [0.5, 0.277699]
    """
    theta0 = _release_angle(amplitude)
    times = _times(t)
    w = _omega(omega)
    if abs(theta0) == np.pi:  # at rest on the unstable top: it stays there
        return PendulumMotion(t=times, theta=np.full(times.shape, theta0), theta_dot=np.zeros(times.shape),
                              omega=w, eta=0.0, method="elliptic")
    k = np.sin(0.5 * abs(theta0))
    m1 = float(_complement(np.asarray(theta0)))
    quarter = float(special.ellipkm1(m1))
    # v = K - Omega t, reduced into [-K, K] with sn(v + 2K) = -sn v, cn(v + 2K) = -cn v, dn(v + 2K) = dn v.
    v = np.mod(quarter - w * times + 2.0 * quarter, 4.0 * quarter) - 2.0 * quarter
    flip = np.where(np.abs(v) > quarter, -1.0, 1.0)
    v = np.where(v > quarter, v - 2.0 * quarter, np.where(v < -quarter, v + 2.0 * quarter, v))
    sn, cn, dn = jacobi_sn_cn_dn(v, k * k, m1)
    sign = np.sign(theta0)
    theta = 2.0 * sign * np.arctan2(k * flip * sn, dn)
    theta_dot = -2.0 * sign * k * w * flip * cn
    return PendulumMotion(t=times, theta=theta, theta_dot=theta_dot, omega=w, eta=0.0, method="elliptic")


def separatrix_motion(t: ArrayLike, omega: float = 1.0) -> PendulumMotion:
    """The motion on the separatrix (energy 2 Omega^2): theta = 2 arcsin(tanh(Omega t)).

    It passes the bottom at t = 0 with theta' = 2 Omega and creeps up to the top, theta -> pi
    as t -> +inf (and -> -pi as t -> -inf): the limit of `exact_motion` as theta0 -> pi,
    whose period 4 K / Omega grows like 4 ln(8 / (pi - theta0)) / Omega.

    Parameters
    ----------
    t : (n_t,) array_like
        Increasing times, in time units (any sign).
    omega : float
        Omega, in rad per time unit.

    Returns
    -------
    PendulumMotion
        method ``"separatrix"``: theta = 2 arctan(sinh(Omega t)) (twice the Gudermannian,
        the same as 2 arcsin(tanh(Omega t)) without its rounding near the top) and
        theta' = 2 Omega / cosh(Omega t).

    Raises
    ------
    TypeError
        omega not a real number.
    ValueError
        omega not positive; t not 1-D, finite and increasing.

    Examples
    --------
    >>> motion = separatrix_motion([0.0, 1.0, 40.0])
    >>> motion.theta.round(12).tolist(), float(motion.theta_dot[0])
    ([0.0, 1.731538966479, 3.14159265359], 2.0)
    """
    times = _times(t)
    w = _omega(omega)
    x = w * times
    # sin(theta/2) = tanh x, cos(theta/2) = sech x: theta / 2 = atan2(sinh x, 1), the Gudermannian.
    theta = 2.0 * np.arctan(np.sinh(x))
    theta_dot = 2.0 * w / np.cosh(x)
    return PendulumMotion(t=times, theta=theta, theta_dot=theta_dot, omega=w, eta=0.0, method="separatrix")


def harmonic_motion(amplitude: float, t: ArrayLike, omega: float = 1.0, *, eta: float = 0.0) -> PendulumMotion:
    """Harmonic approximation from rest at theta0 (sin theta ~ theta), optionally damped.

    Without friction theta = theta0 cos(Omega t) (Kneller, Mécanique analytique, example 3). With eta < 2 Omega,
    theta = theta0 exp(-eta t / 2) [cos(w t) + eta / (2 w) sin(w t)], w = sqrt(Omega^2 - eta^2/4).

    Parameters
    ----------
    amplitude : float
        Release angle theta0, in rad, in (-pi, pi) (the approximation is only meaningful
        for small ones; the range is that of `exact_motion`, for comparisons).
    t : (n_t,) array_like
        Increasing times, in time units.
    omega : float
        Omega, in rad per time unit.
    eta : float
        Friction rate, in 1 / time unit, 0 <= eta < 2 Omega (under-damped).

    Returns
    -------
    PendulumMotion
        method ``"harmonic"``.

    Raises
    ------
    TypeError
        amplitude, omega or eta not a real number.
    ValueError
        |amplitude| >= pi; omega not positive; eta negative or >= 2 omega; t not 1-D,
        finite and increasing.

    Examples
    --------
    >>> harmonic_motion(0.1, [0.0, np.pi]).theta.round(12).tolist()  # theta0 cos(Omega t)
    [0.1, -0.1]
    """
    theta0 = _release_angle(amplitude)
    times = _times(t)
    w0 = _omega(omega)
    rate = _eta(eta)
    if not rate < 2.0 * w0:
        raise ValueError(f"eta is {rate!r}; harmonic_motion covers the under-damped case eta < 2 omega = {2 * w0!r}")
    w = np.sqrt(w0 * w0 - 0.25 * rate * rate)
    decay = np.exp(-0.5 * rate * times)
    c, s = np.cos(w * times), np.sin(w * times)
    theta = theta0 * decay * (c + 0.5 * rate / w * s)
    theta_dot = -theta0 * decay * (w0 * w0 / w) * s
    return PendulumMotion(t=times, theta=theta, theta_dot=theta_dot, omega=w0, eta=rate, method="harmonic")


def _eta(eta: float) -> float:
    value = _real_scalar(eta, "eta")
    if value < 0:
        raise ValueError(f"eta is {value!r}; a friction rate must be >= 0")
    return value


def damped_motion(
    amplitude: float, t: ArrayLike, *, omega: float = 1.0, eta: float, velocity: float = 0.0,
    rtol: float = 1e-10, atol: float = 1e-12,
) -> PendulumMotion:
    """Pendulum with linear friction, theta'' + eta theta' + Omega^2 sin(theta) = 0 (example 6).

    Integrated with `scipy.integrate.solve_ivp` (DOP853). Its `energy` decays as
    dE/dt = -2 eta T (Kneller, Mécanique analytique, eq. 63); eta = 0 gives the exact frictionless motion.

    Parameters
    ----------
    amplitude : float
        Starting angle theta(t[0]), in rad: any finite value (with `velocity`, a pendulum
        kicked from its rest position starts at 0).
    t : (n_t,) array_like
        Increasing output times, in time units, from the start.
    omega : float
        Omega, in rad per time unit.
    eta : float
        Friction rate, in 1 / time unit, >= 0.
    velocity : float
        Starting rate theta'(t[0]), in rad per time unit.
    rtol, atol : float
        Tolerances of solve_ivp (atol in rad and rad per time unit).

    Returns
    -------
    PendulumMotion
        method ``"solve_ivp"``.

    Raises
    ------
    TypeError
        A scalar argument that is not a real number.
    ValueError
        amplitude or velocity not finite, t not 1-D and increasing, omega not positive,
        eta negative, rtol or atol not positive.
    RuntimeError
        The integrator fails.

    Examples
    --------
    >>> motion = damped_motion(0.1, np.linspace(0.0, 10.0, 3), eta=0.1)
    >>> bool(np.all(np.diff(motion.energy) < 0))  # dE/dt = -2 eta T
    True
    """
    from scipy.integrate import solve_ivp

    theta0 = _real_scalar(amplitude, "amplitude")
    times = _times(t)
    w = _omega(omega)
    rate = _eta(eta)
    speed = _real_scalar(velocity, "velocity")
    rtol, atol = _tolerances(rtol, atol)

    def rhs(_: float, y: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.array([y[1], -rate * y[1] - w * w * np.sin(y[0])])

    solution = solve_ivp(rhs, (times[0], times[-1]), [theta0, speed], method="DOP853", t_eval=times,
                         rtol=rtol, atol=atol)
    if not solution.success:
        raise RuntimeError(f"solve_ivp failed on the pendulum: {solution.message}")
    return PendulumMotion(t=times, theta=solution.y[0], theta_dot=solution.y[1], omega=w, eta=rate,
                          method="solve_ivp")


# ---------------------------------------------------------------------- comparison
def harmonic_error(
    amplitudes: ArrayLike, *, omega: float = 1.0, n_periods: float = 1.0, n_points: int = 2001,
) -> HarmonicError:
    """Period and trajectory error of the harmonic approximation, per release angle.

    Parameters
    ----------
    amplitudes : (n,) array_like
        Release angles theta0 (at rest), in rad, in (0, pi].
    omega : float
        Omega, in rad per time unit.
    n_periods : float
        The trajectories are compared over [0, n_periods * 2 pi / Omega].
    n_points : int
        Sample times per comparison (the error is the largest gap at these times).

    Returns
    -------
    HarmonicError

    Raises
    ------
    TypeError
        A scalar argument that is not a real number; n_points not an int.
    ValueError
        An amplitude outside (0, pi]; omega or n_periods not positive; n_points < 2.

    Examples
    --------
    >>> error = harmonic_error([0.1, 0.2], n_periods=1)
    >>> np.round(error.period_error / error.amplitudes ** 2, 3).tolist()  # about theta0^2 / 16
    [0.063, 0.063]
    """
    theta0 = np.atleast_1d(_amplitudes(amplitudes, "amplitudes"))
    w = _omega(omega)
    periods = _real_scalar(n_periods, "n_periods")
    if not periods > 0:
        raise ValueError(f"n_periods is {periods!r}; it must be positive")
    n_points = _validate.count(n_points, "n_points", low=2, high=10**7)
    t0 = harmonic_period(w)
    times = np.linspace(0.0, periods * t0, n_points)
    gaps = np.empty(theta0.shape[0])
    for i, amplitude in enumerate(theta0):
        exact = exact_motion(amplitude, times, w).theta
        gaps[i] = np.abs(amplitude * np.cos(w * times) - exact).max()
    exact_t = exact_period(theta0, w)
    return HarmonicError(amplitudes=theta0, exact_period=exact_t, harmonic_period=t0,
                         period_error=exact_t / t0 - 1.0, trajectory_error=gaps, n_periods=periods, omega=w)
