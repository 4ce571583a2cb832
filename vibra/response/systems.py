"""The response of a `vibra.System` as it is: K, M and, for generalised coordinates, C and G.

`frequency_response` and `transient_response` take matrices. A system built by
`System.generalized(M, K, C=..., G=...)`, `lagrangian.linearize` or `vibra.mechanics.gyroscopic` carries
its damping C and gyroscopic G; `system_matrices` reads all four over the free degrees of
freedom, and `system_frequency_response` / `system_transient_response` pass them on
unchanged (G included), with the system's units. Extra damping (Rayleigh damping of a chain,
say) is added to the system's own C.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import Frozen, owned_arrays
from vibra.generalized import GeneralizedSystem
from vibra.response.frf import FrequencyResponse, frequency_response
from vibra.response.matrices import velocity_matrix
from vibra.response.transient import Transient, transient_response
from vibra.system import System, Vibrating
from vibra.units import UnitSystem


@dataclass(frozen=True, eq=False)
class SystemMatrices(Frozen):
    """K, M, C and G of a system over its free degrees of freedom, in its units.

    Attributes
    ----------
    K : (n_dof, n_dof) scipy.sparse.csr_matrix
        Stiffness (`System.hessian`), in energy / length^2.
    M : (n_dof,) or (n_dof, n_dof) ndarray
        Masses or the mass matrix (`System.mass_matrix`).
    C : (n_dof, n_dof) ndarray or None
        Symmetric damping of a generalised system (`damping_matrix`), in mass per time unit;
        None for none.
    G : (n_dof, n_dof) ndarray or None
        Skew gyroscopic matrix of a generalised system (`gyroscopic_matrix`), in mass per time
        unit; None for none.
    units : UnitSystem
        The system's unit system.
    """

    K: sp.csr_matrix
    M: NDArray[np.float64]
    C: NDArray[np.float64] | None
    G: NDArray[np.float64] | None
    units: UnitSystem


def system_matrices(system: System | GeneralizedSystem) -> SystemMatrices:
    """K, M, C, G of `system` over its free degrees of freedom (C, G None for a site system).

    Raises
    ------
    TypeError
        `system` is not a `vibra.System` (a `GeneralizedSystem` counts as one).

    Examples
    --------
    >>> import vibra
    >>> parts = system_matrices(vibra.System.generalized(np.eye(2), np.eye(2), G=[[0.0, -1.0], [1.0, 0.0]]))
    >>> parts.G.tolist(), parts.C is None
    ([[0.0, -1.0], [1.0, 0.0]], True)
    """
    if not isinstance(system, Vibrating):
        raise TypeError(f"system must be a vibra.System, got {type(system).__name__}")
    C = G = None
    if isinstance(system, GeneralizedSystem):
        C, G = system.damping_matrix(), system.gyroscopic_matrix()
    with owned_arrays():  # fresh copies from the system's accessors: frozen without another copy
        return SystemMatrices(K=system.hessian(), M=system.mass_matrix(), C=C, G=G, units=system.units)


def _damping(parts: SystemMatrices, C: Any) -> Any:
    """The system's C plus the extra damping C (either may be None); the sum is checked later."""
    if C is None:
        return parts.C
    extra = _validate.square_matrix(C, "C")
    n_dof = parts.K.shape[0]
    if extra.shape[0] != n_dof:
        raise ValueError(f"C must be ({n_dof}, {n_dof}) to match the system's {n_dof} free dofs, "
                         f"got shape {extra.shape}")
    return extra if parts.C is None else velocity_matrix(parts.C, extra)


def system_frequency_response(system: System | GeneralizedSystem, omegas: ArrayLike, force: ArrayLike, *,
                              C: ArrayLike | sp.spmatrix | None = None, **options: Any) -> FrequencyResponse:
    """`frequency_response` of a system with its own C and G: x(w) = (K - w^2 M + i w (C + G))^-1 f.

    Parameters
    ----------
    system : vibra.System
        Any system; a generalised one brings its C and G (`system_matrices`).
    omegas : (n_freq,) array_like
        Driving angular frequencies >= 0, in rad per time unit of the system.
    force : (n_dof,) array_like
        Force amplitudes on the free degrees of freedom, in force units (complex: a phase).
    C : (n_dof, n_dof) array_like or scipy.sparse matrix, optional
        Damping added to the system's own (e.g. `rayleigh_damping` of its K and M), in mass
        per time unit; the sum must be symmetric positive semi-definite.
    **options
        Keywords of `frequency_response` (method, n_modes, damping_ratios,
        residual_correction, modes, max_memory, max_seconds); not G or units, which come
        from the system.

    Returns
    -------
    FrequencyResponse
        In the system's units; `gyroscopic` is True when the system has a nonzero G.

    Raises
    ------
    TypeError
        `system` not a System; G or units among the options.
    ValueError
        C not matching the system; as `frequency_response`.

    Examples
    --------
    >>> import vibra
    >>> charged = vibra.System.generalized(np.eye(2), np.eye(2), G=[[0.0, -1.0], [1.0, 0.0]])
    >>> result = system_frequency_response(charged, [0.5], [1.0, 0.0])
    >>> np.round(result.response, 12), result.gyroscopic
    (array([[2.4+0.j , 0. -1.6j]]), True)
    """
    parts = system_matrices(system)
    _no_system_keywords(options, ("G", "units"))
    return frequency_response(parts.K, parts.M, _damping(parts, C), omegas, force, G=parts.G, units=parts.units,
                              **options)


def system_transient_response(system: System | GeneralizedSystem, t: ArrayLike, force: ArrayLike, *,
                              C: ArrayLike | sp.spmatrix | None = None, **options: Any) -> Transient:
    """`transient_response` of a system with its own C and G (state space when they need it).

    Parameters
    ----------
    system : vibra.System
        Any system; a generalised one brings its C and G (`system_matrices`).
    t : (n_t,) array_like
        Times >= 0, in time units of the system.
    force : (n_dof,) array_like
        Force amplitudes on the free degrees of freedom, in force units.
    C : (n_dof, n_dof) array_like or scipy.sparse matrix, optional
        Damping added to the system's own, in mass per time unit (the sum symmetric positive
        semi-definite).
    **options
        Keywords of `transient_response` (omega, u0, v0, n_modes, damping_ratios, modes);
        not G, which comes from the system.

    Raises
    ------
    TypeError
        `system` not a System; G among the options.
    ValueError
        C not matching the system; as `transient_response`.

    Examples
    --------
    >>> import vibra
    >>> damped = vibra.System.generalized([1.0, 1.0], np.diag([1.0, 4.0]), C=[[0.2, 0.1], [0.1, 0.1]])
    >>> system_transient_response(damped, [0.0, 1.0], [0.0, 0.0], u0=[1.0, 0.0]).method
    'state space'
    """
    parts = system_matrices(system)
    _no_system_keywords(options, ("G",))
    return transient_response(parts.K, parts.M, _damping(parts, C), t, force, G=parts.G, **options)


def _no_system_keywords(options: dict[str, Any], names: tuple[str, ...]) -> None:
    for name in names:
        if name in options:
            raise TypeError(f"{name} is taken from the system; build the system with it "
                            "(System.generalized(M, K, G=..., C=...)) instead of passing it here")
