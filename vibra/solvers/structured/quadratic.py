"""Gyroscopic and damped modes: M q'' + (G + C) q' + K q = 0 in generalised coordinates.

Velocity terms linear in q' that do no work (a magnetic field, a rotating frame, a spinning
wheel) give a skew-symmetric gyroscopic matrix G; a Rayleigh dissipation function
R = 1/2 q'^T C q' gives a symmetric damping matrix C (Kneller, Mécanique analytique, section 2.6). The modes
q = x exp(lambda t) solve the quadratic eigenproblem (lambda^2 M + lambda (G + C) + K) x = 0,
whose 2n eigenvalues come in pairs: one pair per mode. They stay out of `Modes` (no complex
omega there; docs/architecture.md, "Beyond M ü + K u = 0"): they are a `QuadraticModes`.

All three methods first make M the identity: with D = diag(M)^-1/2 and D M D = L L^T
(`vibra.solvers.structured.pencil.equilibrated_cholesky`), q = P y, P = D L^-T, and G, C, K become P^T G P, ...
Then, by what is asked:

- ``"skew-symmetric"`` (G only, K positive definite): with P^T K P = F F^T, w = F^T y and
  v = y', the first-order system is z' = A z with A = [[0, F^T], [-F, -G~]] real
  skew-symmetric. i A is Hermitian, so its eigenvalues come out of LAPACK's Hermitian
  solver real and those of A exactly imaginary: a stable gyroscopic system (K > 0 is
  always stable) gets real frequencies, never a spurious growth rate of 1e-17.
- ``"hamiltonian"`` (G only, K indefinite or singular: gyroscopic stabilisation is
  possible): with the canonical momentum p = y' + G~ y / 2, A = [[-G~/2, I],
  [G~^2/4 - K~, -G~/2]] is Hamiltonian, so its spectrum is symmetric about both axes.
  A computed eigenvalue lambda within its error bound (eps ||A|| times its condition number)
  of the imaginary axis, whose mirror -conj(lambda) is not another computed eigenvalue, is
  simple, and a simple eigenvalue equal to its own mirror lies on the axis: its real part is
  set to 0. The rest are reported as unstable (a growing and a decaying partner).
- ``"companion"`` (C given): the first companion form A = [[0, I], [-K~, -(G~ + C~)]]
  solved by LAPACK geev.

Each mode is a pair of eigenvalues: a complex-conjugate pair (under-damped, or gyroscopic),
or two real ones (over-damped or static divergence), paired by the similarity of their
shapes. Per mode: natural frequency omega_n = sqrt(lambda_1 lambda_2), damping ratio
zeta = -(lambda_1 + lambda_2) / (2 omega_n). Both are symmetric functions of the pair, so
they stay accurate and continuous through critical damping, where the two eigenvalues meet
and each alone is only accurate to sqrt(eps). A pair with lambda_1 lambda_2 < 0 (a saddle)
is reported with a negative omega_n, as `Modes` reports an imaginary frequency.
"""

from __future__ import annotations

import warnings
from typing import ClassVar
from dataclasses import dataclass

import numpy as np
import scipy.linalg as la
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import owned_arrays
from vibra._results import ModesResult, Stored, stored
from vibra.solvers.dispatch import check_solve_plan, plan_problem
from vibra.solvers.problem import quadratic_problem
from vibra.solvers.registry import BY_NAME, PATHS
from vibra.solvers.structured.equilibrated import check_mass_matrix, equilibrated_cholesky
from vibra.solvers.structured.first_order import EPS, FACTOR, Reduced
from vibra.units import DIMENSIONLESS, UnitSystem, unit_system

__all__ = ["QuadraticModes", "quadratic_modes", "check_gyroscopic", "METHODS"]

#: The methods of `quadratic_modes` (chosen from G, C and K; see the module): the registry's
#: quadratic paths.
METHODS = tuple(path.name for path in PATHS if path.family == "quadratic")

# Relative tolerance of the skew-symmetry check of G.
SKEW_RTOL = 1e-10


@dataclass(frozen=True, eq=False, repr=False)
class QuadraticModes(ModesResult):
    """Modes of M q'' + (G + C) q' + K q = 0, one per pair of eigenvalues, by natural frequency.

    Attributes
    ----------
    eigenvalues : (n_modes, 2) complex ndarray
        The pair (lambda_1, lambda_2) of each mode, in rad per time unit: lambda_1 has
        Im >= 0 (for a real pair, the one nearer to 0).
    shapes : (n_dof, n_modes) complex ndarray
        Position part x of the eigenvector of lambda_1 (q = Re{x exp(lambda_1 t)}), scaled
        so that its largest entry is 1, in the coordinates' units.
    natural_frequency : (n_modes,) ndarray
        omega_n = sqrt(lambda_1 lambda_2), ascending, in rad per time unit; negative
        (-sqrt|lambda_1 lambda_2|) for a static divergence (two real roots of opposite sign).
    damping_ratio : (n_modes,) ndarray
        zeta = -(lambda_1 + lambda_2) / (2 |omega_n|): 0 for a stable gyroscopic mode, in
        (0, 1) under-damped, 1 critical, > 1 over-damped, < 0 growing (flutter).
    omega_error : (n_modes,) ndarray
        Estimated absolute error of natural_frequency, in rad per time unit.
    state_vectors : (2 n_dof, 2 n_modes) complex ndarray
        Right eigenvectors [x; lambda x] of the first-order form in the original
        coordinates, columns in the order (mode 0 lambda_1, mode 0 lambda_2, mode 1, ...):
        used by `evolve`.
    method : str
        ``"skew-symmetric"``, ``"hamiltonian"`` or ``"companion"`` (see `vibra.solvers.structured.quadratic`).
    units : UnitSystem
        Units of the frequencies and shapes.
    """

    eigenvalues: NDArray[np.complex128]
    shapes: NDArray[np.complex128]
    natural_frequency: NDArray[np.float64]
    damping_ratio: NDArray[np.float64]
    omega_error: NDArray[np.float64]
    state_vectors: NDArray[np.complex128]
    method: str
    units: UnitSystem = DIMENSIONLESS

    STORED: ClassVar[dict[str, Stored]] = {  # how save / load / from_dict check each array (vibra._results)
        "natural_frequency": stored(("n_modes",)), "eigenvalues": stored(("n_modes", 2), kind="complex"),
        "shapes": stored(("n_dof", "n_modes"), kind="complex"), "damping_ratio": stored(("n_modes",)),
        "omega_error": stored(("n_modes",)),
        "state_vectors": stored((("n_dof", 2), ("n_modes", 2)), kind="complex")}
    PATH_FIELD: ClassVar[str] = "method"

    @property
    def n_modes(self) -> int:
        """Number of modes (the number of degrees of freedom; of a slice, its modes)."""
        return int(self.natural_frequency.shape[0])

    @property
    def omega(self) -> NDArray[np.float64]:
        """(n_modes,) frequency of oscillation |Im lambda_1|, in rad per time unit.

        For a stable gyroscopic mode it is the natural frequency; for a damped one
        omega_n sqrt(1 - zeta^2); 0 for an over-damped or divergent one.
        """
        return np.abs(self.eigenvalues[:, 0].imag)

    @property
    def growth_rate(self) -> NDArray[np.float64]:
        """(n_modes,) largest Re lambda of each pair, in 1 / time unit (> 0: grows)."""
        return np.asarray(self.eigenvalues.real.max(axis=1))

    @property
    def unstable(self) -> NDArray[np.bool_]:
        """(n_modes,) True for a mode that grows: Re lambda above its error bound."""
        return self.growth_rate > self.omega_error

    @property
    def stable(self) -> bool:
        """True when no mode grows (within the error bounds)."""
        return not bool(self.unstable.any())

    def frequencies_hz(self) -> NDArray[np.float64]:
        """(n_modes,) natural frequencies omega_n / 2 pi, in Hz (signed as natural_frequency)."""
        return self.units.omega_to_hz(self.natural_frequency)

    def evolve(self, q0: ArrayLike, v0: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        """Free motion q(t) from q(0) = q0, q'(0) = v0, by superposing the 2 n_dof eigenvectors.

        Exact for distinct eigenvalues; near critical damping (two eigenvalues nearly equal,
        their eigenvectors nearly parallel) it loses about half the digits.

        Parameters
        ----------
        q0, v0 : (n_dof,) array_like
            Initial coordinates and rates, in the coordinates' units (per time unit).
        t : float or (n_t,) array_like
            Times, in the time unit of `units`.

        Returns
        -------
        (n_dof,) or (n_t, n_dof) ndarray
            q(t).

        Raises
        ------
        ValueError
            q0 or v0 not (n_dof,) and finite; t not finite.
        """
        n = self.shapes.shape[0]
        start = []
        for value, name in ((q0, "q0"), (v0, "v0")):
            vector = _validate.real_array(value, name, ndim=1)
            if vector.shape[0] != n:
                raise ValueError(f"{name} must have {n} entries (one per coordinate), got {vector.shape[0]}")
            start.append(vector)
        times = _validate.real_array(t, "t", ndim=(0, 1))
        coefficients = np.linalg.solve(self.state_vectors, np.concatenate(start).astype(complex))
        rates = self.eigenvalues.reshape(-1)
        growth = np.exp(np.multiply.outer(np.atleast_1d(times), rates))
        motion = ((growth * coefficients[None, :]) @ self.state_vectors[:n].T).real
        return motion[0] if times.ndim == 0 else motion


def check_gyroscopic(G: ArrayLike, n_dof: int, name: str = "G") -> NDArray[np.float64]:
    """A skew-symmetric (n_dof, n_dof) gyroscopic matrix, checked within SKEW_RTOL * max|G|.

    Raises
    ------
    ValueError
        Not (n_dof, n_dof), not finite, or not skew-symmetric (the message names the worst
        pair of entries).

    Examples
    --------
    >>> check_gyroscopic([[0.0, 2.0], [-2.0, 0.0]], 2).tolist()
    [[0.0, 2.0], [-2.0, 0.0]]
    """
    matrix = _validate.real_array(G, name, ndim=2)
    if matrix.shape != (n_dof, n_dof):
        raise ValueError(f"{name} must be ({n_dof}, {n_dof}) to match K, got shape {matrix.shape}")
    gap = np.abs(matrix + matrix.T)
    i, j = (int(x) for x in np.unravel_index(np.argmax(gap), gap.shape))
    atol = SKEW_RTOL * float(np.abs(matrix).max(initial=0.0))
    if gap[i, j] > atol:
        raise ValueError(
            f"{name} is not skew-symmetric: |{name}[{i},{j}] + {name}[{j},{i}]| = {gap[i, j]:.3g} > "
            f"atol={atol:.3g} ({SKEW_RTOL:g} * max|{name}|); a gyroscopic matrix satisfies "
            f"{name}^T = -{name} (its symmetric part belongs in C)"
        )
    return np.array(matrix, dtype=float)


def quadratic_modes(
    M: ArrayLike,
    K: ArrayLike,
    *,
    G: ArrayLike | None = None,
    C: ArrayLike | None = None,
    units: str | UnitSystem = DIMENSIONLESS,
    warn: bool = True,
    solver: str = "auto",
    max_memory: float | None = None,
    max_seconds: float | None = None,
) -> QuadraticModes:
    """Modes of M q'' + (G + C) q' + K q = 0 (see the module for the methods).

    The method is a path of the solver registry (`vibra.solvers.registry`, family
    ``"quadratic"``), chosen from what is given (C: ``companion``; G with K positive definite:
    ``skew-symmetric``; else ``hamiltonian``), its cost estimated from n before any work and
    checked against `max_memory` / `max_seconds` as `vibra.normal_modes` does.

    Parameters
    ----------
    M : (n, n) or (n,) array_like
        Symmetric positive-definite mass matrix (or its diagonal).
    K : (n, n) array_like
        Symmetric stiffness matrix (indefinite allowed).
    G : (n, n) array_like, optional
        Skew-symmetric gyroscopic matrix.
    C : (n, n) array_like, optional
        Symmetric damping matrix (R = 1/2 q'^T C q').
    units : str or UnitSystem
        Unit system carried by the result.
    warn : bool
        Warn (RuntimeWarning) when a mode grows, naming it and its growth rate.
    solver : str
        "auto", or a method by name (one of `METHODS`; it must apply: ``skew-symmetric`` needs
        K positive definite and no C, ``hamiltonian`` no C).
    max_memory, max_seconds : float, optional
        Limits checked against the estimate before any work (`vibra.solvers.budget.guard`).

    Returns
    -------
    QuadraticModes

    Raises
    ------
    ValueError
        K not square, finite and symmetric; M refused by `vibra.solvers.structured.pencil.check_mass_matrix`;
        G not skew-symmetric; C not symmetric; a matrix not matching K; a `solver` that is not
        a method, or does not apply.
    vibra.solvers.budget.ResourceLimitError
        The estimate exceeds `max_memory` or `max_seconds`.

    Examples
    --------
    A charged particle in an isotropic well (omega0 = 1) and a field with omega_c = 1:
    omega = sqrt(omega0^2 + omega_c^2 / 4) -+ omega_c / 2.

    >>> modes = quadratic_modes(np.eye(2), np.eye(2), G=[[0.0, -1.0], [1.0, 0.0]])
    >>> modes.method, np.round(modes.natural_frequency, 12), modes.damping_ratio.tolist()
    ('skew-symmetric', array([0.61803399, 1.61803399]), [0.0, 0.0])
    """
    K_matrix = _validate.real_array(K, "K", ndim=2)
    if K_matrix.shape[0] != K_matrix.shape[1]:
        raise ValueError(f"K must be square, got shape {K_matrix.shape}")
    K_matrix = np.array(_validate.symmetric(K_matrix, "K"), dtype=float)
    n = K_matrix.shape[0]
    mass_input = _validate.real_array(M, "M", ndim=(1, 2))
    if mass_input.ndim == 1:
        if mass_input.shape[0] != n:
            raise ValueError(f"M must have {n} masses to match K, got shape {mass_input.shape}")
        _validate.positive(mass_input, "M", "mass")
        mass_input = np.diag(mass_input)
    mass = check_mass_matrix(mass_input, n, "M")
    gyroscopic = check_gyroscopic(G, n) if G is not None else np.zeros((n, n))
    damping = np.zeros((n, n))
    if C is not None:
        damping = _validate.real_array(C, "C", ndim=2)
        if damping.shape != (n, n):
            raise ValueError(f"C must be ({n}, {n}) to match K, got shape {damping.shape}")
        damping = np.array(_validate.symmetric(damping, "C"), dtype=float)
    factor = equilibrated_cholesky(mass)
    assert factor is not None  # check_mass_matrix accepted M
    scale, lower, mass_condition = factor
    P = scale[:, None] * la.solve_triangular(lower.T, np.eye(n), lower=False)   # q = P y, P^T M P = I
    K_t, G_t, C_t = (P.T @ X @ P for X in (K_matrix, gyroscopic, damping))
    K_t, C_t = 0.5 * (K_t + K_t.T), 0.5 * (C_t + C_t.T)
    G_t = 0.5 * (G_t - G_t.T)
    stiffness = equilibrated_cholesky(K_t)
    request = plan_problem(quadratic_problem(n, damped=bool(damping.any()), definite=stiffness is not None), solver)
    check_solve_plan(request, n_modes=None, vectors=True, band=None, max_memory=max_memory, max_seconds=max_seconds)
    problem = request.problem
    values, positions, condition, inverse = BY_NAME[request.path].run(problem, Reduced(K_t, G_t, C_t, stiffness))
    method = request.path  # (the name the registry declares)
    structure = mass_condition + (stiffness[2] if stiffness is not None else 0.0)
    norm_A = float(max(np.abs(values).max(initial=0.0), 1e-300))
    value_error = FACTOR * EPS * (norm_A * condition + 2 * n * structure * np.abs(values))
    if inverse is not None:
        values, positions, value_error = _refine_small(values, positions, value_error, inverse, 2 * n * structure)
    quadratics = None
    if problem.equation == "damped":  # (the companion form's eigenvalues: refined by their quadratics)
        values, quadratics = _rayleigh(values, positions, K_t, G_t + C_t, value_error)
        if not gyroscopic.any():   # y^H K y and y^H C y are real: drop their rounding
            quadratics = quadratics.real.astype(complex)
    pairs = _pairs(values, positions)
    return _result(values, positions, value_error, pairs, P, method, unit_system(units), warn, quadratics)


def _refine_small(values: NDArray[np.complex128], positions: NDArray[np.complex128], error: NDArray[np.float64],
                  inverse: tuple[NDArray[np.complex128], NDArray[np.complex128], NDArray[np.float64]],
                  structure: float) -> tuple[NDArray[np.complex128], NDArray[np.complex128], NDArray[np.float64]]:
    """Take the eigenvalues below the geometric mean of the spectrum from A^-1 (see `first_order.skew_eigen`).

    A^-1's eigenvalues 1/lambda carry an absolute error eps ||A^-1||, i.e. a relative error
    eps |lambda| / min|lambda| on lambda: the small eigenvalues are resolved there, the
    large ones in A itself.
    """
    inverse_values, inverse_positions, inverse_condition = inverse
    size = np.abs(values)
    nonzero = size[size > 0]
    if nonzero.size == 0:
        return values, positions, error
    threshold = np.sqrt(nonzero.max() * nonzero.min())
    finite = np.abs(inverse_values[(inverse_values != 0) & np.isfinite(inverse_values)])
    inverse_norm = float(1.0 / finite.min()) if finite.size else 0.0
    values, positions, error = values.copy(), positions.copy(), error.copy()
    free = list(range(inverse_values.size))
    for j in np.argsort(size):
        if size[j] >= threshold or not free:
            break
        k = min(free, key=lambda i: abs(inverse_values[i] - values[j]) / max(abs(values[j]), 1e-300))
        free.remove(k)
        values[j], positions[:, j] = inverse_values[k], inverse_positions[:, k]
        magnitude = abs(values[j])
        error[j] = FACTOR * EPS * (magnitude**2 * inverse_norm * inverse_condition[k] + structure * magnitude)
    return values, positions, error


def _rayleigh(values: NDArray[np.complex128], positions: NDArray[np.complex128], K_t: NDArray[np.float64],
              D_t: NDArray[np.float64], error: NDArray[np.float64]
              ) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """Quadratic Rayleigh refinement: lambda from (y^H y) l^2 + (y^H D y) l + y^H K y = 0.

    The root nearest the eigensolver's lambda replaces it when within its error bound. Its
    real part comes from y^H C y directly, so a light damping ratio keeps its relative
    accuracy (the eigensolver gives Re lambda only to eps |lambda|); a 1-dof oscillator gets
    the exact roots of its quadratic. Real eigenvalues take real roots only, and conjugate
    pairs stay conjugate. Also returns the coefficients (a, b, c) of each eigenvalue's
    quadratic, from which `_result` takes a real pair's symmetric functions near critical
    damping.
    """
    out = values.copy()
    coefficients = np.zeros((values.size, 3), dtype=complex)
    for j, value in enumerate(values):
        y = positions[:, j]
        a = float(np.vdot(y, y).real)
        b, c = complex(np.vdot(y, D_t @ y)), complex(np.vdot(y, K_t @ y))
        coefficients[j] = a, b, c
        if value.imag < 0:
            continue
        if value.imag == 0:
            if np.abs(np.imag([b, c])).max() > 0 or (b.real**2 < 4 * a * c.real):
                continue
        root = np.sqrt(b * b - 4 * a * c)
        big = -0.5 * (b + root if abs(b + root) >= abs(b - root) else b - root)
        candidates = [big / a] + ([c / big] if big != 0 else [])
        best = min(candidates, key=lambda r: abs(r - value))
        if value.imag == 0:
            best = complex(best.real, 0.0)
        if abs(best - value) <= max(error[j], 0.0):
            out[j] = best
            if value.imag > 0:
                partner = int(np.argmin(np.abs(values - np.conj(value))))
                out[partner] = np.conj(best)
    return out, coefficients


def _pairs(values: NDArray[np.complex128], positions: NDArray[np.complex128]) -> list[tuple[int, int]]:
    """Indices of the two eigenvalues of each mode: conjugate pairs, then real ones by shape."""
    upper = [j for j in range(values.size) if values[j].imag > 0]
    lower = [j for j in range(values.size) if values[j].imag < 0]
    pairs: list[tuple[int, int]] = []
    for j in upper:
        partner = min(lower, key=lambda i: abs(values[i] - np.conj(values[j])))
        lower.remove(partner)
        pairs.append((j, partner))
    real = [j for j in range(values.size) if values[j].imag == 0] + lower   # lower is empty for real A
    unit = positions / np.maximum(np.linalg.norm(positions, axis=0), 1e-300)[None, :]
    while len(real) >= 2:
        similarity = np.abs(unit[:, real].conj().T @ unit[:, real])
        np.fill_diagonal(similarity, -1.0)
        a, b = np.unravel_index(np.argmax(similarity), similarity.shape)
        first, second = real[int(a)], real[int(b)]
        if abs(values[first]) > abs(values[second]):
            first, second = second, first
        pairs.append((first, second))
        real = [j for j in real if j not in (first, second)]
    return pairs


def _result(values: NDArray[np.complex128], positions: NDArray[np.complex128], value_error: NDArray[np.float64],
            pairs: list[tuple[int, int]], P: NDArray[np.float64], method: str, units: UnitSystem, warn: bool,
            quadratics: NDArray[np.complex128] | None = None) -> QuadraticModes:
    n = P.shape[0]
    physical = P @ positions
    product = np.array([(values[a] * values[b]).real for a, b in pairs])
    total = np.array([(values[a] + values[b]).real for a, b in pairs])
    if quadratics is not None:
        # A pair near critical damping: each root alone is good to sqrt(eps) only, but the real
        # quadratic of its (nearly common) vector gives the product c / a and sum -b / a.
        for k, (first, second) in enumerate(pairs):
            a, b, c = quadratics[first]
            if abs(b.imag) + abs(c.imag) > 0:
                continue
            root = np.sqrt(complex(b.real**2 - 4 * a.real * c.real))
            roots = sorted([(-b.real + root) / (2 * a.real), (-b.real - root) / (2 * a.real)], key=abs)
            pair = sorted([values[first], values[second]], key=abs)
            tolerance = error_bound = value_error[first] + value_error[second]
            if all(abs(r - v) <= tolerance for r, v in zip(roots, pair)) and error_bound > 0:
                product[k], total[k] = c.real / a.real, -b.real / a.real
                # The pair's symmetric functions are well conditioned even where each root is not.
                size = max(abs(values[first]), abs(values[second]))
                value_error = value_error.copy()
                value_error[first] = value_error[second] = FACTOR * EPS * size * (2 + 2 * n)
    magnitude = np.sqrt(np.abs(product))
    natural = np.sign(product) * magnitude
    ratio = -total / (2.0 * np.where(magnitude > 0, magnitude, 1.0)) + 0.0   # + 0.0: no -0.0
    # d omega_n = d(l1 l2) / (2 omega_n) <= (|l2| e1 + |l1| e2) / (2 omega_n), capped by sqrt near 0.
    error = np.array([(abs(values[b]) * value_error[a] + abs(values[a]) * value_error[b]) for a, b in pairs])
    error = np.minimum(error / np.maximum(2.0 * magnitude, 1e-300), np.sqrt(error))
    order = np.lexsort((np.abs(ratio), natural))
    ordered = [pairs[k] for k in order]
    columns = [j for pair in ordered for j in pair]
    eigenvalues = values[columns].reshape(n, 2)
    shapes = physical[:, [a for a, _ in ordered]]
    biggest = shapes[np.argmax(np.abs(shapes), axis=0), np.arange(n)]
    shapes = shapes / np.where(biggest == 0, 1.0, biggest)[None, :]
    state = np.vstack([physical[:, columns], physical[:, columns] * values[columns][None, :]])
    with owned_arrays():
        result = QuadraticModes(eigenvalues=eigenvalues, shapes=shapes, natural_frequency=natural[order],
                                damping_ratio=ratio[order], omega_error=error[order], state_vectors=state,
                                method=method, units=units)
    if warn and not result.stable:
        growing = np.flatnonzero(result.unstable)
        rates = ", ".join(f"mode {k}: Re lambda = {result.growth_rate[k]:.4g}" for k in growing)
        warnings.warn(f"the system is unstable: {growing.size} growing mode(s) ({rates})", RuntimeWarning,
                      stacklevel=3)
    return result
