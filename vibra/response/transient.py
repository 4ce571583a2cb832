"""Transient motion of a multi-dof system under a harmonic force.

With proportional damping (friction, Rayleigh, modal ratios) and no gyroscopic term, by modal
superposition: each normal coordinate moves as one `Oscillator` (eq. 129, continuous across
critical damping); rigid-body modes move as damped free masses. With a non-proportional C or
a skew G, by exact exponential integration of the first-order form
(`vibra.response.state_space`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra._results import Result, stored
from vibra.modes import Modes, normal_modes
from vibra.response.damping import is_modal, modal_damping, modal_projection
from vibra.response.matrices import check_skew, check_structure, mass_times, velocity_matrix
from vibra.response.oscillator import oscillator_state, receptance_denominator
from vibra.response.state_space import state_space_motion

#: How `transient_response` computed the motion (`Transient.method`).
TRANSIENT_METHODS = ("modal", "state space")


@dataclass(frozen=True, eq=False, repr=False)
class Transient(Result):
    """Motion of a multi-dof system under a harmonic force (a `vibra._results.Result` over its
    times; `path` is the method).

    Attributes
    ----------
    t : (n_t,) ndarray
        Times, in time units.
    displacement : (n_t, n_dof) ndarray
        u(t), in length.
    velocity : (n_t, n_dof) ndarray
        u'(t), in length per time unit.
    n_modes : int
        Number of normal modes superposed (modal method); n_dof for the state-space method,
        which keeps every degree of freedom.
    method : str
        ``"modal"`` (superposition of normal modes: no G, C diagonal in the modal basis) or
        ``"state space"`` (exact exponential of the first-order form: a non-proportional C or
        a gyroscopic G).
    """

    STORED = {"t": stored(("n_t",)), "displacement": stored(("n_t", "n_dof")),  # how save / load check them
              "velocity": stored(("n_t", "n_dof"))}
    AXIS, NOUNS, PATH_FIELD = "n_t", ("time", "times"), "method"

    t: NDArray[np.float64]
    displacement: NDArray[np.float64]
    velocity: NDArray[np.float64]
    n_modes: int
    method: str = "modal"

    def _repr_parts(self) -> tuple[str, ...]:
        end = f" to t = {float(self.t[-1]):.6g}" if self.t.size else ""
        return f"{self._size()} of {self.displacement.shape[1]} dofs{end}", f"{self.n_modes} modes"


def transient_response(
    K: ArrayLike | sp.spmatrix,
    M: ArrayLike,
    C: ArrayLike | sp.spmatrix | None,
    t: ArrayLike,
    force: ArrayLike,
    *,
    G: ArrayLike | sp.spmatrix | None = None,
    omega: float = 0.0,
    u0: ArrayLike | None = None,
    v0: ArrayLike | None = None,
    n_modes: int | None = None,
    damping_ratios: ArrayLike | None = None,
    modes: Modes | None = None,
) -> Transient:
    """Motion of M u'' + (C + G) u' + K u = Re{f exp(i w t)} from u0, v0 at t = 0.

    Two methods, chosen from the matrices (`Transient.method` says which ran):

    ``"modal"``, when there is no G and C is diagonal in the modal basis (friction,
    Rayleigh, `damping_ratios`, or None): each normal coordinate q_k = phi_k^T M u obeys q'' + c_k q' + omega_k^2 q = phi_k^T f
    Re{exp(i w t)} and moves as one `Oscillator` (eq. 129, continuous across critical
    damping); u = sum_k phi_k q_k (eq. 150). Rigid-body modes (omega_k = 0) move as damped
    free masses. With n_modes < n_dof the result is the motion of the kept modes (the
    initial conditions and the force projected on them). A constant force (omega = 0) on a
    free structure makes its rigid-body modes drift: q = q0 + v0 t + f_k t^2 / 2 without
    damping, terminal velocity f_k / c_k with it (f_k = phi_k^T f).

    ``"state space"``, for a non-proportional C (detected on the modes) or a nonzero G:
    z = (u, u') obeys z' = A z + b cos(w t), integrated exactly as the matrix exponential of
    A augmented with the force's own (cos, sin) oscillator (`vibra.response.state_space`):
    every dof is kept, resonances grow as t sin(w t) rather than being refused, an unstable
    system grows, and critical damping is passed without loss of digits. Its cost is one
    exponential of a (2 n_dof + 2)-square matrix per distinct time step (dense up to
    `vibra.response.state_space.DENSE_STATE_MAX` states; sparse, expm_multiply, above it
    when M is diagonal).

    Parameters
    ----------
    K, M, C :
        As in `frequency_response` (C symmetric positive semi-definite, or None).
    t : (n_t,) array_like
        Times >= 0, in time units.
    force : (n_dof,) array_like
        Force amplitudes f, in force units; omega = 0 gives a constant force switched on at
        t = 0 (a step), F0 = 0 the free damped motion.
    G : (n_dof, n_dof) array_like or scipy.sparse matrix, optional
        Skew-symmetric gyroscopic matrix, in mass per time unit (as in
        `frequency_response`); a zero G counts as none.
    omega : float
        Driving angular frequency >= 0, in rad per time unit.
    u0, v0 : (n_dof,) array_like, optional
        Initial displacement (length) and velocity (length per time unit); zero by default.
    n_modes : int, optional
        Modal method: how many of the lowest modes to superpose (all by default).
    damping_ratios : float or (n_modes,) array_like, optional
        Modal method: modal damping ratios instead of C.
    modes : Modes, optional
        Normal modes of (K, M) already computed (they also decide whether C is proportional).

    Returns
    -------
    Transient

    Raises
    ------
    ValueError
        As `frequency_response`; t negative; u0, v0 of the wrong length; a flexible mode
        with no damping driven exactly at its frequency, whose amplitude grows without bound
        (modal method); n_modes, damping_ratios or modes with G, n_modes below n_dof with a
        non-proportional C (the state-space method keeps every dof).

    Examples
    --------
    >>> import numpy as np
    >>> K = np.array([[1.0, -1.0], [-1.0, 1.0]])       # two unit masses, one unit spring
    >>> t = [0.0, np.pi / np.sqrt(2.0)]                # half a period of the stretch, omega = sqrt(2)
    >>> motion = transient_response(K, [1.0, 1.0], None, t, [0.0, 0.0], u0=[0.5, -0.5])
    >>> np.round(motion.displacement, 12) + 0.0
    array([[ 0.5, -0.5],
           [-0.5,  0.5]])

    A free charge in a magnetic field (K = 0, omega_c = q B / m = 2) launched along x turns on
    a circle of radius v / omega_c = 1/2; half a turn later it is at (0, -1), moving along -x:

    >>> G = np.array([[0.0, -2.0], [2.0, 0.0]])
    >>> motion = transient_response(np.zeros((2, 2)), [1.0, 1.0], None, [np.pi / 2], [0.0, 0.0],
    ...                             G=G, v0=[1.0, 0.0])
    >>> np.round(motion.displacement, 12) + 0.0, np.round(motion.velocity, 12) + 0.0
    (array([[ 0., -1.]]), array([[-1.,  0.]]))
    >>> motion.method
    'state space'
    """
    stiffness, mass, damping, loads = check_structure(K, M, C, force)
    n_dof = stiffness.shape[0]
    times = _validate.real_array(t, "t", ndim=1)
    _validate.nonnegative(times, "t", "time")
    w = _validate.real_scalar(omega, "omega")
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
    gyroscopic = check_skew(G, n_dof)
    if gyroscopic is not None:
        given: dict[str, Any] = {"n_modes": n_modes, "damping_ratios": damping_ratios, "modes": modes}
        for name in given:
            if given[name] is not None:
                raise ValueError(f"{name} is given with G: a gyroscopic system moves in state space with all "
                                 f"{n_dof} dofs, and {name} applies to the modal method (give damping as C)")
        return _state_space(stiffness, mass, velocity_matrix(damping, gyroscopic), times, loads, w, starts)
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
    projected = None
    if damping is not None:
        projected = modal_projection(shapes, damping)
        if not is_modal(projected):
            if wanted < n_dof:
                raise ValueError(f"n_modes is {wanted}: C is not diagonal in the modal basis (non-proportional "
                                 f"damping), so the motion is computed in state space with all {n_dof} dofs; "
                                 "leave n_modes out")
            return _state_space(stiffness, mass, damping, times, loads, w, starts)
    modal_c = modal_damping(shapes, omega_k, damping, damping_ratios,
                             "transient_response superposes real normal modes and needs friction, "
                             "Rayleigh or modal damping", projected=projected)
    loads_q = shapes.T @ loads
    q0 = shapes.T @ mass_times(mass, starts[0])
    qd0 = shapes.T @ mass_times(mass, starts[1])
    denominators = receptance_denominator(omega_k, modal_c, w)
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
    q = oscillator_state(column, omega_k, modal_c, q0, qd0, amplitude, w, derivative=False)
    qd = oscillator_state(column, omega_k, modal_c, q0, qd0, amplitude, w, derivative=True)
    if drift.any():
        q[:, drift], qd[:, drift] = _pushed_free_mass(column, modal_c[drift], q0[drift], qd0[drift],
                                                      loads_q[drift])
    return Transient(t=times, displacement=q @ shapes.T, velocity=qd @ shapes.T, n_modes=wanted)


def _state_space(stiffness: Any, mass: NDArray[np.float64], velocity: Any, times: NDArray[np.float64],
                 loads: NDArray[np.float64], w: float, starts: list[NDArray[np.float64]]) -> Transient:
    """The state-space method of `transient_response` (velocity matrix C + G, or C)."""
    displacement, speed, _ = state_space_motion(stiffness, mass, velocity, times, loads, w, starts[0], starts[1])
    return Transient(t=times, displacement=displacement, velocity=speed, n_modes=stiffness.shape[0],
                     method="state space")


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

