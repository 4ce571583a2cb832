"""Small oscillations in generalised coordinates: linearise a Lagrangian written in sympy.

Lagrange's equations (seed 000, eq. 5) for a kinetic energy T(q, q') and a potential energy
V(q) are linearised about an equilibrium q0:

    M = d2T/dq'dq'  at (q0, q' = 0),      K = d2V/dqdq  at q0,

so that M u'' + K u = 0 for u = q - q0, with a non-diagonal, configuration-dependent M
frozen at q0. `linearize` returns that as a `vibra.generalized.GeneralizedSystem` (built by
`vibra.System.generalized`); its `modes()` then gives the normal modes through the core solver.

Sign convention: V here is the potential energy (the Lagrangian is T - V). Vieille's "V"
in seed 000 is the force function, i.e. minus the potential energy.

Steady motions (seed 000, problem III, the rotating wheel): when a moving constraint has
been eliminated, T may keep terms of degree 0 and 1 in q'. T0 = T(q, 0) then acts as a
centrifugal potential and K = d2(V - T0)/dqdq; the degree-1 part must not couple the
coordinates gyroscopically (its skew matrix d2T/dq'_i dq_j - d2T/dq'_j dq_i must vanish,
always true for one coordinate), since a gyroscopic term has no place in M u'' + K u = 0.

The module also holds seed 000's problem II, the double pendulum (two masses on a string):
its linearised system, the closed forms (15), (16) and (19), and the full non-linear
equations (13) for `scipy.integrate.solve_ivp`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy
from numpy.typing import ArrayLike, NDArray

from vibra import _validate
from vibra._frozen import _freeze_arrays
from vibra.generalized import GeneralizedSystem
from vibra.system import System
from vibra.units import UnitSystem

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

#: Default relative tolerance of the equilibrium check of `linearize` (see there).
EQUILIBRIUM_RTOL = 1e-8

# Digits used when sympy evaluates the derivatives numerically: well beyond float64, so the
# numbers handed to numpy are correctly rounded.
_EVALF_DIGITS = 30


# ---------------------------------------------------------------------- linearize
def linearize(
    T: Any,
    V: Any,
    q: Sequence[Any],
    qd: Sequence[Any],
    q0: ArrayLike | Mapping[Any, float],
    values: Mapping[Any, float] | None = None,
    *,
    rtol: float = EQUILIBRIUM_RTOL,
    units: str | UnitSystem = "SI",
    name: str = "linearized",
) -> GeneralizedSystem:
    """Linearise T(q, q') and V(q) about the equilibrium q0: a `GeneralizedSystem` with M and K.

    M = d2T/dq'dq' and K = d2V/dqdq (seed 000 eq. 5 linearised; seed 003 eq. 134), both
    evaluated at q = q0, q' = 0 with the parameter `values`. If T has terms of degree 0 in
    q' (a steady motion, seed 000 problem III), K = d2(V - T(q, 0))/dqdq.

    Parameters
    ----------
    T : sympy expression
        Kinetic energy in the coordinates `q` and velocities `qd` (and parameters), in the
        energy unit of `units` (J in SI).
    V : sympy expression
        Potential energy (not Vieille's force function) in `q` and parameters, same unit.
    q : (n,) sequence of sympy.Symbol (or sympy.physics.mechanics dynamicsymbols)
        The generalised coordinates; their names label the degrees of freedom.
    qd : (n,) sequence of sympy.Symbol (or dynamicsymbols(..., 1))
        The generalised velocities, qd[i] = dq[i]/dt.
    q0 : (n,) array_like or mapping of coordinate to float
        The operating point, in the units of the coordinates (rad for angles).
    values : mapping of sympy.Symbol (or its name) to float, optional
        A number for every other symbol of T and V (masses, lengths, g, ...).
    rtol : float
        Relative tolerance of the equilibrium check. q0 is accepted when, for every i,
        |dV_eff/dq_i| <= rtol * (sum_terms |term of dV_eff/dq_i| + sum_j |K_ij| |q0_j|):
        the first sum (the sizes of the separate forces that must cancel, e.g. gravity
        against a spring) measures rounding in the forces, the second the generalised
        force that an error of relative size rtol in q0 itself would leave.
    units : str or UnitSystem
        Unit system of the result ("SI": M in kg m^2 for angles, K in J/rad^2).
    name : str
        Name used in reports.

    Returns
    -------
    GeneralizedSystem
        In generalised coordinates (`System.generalized`), dense M (n, n) and K (n, n),
        coordinates named ``str(q[i])``.

    Raises
    ------
    TypeError
        T or V not a sympy expression (strings are refused: they would be evaluated), an
        entry of q or qd that is not a symbol, values or q0 of the wrong kind.
    ValueError
        q and qd of different lengths or with repeated or shared symbols; q0 of the wrong
        length; a value that is not finite; symbols left without values; V depending on
        a velocity; T or V not real at q0; q0 not an equilibrium (the message gives the
        residual generalised force); T not positive definite at q0; gyroscopic terms.

    Examples
    --------
    >>> import sympy
    >>> from vibra.lagrangian import linearize
    >>> th, thd, m, l, g = sympy.symbols("theta theta_dot m l g")
    >>> system = linearize(m * l**2 * thd**2 / 2, -m * g * l * sympy.cos(th), [th], [thd],
    ...                    [0.0], {m: 2.0, l: 0.5, g: 9.81})
    >>> float(system.mass_matrix()[0, 0]), float(system.hessian().toarray()[0, 0])
    (0.5, 9.81)
    """
    T_expr = _expression(T, "T")
    V_expr = _expression(V, "V")
    coordinates = _symbol_list(q, "q")
    velocities = _symbol_list(qd, "qd")
    if len(velocities) != len(coordinates):
        raise ValueError(
            f"q has {len(coordinates)} coordinate(s) but qd has {len(velocities)} velocity "
            "symbol(s); give one velocity per coordinate"
        )
    for i, symbol in enumerate(velocities):
        if symbol in coordinates:
            raise ValueError(f"qd[{i}] ({symbol}) is also a coordinate in q; velocities need their own symbols")
    n = len(coordinates)
    point = _operating_point(q0, coordinates)
    parameters = _parameter_values(values, coordinates, velocities)
    rtol = _real_scalar(rtol, "rtol")
    if not rtol > 0:
        raise ValueError(f"rtol is {rtol!r}; it must be positive")

    # Plain symbols stand in for the coordinates and velocities (dynamicsymbols are
    # functions of t; velocities are replaced first, as they contain the coordinates).
    q_dummy = [sympy.Dummy(f"q{i}") for i in range(n)]
    qd_dummy = [sympy.Dummy(f"qd{i}") for i in range(n)]
    swap = dict(zip(velocities, qd_dummy))
    T_plain = T_expr.subs(swap).subs(dict(zip(coordinates, q_dummy)))
    V_plain = V_expr.subs(swap).subs(dict(zip(coordinates, q_dummy)))
    for i, symbol in enumerate(qd_dummy):
        if V_plain.has(symbol):
            raise ValueError(f"V depends on the velocity qd[{i}] ({velocities[i]}); V must be a function of q only")
    resolved: dict[sympy.Basic, Any] = {}
    missing = []
    by_name = {str(s): v for s, v in parameters.items()}
    for symbol in (T_plain.free_symbols | V_plain.free_symbols) - set(q_dummy) - set(qd_dummy):
        # A value keyed by a symbol, or by its name (whatever the symbol's assumptions:
        # sympy.Symbol("m") != sympy.Symbol("m", positive=True)).
        value = parameters.get(symbol, by_name.get(str(symbol)))
        if value is None:
            missing.append(str(symbol))
        else:
            resolved[symbol] = sympy.Float(value, _EVALF_DIGITS)
    if missing:
        raise ValueError(
            f"symbols left without values: {sorted(missing)}; give a number for each in values "
            "(or list it in q / qd if it is a coordinate or velocity)"
        )

    at_point: dict[sympy.Basic, Any] = dict(resolved)
    at_point.update({s: sympy.Float(float(v), _EVALF_DIGITS) for s, v in zip(q_dummy, point)})
    at_point.update({s: sympy.Integer(0) for s in qd_dummy})

    # Mass matrix, positive definite at q0.
    M = np.empty((n, n))
    for i in range(n):
        for j in range(i, n):
            M[i, j] = M[j, i] = _number(sympy.diff(T_plain, qd_dummy[i], qd_dummy[j]), at_point, f"d2T/dqd[{i}]dqd[{j}]")
    eigenvalues = np.linalg.eigvalsh(M)
    if not eigenvalues[0] > 1e-12 * max(abs(eigenvalues[-1]), np.finfo(float).tiny):
        raise ValueError(
            f"T is not positive definite at q0: the mass matrix d2T/dqd2 has eigenvalues "
            f"{np.array2string(eigenvalues, precision=4)}; every direction of motion needs kinetic energy"
        )

    # Gyroscopic part of the terms of degree 1 in q' (steady motions): must vanish.
    if n > 1:
        mixed = np.empty((n, n))
        for i in range(n):
            for j in range(n):
                mixed[i, j] = _number(sympy.diff(T_plain, qd_dummy[i], q_dummy[j]), at_point, f"d2T/dqd[{i}]dq[{j}]")
        gyroscopic = mixed - mixed.T
        # A degree-1 part b(q) . q' that is a gradient (no coupling) cancels here to rounding.
        if np.abs(gyroscopic).max() > 1e-10 * np.abs(mixed).max():
            i, j = (int(x) for x in np.unravel_index(np.argmax(np.abs(gyroscopic)), gyroscopic.shape))
            raise ValueError(
                f"T has gyroscopic (velocity-coupling) terms at q0: d2T/dqd[{i}]dq[{j}] - "
                f"d2T/dqd[{j}]dq[{i}] = {gyroscopic[i, j]:.4g}; M u'' + K u = 0 cannot hold them"
            )

    # Effective potential, its gradient (the equilibrium check) and Hessian.
    effective = V_plain - T_plain.subs({s: 0 for s in qd_dummy})
    gradient = [sympy.diff(effective, s) for s in q_dummy]
    K = np.empty((n, n))
    for i in range(n):
        for j in range(i, n):
            K[i, j] = K[j, i] = _number(sympy.diff(gradient[i], q_dummy[j]), at_point, f"d2V/dq[{i}]dq[{j}]")
    force = np.empty(n)
    scale = np.empty(n)
    for i in range(n):
        force[i] = -_number(gradient[i], at_point, f"dV/dq[{i}]")
        terms = sympy.Add.make_args(sympy.expand(gradient[i]))
        scale[i] = sum(abs(_number(term, at_point, f"dV/dq[{i}]")) for term in terms)
    scale += np.abs(K) @ np.abs(point)
    excess = np.abs(force) - rtol * scale
    if (excess > 0).any():
        i = int(np.argmax(excess))
        raise ValueError(
            f"q0 is not an equilibrium: the generalised force -dV/dq at q0 is "
            f"{np.array2string(force, precision=6)}; |Q[{i}]| = {abs(force[i]):.4g} for "
            f"{coordinates[i]} exceeds rtol * scale = {rtol:g} * {scale[i]:.4g}"
        )
    return System.generalized(M, K, coordinates=[str(s) for s in coordinates], units=units, name=name)


# ---------------------------------------------------------------------- input checks
_real_scalar = _validate.real_scalar


def _expression(value: Any, name: str) -> sympy.Expr:
    if isinstance(value, str):
        raise TypeError(f"{name} must be a sympy expression, got a str (strings are not evaluated)")
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return sympy.Float(value)
    if not isinstance(value, sympy.Expr):
        raise TypeError(f"{name} must be a sympy expression, got {type(value).__name__}")
    return value


def _symbol_list(value: Any, name: str) -> list[sympy.Expr]:
    if isinstance(value, (str, sympy.Basic)) or not isinstance(value, Sequence):
        raise TypeError(f"{name} must be a list of sympy symbols, got {type(value).__name__}")
    if len(value) == 0:
        raise ValueError(f"{name} is empty; give at least one coordinate")
    out: list[sympy.Expr] = []
    for i, item in enumerate(value):
        is_function = isinstance(item, sympy.core.function.AppliedUndef)
        is_derivative = isinstance(item, sympy.Derivative) and isinstance(item.expr, sympy.core.function.AppliedUndef)
        if not (isinstance(item, sympy.Symbol) or is_function or is_derivative):
            raise TypeError(f"{name}[{i}] must be a sympy Symbol (or dynamicsymbol), got {item!r} of type {type(item).__name__}")
        if item in out:
            raise ValueError(f"{name}[{i}] repeats {name}[{out.index(item)}] ({item}); every symbol must be distinct")
        out.append(item)
    return out


def _operating_point(q0: Any, coordinates: list[sympy.Expr]) -> NDArray[np.float64]:
    n = len(coordinates)
    if isinstance(q0, Mapping):
        point = np.empty(n)
        by_name = {str(k): v for k, v in q0.items()}
        for i, symbol in enumerate(coordinates):
            if symbol in q0:
                raw = q0[symbol]
            elif str(symbol) in by_name:
                raw = by_name[str(symbol)]
            else:
                raise ValueError(f"q0 has no value for coordinate q[{i}] ({symbol})")
            point[i] = _real_scalar(raw, f"q0[{symbol}]")
        unknown = sorted(str(k) for k in q0 if k not in coordinates and str(k) not in {str(c) for c in coordinates})
        if unknown:
            raise ValueError(f"q0 names {unknown}, which are not coordinates in q")
        return point
    point = _validate.real_array(q0, "q0", ndim=1)
    if point.shape[0] != n:
        raise ValueError(f"q0 must have {n} value(s), one per coordinate in q, got {point.shape[0]}")
    return point


def _parameter_values(values: Any, coordinates: list[sympy.Expr], velocities: list[sympy.Expr]
                      ) -> dict[sympy.Symbol, float]:
    if values is None:
        return {}
    if not isinstance(values, Mapping):
        raise TypeError(f"values must be a mapping of symbol to number, got {type(values).__name__}")
    out: dict[sympy.Symbol, float] = {}
    for key, raw in values.items():
        if isinstance(key, str):
            symbol = sympy.Symbol(key)
        elif isinstance(key, sympy.Symbol):
            symbol = key
        else:
            raise TypeError(f"values has key {key!r} of type {type(key).__name__}; keys must be sympy Symbols or names")
        if symbol in coordinates or symbol in velocities:
            raise ValueError(f"values gives a number to {symbol}, a coordinate or velocity; the operating point goes in q0")
        if isinstance(raw, bool) or not isinstance(raw, (int, float, np.integer, np.floating, sympy.Number)):
            raise TypeError(f"values[{symbol}] must be a real number, got {type(raw).__name__}")
        number = float(raw)
        if not np.isfinite(number):
            raise ValueError(f"values[{symbol}] is {number!r}; every value must be finite")
        out[symbol] = number
    return out


def _number(expression: sympy.Expr, at_point: Mapping[sympy.Basic, Any], what: str) -> float:
    value = complex(sympy.N(expression.subs(at_point), _EVALF_DIGITS))
    if not np.isfinite(value.real) or abs(value.imag) > 1e-12 * max(abs(value.real), 1.0):
        raise ValueError(f"{what} is {value} at q0; T and V must be real and finite there")
    return value.real


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
    `linearize` from T and V written in sympy (seed 000, before eq. 13):

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
    """(2,) roots r1 < r2 of seed 000 eq. (15), the squared angular frequencies, in (rad/s)^2.

    (15): [(m + m') g - m a r](g - b r) - m' a g r = 0, i.e.
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
    """(2,) amplitude ratios mu_k = phi / theta of the two modes, seed 000 eq. (16).

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
    mode (alpha / beta in (0, 1), the seed's case), row 1 the fast one (alpha / beta < 0).
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
    """Time derivative of y = (theta, phi, theta', phi') from the full equations (13), seed 000.

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
class DoublePendulumMotion:
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

    def __post_init__(self) -> None:
        _freeze_arrays(self)


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
