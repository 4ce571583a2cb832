"""Small oscillations in generalised coordinates: linearise a Lagrangian written in sympy.

Lagrange's equations (Vieille 1849, eq. 5) for a kinetic energy T(q, q') and a potential energy
V(q) are linearised about an equilibrium q0:

    M = d2T/dq'dq'  at (q0, q' = 0),      K = d2V/dqdq  at q0,

so that M u'' + K u = 0 for u = q - q0, with a non-diagonal, configuration-dependent M
frozen at q0. `linearize` returns that as a `vibra.generalized.GeneralizedSystem` (built by
`vibra.System.generalized`); its `modes()` then gives the normal modes through the core solver.

Sign convention: V here is the potential energy (the Lagrangian is T - V). Vieille's "V"
(1849) is the force function, i.e. minus the potential energy.

Steady motions (Vieille 1849, problem III, the rotating wheel): when a moving constraint has
been eliminated, T may keep terms of degree 0 and 1 in q'. T0 = T(q, 0) then acts as a
centrifugal potential and K = d2(V - T0)/dqdq; the degree-1 part gives the skew gyroscopic
matrix G = N - N^T, N_ij = d2T/dq'_i dq_j (zero for one coordinate), kept in the system:
M u'' + G u' + K u = 0. `linearize` also takes the Lagrangian L itself, a Rayleigh
dissipation function (C), and sympy.physics.mechanics' LagrangesMethod and KanesMethod; it
lives in `vibra.mechanics.linearization` and is re-exported here.

The module also holds Vieille's problem II, the double pendulum (two masses on a string):
its linearised system, the closed forms (15), (16) and (19), and the full non-linear
equations (13) for `scipy.integrate.solve_ivp`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import Frozen
from vibra.generalized import GeneralizedSystem
from vibra.mechanics.linearization import EQUILIBRIUM_RTOL, linearize
from vibra.units import UnitSystem

_real_scalar = _validate.real_scalar

__all__ = [
    "linearize",
    "double_pendulum",
    "double_pendulum_frequencies_squared",
    "double_pendulum_mode_ratios",
    "double_pendulum_single_mode_offsets",
    "double_pendulum_rhs",
    "integrate_double_pendulum",
    "DoublePendulumMotion",
    "EQUILIBRIUM_RTOL",
]


# ---------------------------------------------------------------------- double pendulum
def _pendulum_parameters(m: float, m_prime: float, a: float, b: float, g: float) -> tuple[float, ...]:
    numbers = []
    for value, name in ((m, "m"), (m_prime, "m_prime"), (a, "a"), (b, "b"), (g, "g")):
        numbers.append(_validate.positive_scalar(value, name))
    return tuple(numbers)


def double_pendulum(
    m: float = 1.0, m_prime: float = 1.0, a: float = 1.0, b: float = 1.0, g: float = 9.81,
    *, units: str | UnitSystem = "SI",
) -> GeneralizedSystem:
    """Seed 000, problem II: a string hung at o carrying m at distance a and m' a further b below.

    theta is the angle of om with the downward vertical, phi that of mm'. Built by
    `linearize` from T and V written in sympy (Vieille 1849, before eq. 13):

        T = 1/2 [(m + m') a^2 theta'^2 + m' b^2 phi'^2 + 2 m' a b cos(phi - theta) theta' phi'],
        V = -(m + m') g a cos(theta) - m' g b cos(phi)   (potential energy),

    linearised about the hanging position theta = phi = 0, which gives
    M = [[(m + m') a^2, m' a b], [m' a b, m' b^2]] and K = diag((m + m') g a, m' g b).

    Parameters
    ----------
    m, m_prime : float
        The upper and lower masses, in kg.
    a, b : float
        The lengths om and mm', in m.
    g : float
        Gravitational acceleration, in m/s^2.
    units : str or UnitSystem
        Unit system of the result.

    Returns
    -------
    GeneralizedSystem
        Coordinates ``("theta", "phi")``, in rad; M in kg m^2, K in J/rad^2.

    Examples
    --------
    >>> system = double_pendulum(g=1.0)
    >>> system.M.tolist(), system.K.tolist()
    ([[2.0, 1.0], [1.0, 1.0]], [[2.0, 0.0], [0.0, 1.0]])
    """
    _pendulum_parameters(m, m_prime, a, b, g)
    theta, phi, theta_dot, phi_dot = sympy.symbols("theta phi theta_dot phi_dot")
    m_s, mp_s, a_s, b_s, g_s = sympy.symbols("m m_prime a b g", positive=True)
    T = sympy.Rational(1, 2) * ((m_s + mp_s) * a_s**2 * theta_dot**2 + mp_s * b_s**2 * phi_dot**2
                                + 2 * mp_s * a_s * b_s * sympy.cos(phi - theta) * theta_dot * phi_dot)
    V = -(m_s + mp_s) * g_s * a_s * sympy.cos(theta) - mp_s * g_s * b_s * sympy.cos(phi)
    return linearize(T, V, [theta, phi], [theta_dot, phi_dot], [0.0, 0.0],
                     {m_s: m, mp_s: m_prime, a_s: a, b_s: b, g_s: g},
                     units=units, name="double pendulum")


def double_pendulum_frequencies_squared(
    m: float = 1.0, m_prime: float = 1.0, a: float = 1.0, b: float = 1.0, g: float = 9.81,
) -> NDArray[np.float64]:
    """(2,) roots r1 < r2 of Vieille 1849, eq. (15), the squared angular frequencies, in (rad/s)^2.

    (15): ``[(m + m') g - m a r] (g - b r) - m' a g r = 0``, i.e.
    m a b r^2 - (m + m') g (a + b) r + (m + m') g^2 = 0, solved without cancellation.

    Examples
    --------
    >>> np.round(double_pendulum_frequencies_squared(g=1.0), 12)  # 2 -+ sqrt(2)
    array([0.58578644, 3.41421356])
    """
    m, m_prime, a, b, g = _pendulum_parameters(m, m_prime, a, b, g)
    total = m + m_prime
    quadratic, linear, constant = m * a * b, -total * g * (a + b), total * g * g
    root = np.sqrt(g * g * total * (total * (a + b) ** 2 - 4.0 * m * a * b))
    half = 0.5 * (-linear + root)
    return np.array([constant / half, half / quadratic])


def double_pendulum_mode_ratios(
    m: float = 1.0, m_prime: float = 1.0, a: float = 1.0, b: float = 1.0, g: float = 9.81,
) -> NDArray[np.float64]:
    """(2,) amplitude ratios mu_k = phi / theta of the two modes, Vieille 1849, eq. (16).

    mu = a r / (g - b r) with r the roots of (15), ascending r: mu_1 > 1 (in phase),
    mu_2 < 0 (opposite phase).

    Examples
    --------
    >>> np.round(double_pendulum_mode_ratios(g=1.0), 12)  # phi / theta = +-sqrt(2)
    array([ 1.41421356, -1.41421356])
    """
    m, m_prime, a, b, g = _pendulum_parameters(m, m_prime, a, b, g)
    r = double_pendulum_frequencies_squared(m, m_prime, a, b, g)
    return a * r / (g - b * r)


def double_pendulum_single_mode_offsets(
    m: float = 1.0, m_prime: float = 1.0, a: float = 1.0, b: float = 1.0, *, phi0: float = 1.0,
) -> NDArray[np.float64]:
    """(2, 2) starting angles (alpha, beta) that, released at rest, excite one mode alone.

    Seed 000 eq. (19): (m + m') a alpha^2 + (m + m')(b - a) alpha beta - m' b beta^2 = 0.
    With beta = `phi0` its two roots alpha give the two modes: row 0 the slow, in-phase
    mode (alpha / beta in (0, 1), Vieille's case), row 1 the fast one (alpha / beta < 0).
    Angles in rad; g does not enter.

    Examples
    --------
    >>> np.round(double_pendulum_single_mode_offsets(phi0=1.0), 12)  # alpha / beta = +-1/sqrt(2)
    array([[ 0.70710678,  1.        ],
           [-0.70710678,  1.        ]])
    """
    m, m_prime, a, b, _ = _pendulum_parameters(m, m_prime, a, b, 1.0)
    beta = _real_scalar(phi0, "phi0")
    total = m + m_prime
    quadratic, linear, constant = total * a, total * (b - a), -m_prime * b
    root = np.sqrt(linear * linear - 4.0 * quadratic * constant)
    # Stable roots: x_pos = 2c / (-B - sqrt) is positive (c < 0), x_neg = (-B - sqrt) / 2A.
    away = -linear - root
    x = np.array([2.0 * constant / away, away / (2.0 * quadratic)])
    return np.column_stack([x * beta, np.full(2, beta)])


def double_pendulum_rhs(
    t: float, y: ArrayLike, m: float = 1.0, m_prime: float = 1.0, a: float = 1.0, b: float = 1.0,
    g: float = 9.81,
) -> NDArray[np.float64]:
    """Time derivative of y = (theta, phi, theta', phi') from the full equations (13), Vieille 1849.

    (13), with its velocity terms collected:
        (m + m') a theta'' + m' b cos(phi - theta) phi'' - m' b sin(phi - theta) phi'^2 + (m + m') g sin(theta) = 0,
        b phi'' + a cos(phi - theta) theta'' + a sin(phi - theta) theta'^2 + g sin(phi) = 0,
    solved for the accelerations. Arguments as in `double_pendulum`; `t` (s) is unused (the
    system is autonomous) and is there for `scipy.integrate.solve_ivp`. No validation: this
    is the inner loop of an integration.

    Examples
    --------
    >>> double_pendulum_rhs(0.0, [0.0, 0.0, 0.0, 0.0]).tolist()  # at rest, hanging: no acceleration
    [0.0, 0.0, 0.0, -0.0]
    """
    theta, phi, theta_dot, phi_dot = np.asarray(y, dtype=float)
    c, s = np.cos(phi - theta), np.sin(phi - theta)
    total = m + m_prime
    a11, a12, a21, a22 = total * a, m_prime * b * c, a * c, b
    f1 = m_prime * b * s * phi_dot**2 - total * g * np.sin(theta)
    f2 = -a * s * theta_dot**2 - g * np.sin(phi)
    det = a11 * a22 - a12 * a21
    return np.array([theta_dot, phi_dot, (f1 * a22 - a12 * f2) / det, (a11 * f2 - a21 * f1) / det])


@dataclass(frozen=True, eq=False)
class DoublePendulumMotion(Frozen):
    """A motion of the double pendulum from the full non-linear equations (13).

    Attributes
    ----------
    t : (n_t,) ndarray
        Times, in s.
    theta, phi : (n_t,) ndarray
        Angles of the upper and lower string with the downward vertical, in rad.
    theta_dot, phi_dot : (n_t,) ndarray
        Their rates, in rad/s.
    energy : (n_t,) ndarray
        T + V (V = 0 at the hanging position), in J: constant up to the integration error.
    parameters : (5,) ndarray
        (m, m', a, b, g) in kg, kg, m, m, m/s^2.
    """

    t: NDArray[np.float64]
    theta: NDArray[np.float64]
    phi: NDArray[np.float64]
    theta_dot: NDArray[np.float64]
    phi_dot: NDArray[np.float64]
    energy: NDArray[np.float64]
    parameters: NDArray[np.float64]


def integrate_double_pendulum(
    theta0: float, phi0: float, t: ArrayLike, *, theta_dot0: float = 0.0, phi_dot0: float = 0.0,
    m: float = 1.0, m_prime: float = 1.0, a: float = 1.0, b: float = 1.0, g: float = 9.81,
    rtol: float = 1e-10, atol: float = 1e-12,
) -> DoublePendulumMotion:
    """Integrate the full equations (13) with `scipy.integrate.solve_ivp` (DOP853).

    Parameters
    ----------
    theta0, phi0 : float
        Starting angles, in rad.
    t : (n_t,) array_like
        Increasing output times, in s, starting at the initial time.
    theta_dot0, phi_dot0 : float
        Starting rates, in rad/s.
    m, m_prime, a, b, g : float
        As in `double_pendulum`.
    rtol, atol : float
        Tolerances handed to solve_ivp (atol in rad and rad/s).

    Returns
    -------
    DoublePendulumMotion

    Raises
    ------
    TypeError
        A starting value, parameter or tolerance that is not a real number.
    ValueError
        Non-finite starting values, t not 1-D increasing, non-positive parameters or
        tolerances.
    RuntimeError
        The integrator fails.

    Examples
    --------
    >>> motion = integrate_double_pendulum(0.1, 0.1, np.linspace(0.0, 5.0, 6))
    >>> bool(np.ptp(motion.energy) < 1e-9 * motion.energy[0])  # energy is conserved
    True
    """
    from scipy.integrate import solve_ivp

    start = np.array([_real_scalar(value, name) for value, name in
                      ((theta0, "theta0"), (phi0, "phi0"), (theta_dot0, "theta_dot0"), (phi_dot0, "phi_dot0"))])
    times = _times(t)
    parameters = _pendulum_parameters(m, m_prime, a, b, g)
    rtol, atol = _validate.integration_tolerances(rtol, atol)
    solution = solve_ivp(double_pendulum_rhs, (times[0], times[-1]), start, method="DOP853",
                         t_eval=times, args=parameters, rtol=rtol, atol=atol)
    if not solution.success:
        raise RuntimeError(f"solve_ivp failed on the double pendulum: {solution.message}")
    theta, phi, theta_dot, phi_dot = solution.y
    m, m_prime, a, b, g = parameters
    kinetic = 0.5 * ((m + m_prime) * a**2 * theta_dot**2 + m_prime * b**2 * phi_dot**2
                     + 2.0 * m_prime * a * b * np.cos(phi - theta) * theta_dot * phi_dot)
    potential = (m + m_prime) * g * a * (1.0 - np.cos(theta)) + m_prime * g * b * (1.0 - np.cos(phi))
    return DoublePendulumMotion(t=times, theta=theta, phi=phi, theta_dot=theta_dot, phi_dot=phi_dot,
                                energy=kinetic + potential, parameters=np.array(parameters))


_times = _validate.increasing_times
