"""`linearize`: small oscillations of a sympy Lagrangian about an equilibrium.

Lagrange's equations (Vieille 1849, eq. 5) d/dt dL/dq' - dL/dq = -dR/dq' for a Lagrangian
L(q, q') (= T - V) and a Rayleigh dissipation function R(q, q') are linearised about an
equilibrium q0 (q' = 0). With, at (q0, 0),

    M = d2L/dq'dq',   N_ij = d2L/dq'_i dq_j,   K = -d2L/dqdq,   C = d2R/dq'dq',

they read M u'' + (G + C) u' + K u = 0 for u = q - q0, with the skew gyroscopic matrix
G = N - N^T (the velocity-linear terms of L: a magnetic field, a rotating frame) and the
symmetric damping matrix C. Written with T and V, K = d2(V - T(q, 0))/dqdq: the terms of
T of degree 0 in q' act as a centrifugal potential (steady motions, Vieille 1849, problem III).
The result is a `vibra.generalized.GeneralizedSystem` (G and C only when non-zero).

sympy.physics.mechanics: a `LagrangesMethod` (and a `KanesMethod` whose generalised speeds
are the coordinates' rates, u = q') is taken directly: its mass matrix and forcing vector
f(q, q') (M q'' = f) give K = -df/dq, D = -df/dq', G = (D - D^T)/2, C = (D + D^T)/2, which is
what `LagrangesMethod.linearize` computes symbolically.

Derivatives are taken by sympy and evaluated at 30 digits, then rounded to float64.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import sympy
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra.generalized import GeneralizedSystem
from vibra.solvers.structured.pencil import check_mass_matrix
from vibra.units import UnitSystem

if TYPE_CHECKING:
    from sympy.physics.mechanics import KanesMethod, LagrangesMethod

__all__ = ["linearize", "EQUILIBRIUM_RTOL"]

#: Default relative tolerance of the equilibrium check of `linearize` (see there).
EQUILIBRIUM_RTOL = 1e-8

# Digits used when sympy evaluates the derivatives numerically: well beyond float64, so the
# numbers handed to numpy are correctly rounded.
_EVALF_DIGITS = 30


def linearize(
    T: sympy.Expr | float | LagrangesMethod | KanesMethod | None = None,
    V: sympy.Expr | float | None = None,
    q: Sequence[sympy.Expr] | None = None,
    qd: Sequence[sympy.Expr] | None = None,
    q0: ArrayLike | Mapping[Any, float] | None = None,
    values: Mapping[Any, float] | None = None,
    *,
    lagrangian: sympy.Expr | float | None = None,
    dissipation: sympy.Expr | float | None = None,
    rtol: float = EQUILIBRIUM_RTOL,
    units: str | UnitSystem = "SI",
    name: str = "linearized",
) -> GeneralizedSystem:
    """Linearise L = T - V (and R) about the equilibrium q0: a `GeneralizedSystem` (M, K, G, C).

    Called as ``linearize(T, V, q, qd, q0, values)``, as
    ``linearize(lagrangian=L, q=..., qd=..., q0=..., values=...)``, or with a
    sympy.physics.mechanics ``LagrangesMethod`` / ``KanesMethod`` in place of T:
    ``linearize(method, q0=..., values=...)`` (its coordinates and rates are used).

    Parameters
    ----------
    T : sympy expression, or LagrangesMethod / KanesMethod
        Kinetic energy in `q`, `qd` (and parameters), in the energy unit of `units`
        (J in SI); or a mechanics method object (then V, q, qd, lagrangian and dissipation
        must be None: forces and dissipation are in its force list).
    V : sympy expression
        Potential energy (not Vieille's force function) in `q` and parameters.
    q : (n,) sequence of sympy.Symbol (or sympy.physics.mechanics dynamicsymbols)
        The generalised coordinates; their names label the degrees of freedom.
    qd : (n,) sequence of sympy.Symbol (or dynamicsymbols(..., 1))
        The generalised velocities, qd[i] = dq[i]/dt.
    q0 : (n,) array_like or mapping of coordinate to float
        The operating point, in the units of the coordinates (rad for angles).
    values : mapping of sympy.Symbol (or its name) to float, optional
        A number for every other symbol (masses, lengths, g, ...).
    lagrangian : sympy expression, optional
        L(q, qd) instead of T and V.
    dissipation : sympy expression, optional
        Rayleigh dissipation function R(q, qd) (a quadratic form in qd), in energy per
        time unit: C = d2R/dqd2 at q0.
    rtol : float
        Relative tolerance of the equilibrium check. q0 is accepted when, for every i,
        |dL/dq_i| <= rtol * (sum_terms |term of dL/dq_i| + sum_j |K_ij| |q0_j|):
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
        Dense M, K (n, n); G when L has velocity-linear terms that couple coordinates; C
        when `dissipation` (or a mechanics force list) gives damping; coordinates named
        ``str(q[i])``.

    Raises
    ------
    TypeError
        T, V, L or R not a sympy expression (strings are refused: they would be evaluated),
        an entry of q or qd that is not a symbol, values or q0 of the wrong kind.
    ValueError
        Neither T and V nor lagrangian, or both; q and qd of different lengths or with
        repeated or shared symbols; q0 of the wrong length; a value that is not finite;
        symbols left without values; V depending on a velocity; an expression not real at
        q0; q0 not an equilibrium (the message gives the residual generalised force); T not
        positive definite at q0, or singular to working precision (with its condition
        number); R not positive semi-definite at q0; a KanesMethod whose speeds are not the
        coordinates' rates; non-conservative position forces (K not symmetric).

    Examples
    --------
    >>> import sympy
    >>> th, thd, m, l, g = sympy.symbols("theta theta_dot m l g")
    >>> system = linearize(m * l**2 * thd**2 / 2, -m * g * l * sympy.cos(th), [th], [thd],
    ...                    [0.0], {m: 2.0, l: 0.5, g: 9.81})
    >>> float(system.mass_matrix()[0, 0]), float(system.hessian().toarray()[0, 0])
    (0.5, 9.81)

    A charged particle in a well, in a magnetic field (L has the velocity-linear q B A . q'):

    >>> x, y, xd, yd = sympy.symbols("x y x_dot y_dot")
    >>> L = (xd**2 + yd**2) / 2 - (x**2 + y**2) / 2 + (x * yd - y * xd) / 2
    >>> linearize(lagrangian=L, q=[x, y], qd=[xd, yd], q0=[0.0, 0.0]).G.tolist()
    [[0.0, -1.0], [1.0, 0.0]]
    """
    if _is_mechanics(T):
        for other, label in ((V, "V"), (q, "q"), (qd, "qd"), (lagrangian, "lagrangian"), (dissipation, "dissipation")):
            if other is not None:
                raise ValueError(f"{label} is given with a {type(T).__name__}; the method object holds the "
                                 "coordinates, the Lagrangian and the forces: give only q0 and values")
        return _from_mechanics(T, q0, values, units=units, name=name)
    if lagrangian is not None:
        if T is not None or V is not None:
            raise ValueError("give either lagrangian=L or T and V, not both")
        L_expr = _expression(lagrangian, "lagrangian")
        V_expr: sympy.Expr | None = None
    else:
        if T is None or V is None:
            raise ValueError("give T and V (kinetic and potential energy), or lagrangian=L")
        T_expr = _expression(T, "T")
        V_expr = _expression(V, "V")
        L_expr = T_expr - V_expr
    R_expr = _expression(dissipation, "dissipation") if dissipation is not None else None
    if q is None or qd is None or q0 is None:
        raise ValueError("q, qd and q0 are needed (the coordinates, their rates and the operating point)")
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

    def plain(expression: sympy.Expr) -> sympy.Expr:
        return expression.subs(swap).subs(dict(zip(coordinates, q_dummy)))

    L_plain = plain(L_expr)
    if V_expr is not None:
        V_plain = plain(V_expr)
        for i, symbol in enumerate(qd_dummy):
            if V_plain.has(symbol):
                raise ValueError(f"V depends on the velocity qd[{i}] ({velocities[i]}); V must be a function of q only")
    R_plain = plain(R_expr) if R_expr is not None else sympy.Integer(0)
    at_point = _evaluation_point(sympy.Tuple(L_plain, R_plain), parameters, q_dummy, qd_dummy, point)

    def matrix(expression: sympy.Expr, first: list[sympy.Dummy], second: list[sympy.Dummy], what: str
               ) -> NDArray[np.float64]:
        out = np.empty((n, n))
        for i in range(n):
            for j in range(n):
                out[i, j] = _number(sympy.diff(expression, first[i], second[j]), at_point, f"{what}[{i}][{j}]")
        return out

    M = matrix(L_plain, qd_dummy, qd_dummy, "d2L/dqd dqd")
    M = 0.5 * (M + M.T)
    try:
        check_mass_matrix(M, n, "d2T/dqd2")
    except ValueError as error:
        raise ValueError(f"T is not positive definite at q0: {error}; every direction of motion needs "
                         "kinetic energy") from None
    mixed = matrix(L_plain, qd_dummy, q_dummy, "d2L/dqd dq") if n > 1 else np.zeros((1, 1))
    gyroscopic = mixed - mixed.T
    # A degree-1 part b(q) . q' that is a gradient (no coupling) cancels here to rounding.
    if np.abs(gyroscopic).max() <= 1e-14 * max(np.abs(mixed).max(), np.finfo(float).tiny):
        gyroscopic[:] = 0.0
    damping = None
    if R_expr is not None:
        damping = matrix(R_plain, qd_dummy, qd_dummy, "d2R/dqd dqd")
        damping = 0.5 * (damping + damping.T)
        smallest = float(np.linalg.eigvalsh(damping)[0])
        if smallest < -1e-12 * float(np.abs(damping).max(initial=0.0)):
            raise ValueError(f"the dissipation R is not positive semi-definite at q0: d2R/dqd2 has smallest "
                             f"eigenvalue {smallest:.4g}; a Rayleigh function never feeds energy in")

    # Effective potential -L(q, 0), its gradient (the equilibrium check) and Hessian.
    effective = -L_plain.subs({s: 0 for s in qd_dummy})
    K = _stiffness_and_check(effective, q_dummy, at_point, point, rtol, coordinates)
    return GeneralizedSystem.from_matrices(
        M, K, G=gyroscopic if gyroscopic.any() else None, C=damping,
        coordinates=[str(s) for s in coordinates], units=units, name=name)


def _evaluation_point(expression: sympy.Basic, parameters: dict[sympy.Symbol, float], q_dummy: list[sympy.Dummy],
                      qd_dummy: list[sympy.Dummy], point: NDArray[np.float64]) -> dict[sympy.Basic, Any]:
    """Numbers (30 digits) for every parameter of `expression`, q = q0 and q' = 0."""
    resolved: dict[sympy.Basic, Any] = {}
    missing = []
    by_name = {str(s): v for s, v in parameters.items()}
    for symbol in expression.free_symbols - set(q_dummy) - set(qd_dummy):
        # A value keyed by a symbol, or by its name (whatever the symbol's assumptions:
        # sympy.Symbol("m") != sympy.Symbol("m", positive=True)).
        value = parameters.get(symbol, by_name.get(str(symbol)))  # type: ignore[call-overload]
        if value is None:
            missing.append(str(symbol))
        else:
            resolved[symbol] = sympy.Float(value, _EVALF_DIGITS)
    if missing:
        raise ValueError(
            f"symbols left without values: {sorted(missing)}; give a number for each in values "
            "(or list it in q / qd if it is a coordinate or velocity)"
        )
    resolved.update({s: sympy.Float(float(v), _EVALF_DIGITS) for s, v in zip(q_dummy, point)})
    resolved.update({s: sympy.Integer(0) for s in qd_dummy})
    return resolved


def _stiffness_and_check(effective: sympy.Expr, q_dummy: list[sympy.Dummy], at_point: Mapping[sympy.Basic, Any],
                         point: NDArray[np.float64], rtol: float, coordinates: Sequence[Any]) -> NDArray[np.float64]:
    """K = d2(effective)/dq2 at q0, after checking that q0 is an equilibrium of it."""
    n = len(q_dummy)
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
    return K


# ---------------------------------------------------------------------- sympy.physics.mechanics
def _is_mechanics(value: Any) -> bool:
    from sympy.physics.mechanics import KanesMethod, LagrangesMethod

    return isinstance(value, (LagrangesMethod, KanesMethod))


def _from_mechanics(method: Any, q0: Any, values: Any, *, units: str | UnitSystem, name: str) -> GeneralizedSystem:
    """M, G, C, K from a LagrangesMethod or KanesMethod: M q'' = f(q, q') linearised."""
    from sympy.physics.mechanics import KanesMethod, dynamicsymbols

    t = dynamicsymbols._t
    coordinates = list(method.q)
    if isinstance(method, KanesMethod):
        try:
            kane_mass, kane_forcing = method.mass_matrix, method.forcing
        except (ValueError, AttributeError):
            raise ValueError("the KanesMethod has no equations yet; call kanes_equations(bodies, loads) first") from None
        speeds = list(method.u)
        rates = method.kindiffdict()
        mapping = {}
        for coordinate, speed in zip(coordinates, speeds):
            rate = sympy.simplify(rates.get(coordinate.diff(t), sympy.nan))
            if rate != speed or len(speeds) != len(coordinates):
                raise ValueError(f"the KanesMethod's speeds are not the coordinates' rates ({coordinate.diff(t)} = "
                                 f"{rate}, not {speed}); only u = q' maps onto M q'' + D q' + K q = 0")
            mapping[speed] = coordinate.diff(t)
        mass = kane_mass.subs(mapping)
        forcing = kane_forcing.subs(mapping)
    else:
        try:
            mass, forcing = method.mass_matrix, method.forcing
        except (ValueError, AttributeError, TypeError):
            raise ValueError("the LagrangesMethod has no equations yet; call form_lagranges_equations() first") from None
    velocities = [c.diff(t) for c in coordinates]
    n = len(coordinates)
    point = _operating_point(q0 if q0 is not None else [0.0] * n, coordinates)
    parameters = _parameter_values(values, coordinates, velocities)
    q_dummy = [sympy.Dummy(f"q{i}") for i in range(n)]
    qd_dummy = [sympy.Dummy(f"qd{i}") for i in range(n)]
    accelerations = [c.diff(t, 2) for c in coordinates]

    def plain(expression: Any) -> Any:
        expression = expression.subs({a: 0 for a in accelerations})
        return expression.subs(dict(zip(velocities, qd_dummy))).subs(dict(zip(coordinates, q_dummy)))

    mass, forcing = plain(sympy.Matrix(mass)), plain(sympy.Matrix(forcing))
    at_point = _evaluation_point(sympy.Tuple(*mass, *forcing), parameters, q_dummy, qd_dummy, point)
    M = np.array([[_number(mass[i, j], at_point, f"mass_matrix[{i}][{j}]") for j in range(n)] for i in range(n)])
    static = np.array([_number(forcing[i], at_point, f"forcing[{i}]") for i in range(n)])
    if np.abs(static).max() > 1e-8 * max(1.0, float(np.abs(M).max())):
        i = int(np.argmax(np.abs(static)))
        raise ValueError(f"q0 is not an equilibrium: the forcing vector at q0 is "
                         f"{np.array2string(static, precision=6)}; |f[{i}]| = {abs(static[i]):.4g}")
    K = -np.array([[_number(sympy.diff(forcing[i], q_dummy[j]), at_point, f"df/dq[{i}][{j}]") for j in range(n)]
                   for i in range(n)])
    D = -np.array([[_number(sympy.diff(forcing[i], qd_dummy[j]), at_point, f"df/dqd[{i}][{j}]") for j in range(n)]
                   for i in range(n)])
    asymmetry = float(np.abs(K - K.T).max())
    if asymmetry > 1e-10 * max(float(np.abs(K).max()), np.finfo(float).tiny):
        raise ValueError(f"the position forces are not conservative at q0: |K - K^T| = {asymmetry:.3g} "
                         "(circulatory forces); M q'' + (G + C) q' + K q = 0 needs a symmetric K")
    G, C = 0.5 * (D - D.T), 0.5 * (D + D.T)
    return GeneralizedSystem.from_matrices(
        0.5 * (M + M.T), 0.5 * (K + K.T), G=G if G.any() else None, C=C if C.any() else None,
        coordinates=[str(c) for c in coordinates], units=units, name=name)


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

