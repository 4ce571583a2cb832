"""`normal_modes(K, M)` and its immutable result, `Modes` (Kneller, Mécanique analytique, eqs. 137-151).

The eigenproblem K u = omega^2 M u is solved in mass-weighted form,
K~ = M^-1/2 K M^-1/2 = D Omega^2 D^T (eqs. 138-141), by the solver path in `vibra.solvers`
that fits the structure of K and what is asked. The result carries the frequencies, the
mass-weighted vectors d_k, the physical shapes u_k = M^-1/2 d_k (eq. 151), and the accuracy
figures of the run.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, ClassVar

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from vibra import solvers
from vibra._core import validate as _validate
from vibra.solvers.standard import gpu
from vibra._core.frozen import freeze_arrays, owned_arrays
from vibra._results import ModesResult, Stored, stored
from vibra.solvers.accuracy import uses_springs
from vibra.solvers.common import omega_and_error
from vibra.units import DIMENSIONLESS, UnitSystem, unit_system
from vibra._core.text import counted

if TYPE_CHECKING:
    from vibra.solvers.structured.quadratic import QuadraticModes

__all__ = ["Modes", "normal_modes", "pencil_modes", "SOLVERS"]

#: Solver paths accepted by `normal_modes(solver=...)`: `vibra.solvers.SOLVER_NAMES`.
SOLVERS = solvers.SOLVER_NAMES


@dataclass(frozen=True, eq=False, repr=False)
class Modes(ModesResult):
    """Normal modes of one system, in that system's units.

    Attributes
    ----------
    omega : (n_modes,) ndarray
        Angular frequencies, ascending, in rad per time unit of `units` (rad/s for SI).
        An unstable (imaginary) mode is reported as -|omega|, never NaN.
    vectors : (n_dof, n_modes) ndarray or None
        Mass-weighted orthonormal d_k (eq. 143); column k belongs to omega[k]. None when
        only frequencies were computed.
    shapes : (n_dof, n_modes) ndarray or None
        Physical-space shapes u_k = M^-1/2 d_k (eq. 151), M-orthonormal, in length per
        sqrt(mass) of `units`.
    mass : (n_dof,) or (n_dof, n_dof) ndarray
        The mass matrix the modes belong to (diagonal masses or dense SPD matrix).
    omega_error : (n_modes,) ndarray
        Estimated absolute error of each omega, in the units of omega.
    residual : float
        Largest relative eigen-residual ||K~ d - omega^2 d|| / ||K~|| (NaN without vectors).
    orthogonality : float
        Largest |D^T D - I| entry (NaN without vectors).
    solver : str
        The solver path that ran (see `vibra.solvers`); `path` is the same, under the name
        every result type shares.
    units : UnitSystem
        Units of omega and of the shapes.
    refined : (n_modes,) bool ndarray or None
        True where the mode's frequency comes from the accurate machinery (Rayleigh-Ritz in
        spring space, a relative-accuracy SVD) because the fast solve's own bound could not
        vouch for it (on ``accurate-checked``: omega^2 below ~n eps ||K~|| / 1e-10; after
        ``accurate-jacobi``, or on the paths that never keep a fast value, every mode); False
        where the fast value was kept. None on the standard paths (no such notion).
    refinement : str or None
        One line saying which modes were refined and why, e.g. ``"6 of 1500 modes below that
        bound's reach refined by spring-space Rayleigh-Ritz (6 zero within rounding); 1494
        kept from the dense solve, ..."``; None where `refined` is None.

    The result protocol every result type shares (`vibra._results.Result`, here
    `ModesResult`): `path` (the same as `solver`), ``len(modes)``, ``modes[6:]`` / ``modes[k]`` /
    ``modes[mask]`` (a smaller `Modes`), a short repr, `to_dict` / `from_dict`, and `save` /
    `load` (``.npz``).
    """

    STORED: ClassVar[dict[str, Stored]] = {  # how save / load / from_dict check each array (vibra._results)
        "omega": stored(("n_modes",), finite=True),
        "vectors": stored(("n_dof", "n_modes"), optional=True, finite=True),
        "shapes": stored(("n_dof", "n_modes"), optional=True, finite=True),
        "mass": stored(("n_dof",), ("n_dof", "n_dof"), finite=True),
        "omega_error": stored(("n_modes",)),
        "refined": stored(("n_modes",), kind="bool", optional=True)}
    PATH_FIELD: ClassVar[str] = "solver"

    omega: NDArray[np.float64]
    vectors: NDArray[np.float64] | None
    shapes: NDArray[np.float64] | None
    mass: NDArray[np.float64]
    omega_error: NDArray[np.float64]
    residual: float
    orthogonality: float
    solver: str
    units: UnitSystem = DIMENSIONLESS
    refined: NDArray[np.bool_] | None = None
    refinement: str | None = None

    def __setstate__(self, state: dict[str, object]) -> None:
        """Unpickling: the fields, then read-only arrays again (pickle skips __post_init__)."""
        self.__dict__.update(state)
        freeze_arrays(self)

    def summary(self) -> str:
        """A few lines: how many modes, the omega range, the path, its accuracy and refinement.

        Examples
        --------
        >>> import numpy as np, vibra
        >>> K = np.array([[1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
        >>> print(vibra.normal_modes(K, [1.0, 1.0, 1.0], vectors=False).summary().splitlines()[0])
        3 modes of 3 dofs by the dense path
        """
        lines = [f"{counted(self.n_modes, 'mode')} of {counted(self.n_dof, 'dof')} by the {self.path} path"]
        if self.n_modes:
            nonzero = np.abs(self.omega) > self.omega_error
            relative = self.omega_error[nonzero] / np.abs(self.omega[nonzero])
            lines.append(f"omega {float(self.omega[0]):.6g} .. {float(self.omega[-1]):.6g} ({self.units.name}); "
                         f"largest omega_error / |omega| {float(relative.max(initial=0.0)):.1e}"
                         f" ({int((~nonzero).sum())} within their bound of zero)")
        if self.vectors is not None:
            lines.append(f"residual {self.residual:.1e}, orthogonality {self.orthogonality:.1e}")
        if self.refined is not None:
            count = f"{int(self.refined.sum())} of {self.n_modes}"
            # the refinement text names its count itself ("6 of 9 modes below ..."): not said twice
            lines.append(f"refined: {self.refinement}" if self.refinement.startswith(count) else
                         f"refined: {count}: {self.refinement}")
        return "\n".join(lines)

    def overlap(self, other: Modes | QuadraticModes | ArrayLike, *, weighted: bool = True) -> NDArray[np.float64]:
        """|cos| between each of these modes (rows) and each of `other`'s (columns), mass-weighted
        by default: `vibra.compare.overlap` (also `match_modes`, `subspace_overlap`, `mac` there).

        Examples
        --------
        >>> import numpy as np, vibra
        >>> modes = vibra.chains.linear_chain(3, units="dimensionless").modes()
        >>> np.allclose(modes.overlap(modes), np.eye(3))
        True
        """
        from vibra.compare import overlap

        return overlap(self, other, weighted=weighted)

    # ------------------------------------------------------------------ sizes
    @property
    def n_modes(self) -> int:
        """Number of modes held."""
        return int(self.omega.shape[0])

    @property
    def n_dof(self) -> int:
        """Number of degrees of freedom of the system."""
        return int(self.mass.shape[0])

    @property
    def omega_squared(self) -> NDArray[np.float64]:
        """(n_modes,) signed eigenvalues omega * |omega| of K~, in (rad per time unit)^2."""
        return self.omega * np.abs(self.omega)

    @property
    def unstable(self) -> NDArray[np.bool_]:
        """(n_modes,) True for imaginary (unstable) modes, omega < 0."""
        return self.omega < 0

    # ------------------------------------------------------------------ units
    def omega_rad_per_s(self) -> NDArray[np.float64]:
        """(n_modes,) signed angular frequencies in rad/s."""
        return self.units.omega_to_rad_per_s(self.omega)

    def frequencies_hz(self) -> NDArray[np.float64]:
        """(n_modes,) signed frequencies omega / 2 pi, in Hz."""
        return self.units.omega_to_hz(self.omega)

    def frequencies_thz(self) -> NDArray[np.float64]:
        """(n_modes,) signed frequencies in THz (phonopy's convention: negative = imaginary)."""
        return self.units.omega_to_thz(self.omega)

    def wavenumbers_cm1(self) -> NDArray[np.float64]:
        """(n_modes,) signed wavenumbers omega / (2 pi c), in cm^-1."""
        return self.units.omega_to_cm1(self.omega)

    def energies_mev(self) -> NDArray[np.float64]:
        """(n_modes,) signed quantum energies hbar omega, in meV."""
        return self.units.omega_to_mev(self.omega)

    @property
    def sign_uncertain(self) -> NDArray[np.bool_]:
        """(n_modes,) True where the error bound spans zero: stable or unstable is not decided.

        Such a mode's true omega may have either sign (omega_error >= |omega|); a negative
        omega there is not evidence of an instability.
        """
        uncertain: NDArray[np.bool_] = np.abs(self.omega) <= self.omega_error
        return uncertain

    # ------------------------------------------------------------------ groups
    def zero_modes(self, rtol: float = 1e-6) -> NDArray[np.bool_]:
        """(n_modes,) True where |omega| <= rtol * max|omega| (rigid-body / translation modes)."""
        rtol = _validate.nonnegative_scalar(rtol, "rtol")
        scale = float(np.abs(self.omega).max()) if self.n_modes else 0.0
        return np.abs(self.omega) <= np.maximum(rtol * scale, np.abs(self.omega_error))

    def degenerate_groups(self, rtol: float = 1e-8) -> list[NDArray[np.intp]]:
        """Indices of modes whose frequencies agree within ``rtol * max|omega|`` (and their error).

        Returns a list of index arrays, one per group of two or more modes, ascending.
        """
        rtol = _validate.nonnegative_scalar(rtol, "rtol")
        if self.n_modes < 2:
            return []
        scale = float(np.abs(self.omega).max())
        tolerance = np.maximum(rtol * scale, self.omega_error[1:] + self.omega_error[:-1])
        same = np.diff(self.omega) <= tolerance
        groups: list[NDArray[np.intp]] = []
        start = 0
        for i in range(1, self.n_modes + 1):
            if i == self.n_modes or not same[i - 1]:
                if i - start > 1:
                    groups.append(np.arange(start, i))
                start = i
        return groups

    # ------------------------------------------------------------------ motion
    def _require_shapes(self, what: str) -> NDArray[np.float64]:
        if self.shapes is None:
            raise ValueError(f"{what} needs mode shapes; these modes were computed with vectors=False")
        return self.shapes

    def _mass_times(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        if self.mass.ndim == 1:
            return self.mass[:, None] * u if u.ndim == 2 else self.mass * u
        return self.mass @ u

    def normal_coordinates(self, u: ArrayLike) -> NDArray[np.float64]:
        """Normal coordinates q = D^T M^1/2 u (eq. 149).

        Parameters
        ----------
        u : (n_dof,) or (n_dof, n) array_like
            Displacements from equilibrium, in the length unit of `units`.

        Returns
        -------
        (n_modes,) or (n_modes, n) ndarray
            q, in length * sqrt(mass).
        """
        shapes = self._require_shapes("normal_coordinates")
        values = _validate.real_array(u, "u", ndim=(1, 2))
        if values.shape[0] != self.n_dof:
            raise ValueError(f"u must have {self.n_dof} rows (one per dof), got shape {values.shape}")
        return shapes.T @ self._mass_times(values)

    def evolve(self, u0: ArrayLike, v0: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        """Free motion u(t) from u(0) = u0, u'(0) = v0 (eqs. 148-150).

        Each normal coordinate evolves as q0 cos(omega t) + q0' sin(omega t) / omega, which is
        q0 + q0' t for a zero mode and q0 cosh(|omega| t) + q0' sinh(|omega| t) / |omega| for
        an imaginary one. With a partial set of modes this is the motion of the projection of
        (u0, v0) onto those modes.

        Parameters
        ----------
        u0, v0 : (n_dof,) array_like
            Initial displacement (length) and velocity (length per time unit).
        t : float or (n_t,) array_like
            Times, in the time unit of `units`.

        Returns
        -------
        (n_dof,) or (n_t, n_dof) ndarray
            Displacements, in the length unit of `units`.

        Examples
        --------
        >>> import numpy as np, vibra
        >>> modes = vibra.normal_modes(np.array([[4.0]]), [1.0])        # omega = 2
        >>> np.round(modes.evolve([1.0], [0.0], [0.0, np.pi / 2]), 12)   # cos(2 t)
        array([[ 1.],
               [-1.]])
        """
        shapes = self._require_shapes("evolve")
        q0 = self.normal_coordinates(_validate.real_array(u0, "u0", ndim=1))
        qd0 = self.normal_coordinates(_validate.real_array(v0, "v0", ndim=1))
        times = _validate.real_array(t, "t", ndim=(0, 1))
        scalar = times.ndim == 0
        times = np.atleast_1d(times)[:, None]
        w = np.abs(self.omega)[None, :]
        wt = w * times
        stable = (self.omega >= 0)[None, :]
        cos_part = np.where(stable, np.cos(wt), np.cosh(wt))
        # sin(w t) / w -> t as w -> 0: np.sinc keeps it continuous with no division by zero.
        sin_part = np.where(stable, times * np.sinc(wt / np.pi), times * _sinhc(wt))
        q = cos_part * q0[None, :] + sin_part * qd0[None, :]
        u = q @ shapes.T
        return u[0] if scalar else u

    def energy(self, u: ArrayLike, v: ArrayLike) -> float:
        """Total energy 1/2 v^T M v + 1/2 sum_k omega_k|omega_k| q_k^2 within the computed modes."""
        q = self.normal_coordinates(_validate.real_array(u, "u", ndim=(1, 2)))
        qd = self.normal_coordinates(_validate.real_array(v, "v", ndim=(1, 2)))
        return float(0.5 * np.sum(qd**2) + 0.5 * np.sum(self.omega_squared * q**2))


def _sinhc(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """sinh(x) / x, continuous at 0."""
    small = np.abs(x) < 1e-4
    safe = np.where(small, 1.0, x)
    return np.where(small, 1.0 + x * x / 6.0, np.sinh(safe) / safe)


def normal_modes(
    K: ArrayLike | sp.spmatrix,
    M: ArrayLike,
    *,
    n_modes: int | None = None,
    vectors: bool = True,
    band: tuple[float, float] | None = None,
    solver: str = "auto",
    symmetrize: bool = False,
    spring_factor: tuple[sp.spmatrix | ArrayLike, ArrayLike] | None = None,
    positions: ArrayLike | None = None,
    units: str | UnitSystem = DIMENSIONLESS,
    max_memory: float | None = None,
    max_seconds: float | None = None,
    progress: bool | Callable[[float, str], None] | None = None,
    device: str = "cpu",
    accuracy: str = "high",
) -> Modes:
    """Normal modes of M u'' + K u = 0 (Kneller, Mécanique analytique, eqs. 137-151).

    Parameters
    ----------
    K : (n_dof, n_dof) array_like or scipy.sparse matrix
        Symmetric force-constant matrix, in energy / length^2 of `units`. An indefinite K
        is allowed: it warns and reports the imaginary modes as negative omega.
    M : (n_dof,) or (n_dof, n_dof) array_like
        Diagonal masses, or a symmetric positive-definite mass matrix (generalised
        coordinates).
    n_modes : int, optional
        How many of the lowest modes to compute (all by default).
    vectors : bool
        False computes frequencies only (cheaper).
    band : (float, float), optional
        Only modes with omega in [band[0], band[1]] (signed, rad per time unit).
    solver : {"auto", "dense", "tridiagonal", "banded", "sparse", "accurate", "pencil", "slepc"}
        The solver path; "auto" chooses from the structure of K and what is asked (a full
        mass matrix M: the pencil paths, `vibra.solvers.structured.pencil`, which keep the
        accuracy of an ill-conditioned M). "accurate" needs `spring_factor`. "slepc" (only
        when named, with `n_modes`) solves on SLEPc over MPI in a separate program
        (`vibra.solvers.distributed`, docs/distributed.md); without mpiexec or slepc4py it
        raises `vibra.solvers.distributed.SlepcUnavailableError` naming what to install.
    symmetrize : bool
        Replace a non-symmetric K by (K + K^T) / 2 instead of raising.
    spring_factor : (B, w), optional
        B (n_terms, n_dof) sparse or dense and w (n_terms,) > 0 with K = B^T diag(w) B:
        enables the accurate path (frequencies as singular values of W^1/2 B M^-1/2).
    positions : (n_dof / 3, 3) array_like, optional
        The sites' coordinates where K is a 3-D network's, three dofs per site (site-major).
        The iterative paths ("iterative", "accurate-iterative": the lowest modes of a network of
        over ~10^4 dofs) use them: the rotations are projected out exactly, and the rigid motions
        of compact groups of sites are the multigrid's first coarse level (~40 % fewer
        iterations on a protein assembly). Other paths ignore them. `System.modes` passes them.
    units : str or UnitSystem
        Unit system of K and M, carried by the result.
    max_memory : float, optional
        Bytes the solve may allocate beyond its input; default `vibra.solvers.budget.MEMORY_LIMIT`
        (None: the memory available now). ``float("inf")`` disables the check.
    max_seconds : float, optional
        Refuse a solve estimated to take longer, in s; default
        `vibra.solvers.budget.TIME_LIMIT_S` (`vibra.solvers.accuracy.TIME_LIMIT_S`, 600 s).
        ``float("inf")`` disables the check.
    progress : bool or callable, optional
        True writes progress lines to stderr, False keeps quiet, a callable receives
        ``(fraction done, message)``; None (default) writes lines only for solves estimated
        to take over `vibra.solvers.budget.PROGRESS_AFTER_S` (5 s).
    accuracy : {"high", "fast", "certified"}
        What the result promises (`vibra.solvers.accuracy`, the one place that says it). "fast": LAPACK/ARPACK-class
        solves, absolute accuracy ~eps ||K~|| (the spring factor is not used). "high" (the
        default): with a spring factor, every requested frequency to ~1e-10 relative where the
        structure allows, with an a-posteriori bound; the steps that would only tighten a bound
        already within 1e-10 are left out, and `Modes.refinement` names a bound left looser.
        "certified": with a spring factor, every bound a certificate (within 1000x the true
        error or 1e-13 relative), at the cost it takes, estimated up front. Without a spring
        factor all three run the standard paths.
    device : {"cpu", "gpu"}
        "gpu" ("cuda" is the same) solves on an NVIDIA GPU through CuPy (``pip install "vibra[gpu]"``):
        all modes densely (then keeps `n_modes` or `band`; solver "dense"), or the lowest `n_modes`
        of a large 3-D network by the iterative path, LOBPCG and its multigrid cycle on the GPU
        (solver "iterative"); "auto" takes the one with the smaller estimate. Planned and guarded
        (`max_memory`, `max_seconds`) like any path, absolute accuracy whatever `accuracy` says (the
        spring factor unused). The GPU memory each needs is checked against the free memory before
        anything is allocated on it. Without CuPy or a GPU it raises
        `vibra.solvers.standard.gpu.GPUUnavailableError`; it never falls back to the CPU.

    Returns
    -------
    Modes

    Raises
    ------
    TypeError
        K, M or spring_factor not real numbers (complex, text); vectors or symmetrize not a
        bool; solver not a str.
    vibra.solvers.standard.gpu.GPUUnavailableError
        device="gpu" without CuPy or without a usable GPU (the message names the extra).
    ValueError
        An unknown device, or device="gpu" with a solver other than "auto", "dense" or "iterative", or a
        GPU solve that would not fit in the GPU's free memory (with the figures);
        K not square, not symmetric (beyond 1e-10 * max|K|) or not finite; M of the wrong
        shape, non-positive, subnormal, non-finite or not positive definite; max|K| / min(M)
        beyond 1e+-300 (omega^2 would overflow or underflow); spring_factor not a factor of
        K; n_modes out of range; an unknown solver or a solver that cannot serve the request.
    vibra.solvers.ResourceLimitError
        (a ValueError) the solve's estimated memory or time exceeds the limits; the message
        gives the figures and the cheaper requests.

    Examples
    --------
    >>> import numpy as np, vibra
    >>> K = np.array([[1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
    >>> modes = vibra.normal_modes(K, [1.0, 1.0, 1.0])
    >>> np.round(modes.omega ** 2, 12)
    array([0., 1., 3.])
    """
    # Kinds, shapes and options first (cheap), then the resource guard, then the checks that
    # read every entry of K (finite, symmetric, scale, spring factor): a K too large to solve
    # is refused before any pass over it, let alone a copy.
    K_matrix = _validate.matrix_argument(K, "K")
    n_dof = K_matrix.shape[0]
    mass = _validate.mass_argument(M, n_dof, "M")
    if n_modes is not None:
        n_modes = _validate.count(n_modes, "n_modes", low=1, high=n_dof)
    vectors = _validate.boolean(vectors, "vectors")
    if band is not None:
        band = _band(band)
        if n_modes is not None:
            raise ValueError("give either n_modes or band, not both")
    if not isinstance(solver, str):
        raise TypeError(f"solver must be a str, got {solver!r} ({type(solver).__name__})")
    _validate.choice(solver, "solver", SOLVERS)
    symmetrize = _validate.boolean(symmetrize, "symmetrize")
    _validate.choice(accuracy, "accuracy", solvers.ACCURACY_LEVELS)
    factor = None
    if spring_factor is not None:
        factor = solvers.check_spring_factor(spring_factor, n_dof)
    sites = None if positions is None else _validate.site_positions(positions, n_dof)
    if solver == "accurate" and (factor is None or not uses_springs(accuracy)):
        raise ValueError("solver='accurate' needs spring_factor=(B, w) with K = B^T diag(w) B"
                         + (' and accuracy "high" or "certified"' if factor is not None else ""))
    unit = unit_system(units)
    max_memory = _validate.optional_limit(max_memory, "max_memory")
    max_seconds = _validate.optional_limit(max_seconds, "max_seconds")
    if not (progress is None or isinstance(progress, (bool, np.bool_)) or callable(progress)):
        raise TypeError(f"progress must be None, a bool or a callable(fraction, message), got {progress!r}")
    device = gpu.check_device(device)
    if device == "gpu" and solver not in ("auto", "dense", "iterative"):
        raise ValueError(f"device='gpu' runs the dense and the iterative paths only; solver is {solver!r} "
                         "(use 'auto', 'dense' or 'iterative')")
    if not uses_springs(accuracy) or device == "gpu":
        factor = None  # "fast" and the GPU: the standard paths, absolute accuracy

    request = solvers.plan(K_matrix, mass, n_modes=n_modes, vectors=vectors, band=band, solver=solver,
                           spring_factor=factor, accuracy=accuracy, device=device, positions=sites,
                           max_memory=max_memory)
    solvers.check_solve_plan(request, n_modes=n_modes, vectors=vectors, band=band, max_memory=max_memory,
                             max_seconds=max_seconds)

    if not sp.issparse(K_matrix):
        _validate.finite(K_matrix, "K")
    K_matrix = _validate.symmetric(K_matrix, "K", symmetrize=symmetrize)
    smallest_mass = float(np.min(mass if mass.ndim == 1 else np.diag(mass)))
    _validate.eigenvalue_scale(solvers.largest_entry(K_matrix), smallest_mass)
    if factor is not None:
        solvers.check_factor_matches(K_matrix, factor)

    result = solvers.solve(K_matrix, mass, n_modes=n_modes, vectors=vectors, band=band,
                           solver=solver, spring_factor=factor, progress=progress, request=request, positions=sites)
    return _modes_from(result, K_matrix, mass, unit)


def _modes_from(result: solvers.SolveResult, K_matrix: Any, mass: NDArray[np.float64], unit: UnitSystem) -> Modes:
    """The `Modes` of one solver path's raw result (warns about imaginary modes)."""
    if (result.eigenvalues < -result.error).any():
        n_negative = int((result.eigenvalues < -result.error).sum())
        warnings.warn(
            f"K is not positive semi-definite: {n_negative} imaginary mode(s), reported as "
            "negative omega", RuntimeWarning, stacklevel=3,
        )
    # the images of [omega^2 - error, omega^2 + error]: covers a sign flip near zero
    omega, omega_error = omega_and_error(result.eigenvalues, result.error)
    shapes = result.shapes
    if result.vectors is not None and shapes is None:
        shapes = solvers.physical_shapes(result.vectors, mass)
    if result.vectors is not None and any(np.shares_memory(result.vectors, x) for x in (K_matrix, mass)):
        result.vectors = result.vectors.copy()  # never alias an input
    with owned_arrays():  # vectors and shapes were created here: freeze them without copying
        return Modes(
            omega=omega, vectors=result.vectors, shapes=shapes, mass=mass.copy(), omega_error=omega_error,
            residual=result.residual, orthogonality=result.orthogonality, solver=result.solver,
            units=unit, refined=result.refined, refinement=result.refinement,
        )


def _band(band: Any) -> tuple[float, float]:
    values = _validate.real_array(band, "band", ndim=1)
    if values.shape != (2,) or not values[0] < values[1]:
        raise ValueError(f"band must be (low, high) with low < high, got {band!r}")
    return float(values[0]), float(values[1])


def pencil_modes(
    K: ArrayLike,
    M: ArrayLike,
    *,
    n_modes: int | None = None,
    vectors: bool = True,
    band: tuple[float, float] | None = None,
    units: str | UnitSystem = DIMENSIONLESS,
) -> Modes:
    """Normal modes of M u'' + K u = 0 for a dense, possibly ill-conditioned M (`vibra.solvers.structured.pencil`).

    Parameters
    ----------
    K : (n, n) array_like
        Symmetric stiffness matrix (an indefinite K gives negative omega for its unstable
        modes, as in `vibra.normal_modes`).
    M : (n, n) array_like
        Symmetric positive-definite mass matrix (checked by `check_mass_matrix`).
    n_modes : int, optional
        How many of the lowest modes to return (all by default).
    vectors : bool
        False returns frequencies only.
    band : (float, float), optional
        Only modes with omega in [band[0], band[1]] (signed).
    units : str or UnitSystem
        Unit system carried by the result.

    Returns
    -------
    Modes
        solver ``"pencil-jacobi"`` (K positive definite) or ``"pencil-cholesky"``;
        shapes M-orthonormal, vectors M^1/2 shapes; omega_error from perturbation theory
        (see the module).

    Raises
    ------
    ValueError
        K not square, finite and symmetric; M refused by `check_mass_matrix`; n_modes out
        of range; both n_modes and band.

    Examples
    --------
    >>> modes = pencil_modes([[9810.00981, 0.0], [0.0, 9.81]], [[1000.001, 1.0], [1.0, 1e-3]])
    >>> modes.solver, [float(f"{w:.6e}") for w in modes.omega ** 2]
    ('pencil-jacobi', [9.8002, 9819820000.0])
    """
    K_matrix = _validate.real_array(K, "K", ndim=2)
    if K_matrix.shape[0] != K_matrix.shape[1]:
        raise ValueError(f"K must be square, got shape {K_matrix.shape}")
    # M's own checks (the messages name its equilibrated condition), then the registry's
    # pencil paths, as `normal_modes(K, M, solver="pencil")` runs them
    from vibra.solvers.structured.pencil import check_mass_matrix

    mass = check_mass_matrix(M, K_matrix.shape[0], "M")
    return normal_modes(K_matrix, mass, n_modes=n_modes, vectors=vectors, band=band, solver="pencil", units=units)
