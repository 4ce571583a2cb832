"""Multi-dof frequency response x(w) = (K - w^2 M + i w (C + G))^-1 f: `frequency_response`, `frf`.

The three methods live in `vibra.response.direct` (direct, state space) and
`vibra.response.modal`; this module validates, dispatches and builds the result. A gyroscopic
G (skew) and a non-proportional C go to the direct or state-space method, which take the
velocity matrix C + G as it is; the modal method, whose real normal modes they couple,
refuses them and names those two.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import span
from vibra._results import Result, stored
from vibra.modes import Modes
from vibra.response.direct import direct_response, state_space_response
from vibra.response.matrices import check_skew, check_structure, half_bandwidth, response_cost, velocity_matrix
from vibra.solvers.budget import guard
from vibra.response.modal import modal_response
from vibra.units import DIMENSIONLESS, UnitSystem, unit_system


#: Methods accepted by `frf` and `frequency_response`.
METHODS = ("direct", "modal", "state_space")


@dataclass(frozen=True, eq=False, repr=False)
class FrequencyResponse(Result):
    """Steady-state response x(w) = (K - w^2 M + i w (C + G))^-1 f over many frequencies (a
    `vibra._results.Result` over the frequencies; `path` is the method).

    Attributes
    ----------
    omegas : (n_freq,) ndarray
        Driving angular frequencies, in rad per time unit of `units`.
    response : (n_freq, n_dof) complex ndarray
        Complex displacement amplitudes x(w) (the force is Re{f exp(i w t)}), in length.
    force : (n_dof,) ndarray
        The force amplitudes f, in force units (complex when a phase was given).
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
    gyroscopic : bool
        Whether a gyroscopic matrix G took part (x(w) = (K - w^2 M + i w (C + G))^-1 f).
    """

    STORED = {"omegas": stored(("n_freq",)), "response": stored(("n_freq", "n_dof"), kind="complex"),  # how saved
              "force": stored(("n_dof",), kind="number"), "truncation_error": stored(("n_freq",)),
              "natural_frequencies": stored(("n_modes",), optional=True)}
    AXIS, NOUNS, PATH_FIELD = "n_freq", ("frequency", "frequencies"), "method"

    omegas: NDArray[np.float64]
    response: NDArray[np.complex128]
    force: NDArray[Any]
    method: str
    solver: str
    n_modes: int | None
    residual_correction: bool
    truncation_error: NDArray[np.float64]
    natural_frequencies: NDArray[np.float64] | None
    units: UnitSystem = DIMENSIONLESS
    gyroscopic: bool = False

    def _repr_parts(self) -> tuple[str, ...]:
        modes = "" if self.n_modes is None else f"{self.n_modes} modes"
        return (f"{self._size()} x {self.n_dof} dofs", f"omega {span(self.omegas)}", modes,
                f"solver {self.solver!r}", "gyroscopic" if self.gyroscopic else "")

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


def frequency_response(
    K: ArrayLike | sp.spmatrix,
    M: ArrayLike,
    C: ArrayLike | sp.spmatrix | None,
    omegas: ArrayLike,
    force: ArrayLike,
    *,
    G: ArrayLike | sp.spmatrix | None = None,
    method: Literal["direct", "modal", "state_space"] = "direct",
    n_modes: int | None = None,
    damping_ratios: ArrayLike | None = None,
    residual_correction: bool = False,
    modes: Modes | None = None,
    units: str | UnitSystem = DIMENSIONLESS,
    max_memory: float | None = None,
    max_seconds: float | None = None,
) -> FrequencyResponse:
    """Receptance response x(w) = (K - w^2 M + i w (C + G))^-1 f at many frequencies.

    The steady state of M u'' + (C + G) u' + K u = Re{f exp(i w t)}: C symmetric positive
    semi-definite (proportional or not), G skew-symmetric (gyroscopic: a magnetic field, a
    rotating frame). `vibra.response.system_frequency_response` takes them from a system.

    Parameters
    ----------
    K : (n_dof, n_dof) array_like or scipy.sparse matrix
        Symmetric stiffness, in force per length.
    M : (n_dof,) or (n_dof, n_dof) array_like
        Diagonal masses or an SPD mass matrix, as in `vibra.normal_modes`.
    C : (n_dof, n_dof) array_like or scipy.sparse matrix, or None
        Symmetric positive semi-definite damping matrix, in mass per time unit
        (`friction_damping`, `rayleigh_damping`, or any, non-proportional too); None for no
        damping matrix.
    omegas : (n_freq,) array_like
        Driving angular frequencies >= 0, in rad per time unit.
    force : (n_dof,) array_like
        Force amplitudes f (force Re{f exp(i w t)}), in force units; complex amplitudes
        carry a phase per dof (f_j = |f_j| exp(i phi_j)), which the response keeps.
    G : (n_dof, n_dof) array_like or scipy.sparse matrix, optional
        Skew-symmetric gyroscopic matrix (G^T = -G within `vibra.solvers.structured.quadratic.SKEW_RTOL` * max|G|),
        in mass per time unit; it does no work. Methods ``"direct"`` and ``"state_space"``;
        a zero G counts as none.
    method : {"direct", "modal", "state_space"}
        ``"direct"``: one LU per frequency, tridiagonal or banded when K, M and C are (half
        bandwidth <= `BANDED_MAX_HALF_WIDTH`), sparse LU otherwise (dense LU for small dense
        input); exact to round-off times the conditioning. ``"modal"``: superposition of the
        lowest `n_modes` normal modes; C must be diagonal in the modal basis (friction,
        Rayleigh) or replaced by `damping_ratios`, and no G. ``"state_space"``: complex modes
        of the first-order form (dense, all modes), for non-proportional C and for G.
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
        Unit system of K, M, C, carried by the result and named on its charts. The default,
        dimensionless, suits bare matrices (omega in rad per time unit); give ``"SI"`` for K
        in N/m, M in kg and C in kg/s (omega in rad/s, receptance in m/N).
    max_memory, max_seconds : float, optional
        Limits of the estimated memory (bytes) and time (s), as in `vibra.normal_modes`:
        a larger request raises `vibra.solvers.ResourceLimitError` before any allocation.

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
        K not square/symmetric/finite; M, C or force not matching K; C not positive
        semi-definite (negative damping); G not square, not matching K, not finite or not
        skew-symmetric (the message gives |G[i,j] + G[j,i]|); G with method='modal';
        omegas negative; unknown method; n_modes out of range or given to a
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

    A charge in a 2-D well (w0 = 1) and a field with w_c = 1: the undamped response is
    singular at sqrt(5)/2 -+ 1/2, and the field turns a push along x into motion along y.

    >>> G = np.array([[0.0, -1.0], [1.0, 0.0]])
    >>> x = frequency_response(np.eye(2), [1.0, 1.0], None, [0.5], [1.0, 0.0], G=G).response
    >>> np.round(x, 12)                # ((0.75, -0.5 i), (0.5 i, 0.75))^-1 (1, 0)
    array([[2.4+0.j , 0. -1.6j]])
    """
    _validate.choice(method, "method", METHODS)
    stiffness, mass, damping, loads = check_structure(K, M, C, force, complex_force=True)
    n_dof = stiffness.shape[0]
    frequencies = _validate.real_array(omegas, "omegas", ndim=1)
    _validate.nonnegative(frequencies, "omegas", "angular frequency")
    gyroscopic = check_skew(G, n_dof)
    if gyroscopic is not None and method == "modal":
        raise ValueError("G is given, and method='modal' superposes real normal modes, which a gyroscopic "
                         "matrix couples; use method='direct' or method='state_space' (complex modes)")
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
    max_memory = _validate.optional_limit(max_memory, "max_memory")
    max_seconds = _validate.optional_limit(max_seconds, "max_seconds")
    width = max(half_bandwidth(stiffness), half_bandwidth(mass), half_bandwidth(damping),
                half_bandwidth(gyroscopic))
    stored = int(stiffness.nnz) if sp.issparse(stiffness) else n_dof * n_dof
    cost = response_cost(method, n_dof, frequencies.size, width, stored,
                         parts=2 if np.iscomplexobj(loads) and loads.imag.any() else 1)
    guard(cost, n_dof=n_dof, max_memory=max_memory, max_seconds=max_seconds,
          alternatives=["fewer frequencies in omegas", "method='modal' with n_modes (the lowest modes only)"])

    if np.iscomplexobj(loads) and loads.imag.any():
        # x(f) is linear in f: x(f_r + i f_i) = x(f_r) + i x(f_i), which keeps the phase of f
        parts = [frequency_response(stiffness, mass, damping, frequencies, part, G=gyroscopic, method=method,
                                    n_modes=n_modes, damping_ratios=damping_ratios,
                                    residual_correction=residual_correction, modes=modes, units=unit,
                                    max_memory=float("inf"), max_seconds=float("inf"))
                 for part in (loads.real.copy(), loads.imag.copy())]
        response = parts[0].response + 1j * parts[1].response
        # ||e_r + i e_i||_M <= err_r ||x_r||_M + err_i ||x_i||_M, relative to ||x||_M
        norms = [_mass_norms(mass, part.response) for part in parts]
        total = _mass_norms(mass, response)
        bound = parts[0].truncation_error * norms[0] + parts[1].truncation_error * norms[1]
        with np.errstate(divide="ignore", invalid="ignore"):
            error = np.where(total > 0, bound / total, np.where(bound > 0, np.inf, 0.0))
        return FrequencyResponse(
            omegas=frequencies, response=response, force=loads, method=method, solver=parts[0].solver,
            n_modes=parts[0].n_modes, residual_correction=parts[0].residual_correction,
            truncation_error=error, natural_frequencies=parts[0].natural_frequencies, units=unit,
            gyroscopic=gyroscopic is not None,
        )
    loads = np.asarray(loads.real if np.iscomplexobj(loads) else loads, dtype=float)

    error = np.zeros(frequencies.size)
    natural: NDArray[np.float64] | None = None
    used: int | None = None
    has_g = gyroscopic is not None
    if method == "direct":
        response, solver = direct_response(stiffness, mass, velocity_matrix(damping, gyroscopic), frequencies,
                                           loads, gyroscopic=has_g)
    elif method == "modal":
        response, error, used, natural = modal_response(
            stiffness, mass, damping, frequencies, loads, n_modes, damping_ratios,
            bool(residual_correction), modes,
        )
        solver = "modal"
    else:
        response, natural = state_space_response(stiffness, mass, velocity_matrix(damping, gyroscopic),
                                                 frequencies, loads, gyroscopic=has_g)
        used = n_dof
        solver = "state space"
    return FrequencyResponse(
        omegas=frequencies, response=response, force=loads, method=method, solver=solver,
        n_modes=used, residual_correction=bool(residual_correction) and method == "modal",
        truncation_error=error, natural_frequencies=natural, units=unit, gyroscopic=has_g,
    )


def _mass_norms(mass: NDArray[np.float64], rows: NDArray[np.complex128]) -> NDArray[np.float64]:
    """(n_freq,) M-norms sqrt(x^H M x) of the rows of a response."""
    if mass.ndim == 1:
        return np.sqrt(np.sum(mass * np.abs(rows) ** 2, axis=1))
    return np.sqrt(np.maximum(np.einsum("fi,ij,fj->f", rows.conj(), mass, rows).real, 0.0))


def frf(
    K: ArrayLike | sp.spmatrix,
    M: ArrayLike,
    C: ArrayLike | sp.spmatrix | None,
    omegas: ArrayLike,
    force: ArrayLike,
    *,
    G: ArrayLike | sp.spmatrix | None = None,
    method: Literal["direct", "modal", "state_space"] = "direct",
    n_modes: int | None = None,
) -> NDArray[np.complex128]:
    """(n_freq, n_dof) complex receptance response (K - w^2 M + i w (C + G))^-1 f, in length.

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
        frequency_response(K, M, C, omegas, force, G=G, method=method, n_modes=n_modes).response
    )

