"""`GeneralizedSystem`: small oscillations in generalised coordinates, T = 1/2 q'^T M q'.

Lagrange's equations linearised about an equilibrium (Vieille 1849, eq. 5; Kneller, Mécanique analytique, eqs. 134-137)
give M q'' + K q = 0 with a dense, symmetric positive-definite mass matrix M and a symmetric
stiffness matrix K. Such a system has coordinates (angles, lengths, ...) but no sites:
no positions, no site masses, no spring factorisation, so it is a class of its own rather
than a mode of `vibra.System`. It offers the same protocol (`hessian`, `mass_matrix`,
`modes`, `freeze`, `expand`, `n_dof`, `free_dofs`, `labels`, `units`, `name`): both satisfy
the protocol `vibra.system.Vibrating`, so a function that takes any system checks
``isinstance(s, Vibrating)`` and tells the two apart with `is_generalized`.

Build one with ``vibra.System.generalized(M, K)`` (or `GeneralizedSystem.from_matrices`);
`vibra.mechanics.lagrangian.linearize` and `vibra.mechanics.rigid` return them.

With a skew-symmetric gyroscopic matrix G and/or a symmetric damping matrix C
(``System.generalized(M, K, G=..., C=...)``) the equations are M q'' + (G + C) q' + K q = 0
and `modes` returns a `vibra.solvers.structured.quadratic.QuadraticModes` (natural frequency, damping ratio,
complex shapes) instead of `Modes`. Without them `vibra.normal_modes` solves it, whose registry
takes a full M to the pencil paths (`vibra.solvers.structured.pencil`), which keep the accuracy
of ill-conditioned mass matrices.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import Frozen
from vibra.modes import Modes, normal_modes
from vibra.solvers.accuracy import LEVELS as ACCURACY_LEVELS, Accuracy
from vibra.solvers.structured.pencil import check_mass_matrix
from vibra.solvers.structured.quadratic import QuadraticModes, check_gyroscopic, quadratic_modes
from vibra.units import UnitSystem, unit_system

__all__ = ["GeneralizedSystem", "FreeDofs"]


class FreeDofs(Frozen):
    """Which degrees of freedom move: shared by `vibra.System` and `GeneralizedSystem`.

    A subclass has a field ``frozen`` ((n_total,) ndarray of bool, True for a degree of
    freedom held at rest); K, M and the modes refer to the free ones, in the order of
    `free_dofs`.
    """

    frozen: NDArray[np.bool_]

    @property
    def free_dofs(self) -> NDArray[np.intp]:
        """(n_dof,) flat indices of the degrees of freedom that move."""
        return np.flatnonzero(~self.frozen)

    @property
    def n_dof(self) -> int:
        """Number of free degrees of freedom (the size of K and M)."""
        return int((~self.frozen).sum())

    def expand(self, vectors: ArrayLike) -> NDArray[np.float64]:
        """(n_total, ...) values of every degree of freedom from (n_dof, ...) free ones (0 when frozen).

        Examples
        --------
        >>> import vibra
        >>> system = vibra.System.generalized(np.eye(3), np.eye(3)).freeze(dofs=[1])
        >>> system.expand(np.array([1.0, 2.0])).tolist()
        [1.0, 0.0, 2.0]
        """
        values = np.asarray(vectors)
        full = np.zeros((self.frozen.shape[0],) + values.shape[1:], dtype=values.dtype)
        full[self.free_dofs] = values
        return full


@dataclass(frozen=True, eq=False)
class GeneralizedSystem(FreeDofs):
    """A system in generalised coordinates q: T = 1/2 q'^T M q', V = 1/2 q^T K q.

    Attributes
    ----------
    M : (n_coordinates, n_coordinates) ndarray
        Symmetric positive-definite mass matrix, in the units of the kinetic energy's
        coefficients (kg m^2 for angles in SI).
    K : (n_coordinates, n_coordinates) ndarray
        Symmetric stiffness matrix (J per rad^2 for angles in SI).
    frozen : (n_coordinates,) ndarray of bool
        True for a coordinate held at rest.
    labels : tuple of str
        One name per coordinate (free and frozen), e.g. ``"theta1"``.
    units : UnitSystem
        The unit system of the system and of its results.
    name : str
        A short name used in reports.
    G : (n_coordinates, n_coordinates) ndarray or None
        Skew-symmetric gyroscopic matrix (kg m^2 / s for angles in SI), or None.
    C : (n_coordinates, n_coordinates) ndarray or None
        Symmetric damping matrix of the Rayleigh function R = 1/2 q'^T C q' (kg m^2 / s for
        angles in SI), or None.

    Examples
    --------
    >>> import numpy as np
    >>> import vibra
    >>> pendulums = vibra.System.generalized(np.eye(2), [[2.0, -1.0], [-1.0, 2.0]])
    >>> np.round(pendulums.modes().omega ** 2, 12)
    array([1., 3.])
    >>> pendulums.freeze(dofs=[1]).n_dof
    1
    """

    M: NDArray[np.float64]
    K: NDArray[np.float64]
    frozen: NDArray[np.bool_]
    labels: tuple[str, ...]
    units: UnitSystem
    name: str = "system"
    G: NDArray[np.float64] | None = None
    C: NDArray[np.float64] | None = None

    @classmethod
    def from_matrices(
        cls,
        M: ArrayLike,
        K: ArrayLike,
        *,
        G: ArrayLike | None = None,
        C: ArrayLike | None = None,
        coordinates: Sequence[str] | None = None,
        units: str | UnitSystem = "SI",
        name: str = "system",
    ) -> GeneralizedSystem:
        """The system M q'' + (G + C) q' + K q = 0 (the same as ``vibra.System.generalized``).

        Parameters
        ----------
        M : (n, n) or (n,) array_like
            Symmetric positive-definite mass matrix, or its diagonal (kg m^2 for angles in SI).
            An ill-conditioned M is accepted; it is refused only when singular or indefinite
            to working precision (`vibra.solvers.structured.pencil.check_mass_matrix`).
        K : (n, n) array_like
            Symmetric stiffness matrix (J per rad^2 for angles in SI).
        G : (n, n) array_like, optional
            Skew-symmetric gyroscopic matrix (kg m^2 / s for angles in SI).
        C : (n, n) array_like, optional
            Symmetric damping matrix (kg m^2 / s for angles in SI).
        coordinates : sequence of str, optional
            Names of the coordinates (default ``q0, q1, ...``).
        units : str or UnitSystem
            Unit system.
        name : str
            Name used in reports.

        Raises
        ------
        ValueError
            K not square, finite and symmetric; M not matching K, or singular or indefinite
            to working precision (the message gives its condition number); G not
            skew-symmetric; C not symmetric; the wrong number of coordinate names; unknown
            units.

        Examples
        --------
        >>> system = GeneralizedSystem.from_matrices([2.0, 1.0], [[8.0, 0.0], [0.0, 1.0]], coordinates=["x", "y"])
        >>> system.M.tolist(), system.labels
        ([[2.0, 0.0], [0.0, 1.0]], ('x', 'y'))
        """
        name = _validate.text(name, "name")
        K_matrix = _validate.square_matrix(K, "K")
        if not isinstance(K_matrix, np.ndarray):
            K_matrix = np.asarray(K_matrix.toarray())
        K_matrix = np.asarray(_validate.symmetric(K_matrix, "K"))
        n = K_matrix.shape[0]
        if np.ndim(M) == 2 and not hasattr(M, "toarray"):
            M_matrix = check_mass_matrix(M, n, "M")
        else:
            M_matrix = _validate.mass_argument(M, n, "M")
        if M_matrix.ndim == 1:
            M_matrix = np.diag(M_matrix)
        G_matrix = check_gyroscopic(G, n, "G") if G is not None else None
        C_matrix = None
        if C is not None:
            C_matrix = _validate.real_array(C, "C", ndim=2)
            if C_matrix.shape != (n, n):
                raise ValueError(f"C must be ({n}, {n}) to match K, got shape {C_matrix.shape}")
            C_matrix = np.array(_validate.symmetric(C_matrix, "C"), dtype=float)
        if coordinates is not None and (isinstance(coordinates, str) or not isinstance(coordinates, Sequence)):
            raise TypeError(f"coordinates must be a sequence of str, got {coordinates!r}")
        names = tuple(coordinates) if coordinates is not None else tuple(f"q{i}" for i in range(n))
        if len(names) != n:
            raise ValueError(f"coordinates must name {n} coordinates, got {len(names)}")
        return cls(M=M_matrix, K=K_matrix, frozen=np.zeros(n, dtype=bool), labels=names,
                   units=unit_system(units), name=name, G=G_matrix, C=C_matrix)

    # ------------------------------------------------------------------ derived systems
    def freeze(self, sites: ArrayLike | None = None, dofs: ArrayLike | None = None) -> GeneralizedSystem:
        """A copy with more coordinates held at rest (q_j = 0).

        Parameters
        ----------
        sites : None
            Must be None: generalised coordinates have no sites.
        dofs : (n_frozen,) array_like of int, optional
            Indices of the coordinates to hold at rest.

        Raises
        ------
        ValueError
            `sites` given; an index out of range; every coordinate frozen.
        TypeError
            Indices that are not integers.
        """
        if sites is not None:
            raise ValueError("sites is given, but generalised coordinates have no sites; "
                             "freeze coordinates with freeze(dofs=...)")
        mask = np.array(self.frozen)
        if dofs is not None:
            mask[_validate.indices(dofs, "dofs", mask.shape[0], what="coordinate")] = True
        if mask.all():
            raise ValueError("every degree of freedom is frozen; nothing is left to vibrate")
        return dataclasses.replace(self, frozen=mask)

    # ------------------------------------------------------------------ sizes
    @property
    def n_sites(self) -> int:
        """0: generalised coordinates have no sites."""
        return 0

    @property
    def dim(self) -> int:
        """0: generalised coordinates have no spatial dimension."""
        return 0

    @property
    def is_generalized(self) -> bool:
        """True: this system is in generalised coordinates."""
        return True

    # ------------------------------------------------------------------ assembly
    def spring_factor(self) -> None:
        """None: K of generalised coordinates is not factorised into springs."""
        return None

    def hessian(self) -> sp.csr_matrix:
        """(n_dof, n_dof) CSR stiffness matrix K over the free coordinates."""
        free = self.free_dofs
        return sp.csr_matrix(self.K[np.ix_(free, free)])

    def mass_matrix(self) -> NDArray[np.float64]:
        """(n_dof, n_dof) mass matrix M over the free coordinates."""
        free = self.free_dofs
        return np.array(self.M[np.ix_(free, free)])

    def gyroscopic_matrix(self) -> NDArray[np.float64] | None:
        """(n_dof, n_dof) skew gyroscopic matrix G over the free coordinates, or None."""
        free = self.free_dofs
        return None if self.G is None else np.array(self.G[np.ix_(free, free)])

    def damping_matrix(self) -> NDArray[np.float64] | None:
        """(n_dof, n_dof) symmetric damping matrix C over the free coordinates, or None.

        Pass it to `vibra.response.frequency_response` / `transient_response` with
        `hessian()` and `mass_matrix()` (as C).
        """
        free = self.free_dofs
        return None if self.C is None else np.array(self.C[np.ix_(free, free)])

    @property
    def is_quadratic(self) -> bool:
        """True when G or C is present: `modes` returns `QuadraticModes`."""
        return self.G is not None or self.C is not None

    def quadratic_modes(self) -> QuadraticModes:
        """Modes of M q'' + (G + C) q' + K q = 0 over the free coordinates (`vibra.solvers.structured.quadratic`).

        Works without G and C too (then every damping ratio is 0 for a stable system).
        Warns (RuntimeWarning) when the system is unstable.

        Examples
        --------
        >>> import vibra
        >>> charged = vibra.System.generalized(np.eye(2), np.eye(2), G=[[0.0, -1.0], [1.0, 0.0]])
        >>> np.round(charged.quadratic_modes().natural_frequency, 9).tolist()   # sqrt(5)/2 -+ 1/2
        [0.618033989, 1.618033989]
        """
        return quadratic_modes(self.mass_matrix(), self.hessian().toarray(), G=self.gyroscopic_matrix(),
                               C=self.damping_matrix(), units=self.units)

    def modes(
        self,
        n_modes: int | None = None,
        *,
        accuracy: Accuracy = "high",
        vectors: bool = True,
        band: tuple[float, float] | None = None,
        solver: str = "auto",
        device: str = "cpu",
        max_memory: float | None = None,
        max_seconds: float | None = None,
        progress: bool | Callable[[float, str], None] | None = None,
    ) -> Modes | QuadraticModes:
        """Normal modes of the free coordinates (Kneller, Mécanique analytique, eqs. 137-151);
        see `vibra.System.modes`.

        Returns `Modes`, or a `vibra.solvers.structured.quadratic.QuadraticModes` when the system has G or C
        (`is_quadratic`; all modes, so n_modes and band must be None there; `solver` is "auto"
        or one of the quadratic methods, `max_memory` / `max_seconds` are checked against their
        estimate; `accuracy` has one meaning there, the methods' own bounds). Otherwise
        `vibra.normal_modes` solves it, whose registry takes a full M with ``solver="auto"`` to
        the pencil paths (``"pencil-jacobi"``; ``"pencil-cholesky"`` with accuracy="fast" or
        an indefinite K), which keep the accuracy that an ill-conditioned M would cost the
        mass-weighted form. `accuracy`, `device`, `max_memory`, `max_seconds` and `progress`
        mean what they mean for `vibra.normal_modes`.

        Raises
        ------
        ValueError
            An unknown accuracy; n_modes or band with G or C.
        """
        _validate.choice(accuracy, "accuracy", ACCURACY_LEVELS)
        if self.is_quadratic:
            if n_modes is not None or band is not None:
                raise ValueError("n_modes and band are not available for a system with G or C: "
                                 "its modes are computed all at once (dense quadratic eigenproblem)")
            if device != "cpu":
                raise ValueError(f"device={device!r} is not available for a system with G or C: "
                                 "expected 'cpu' (the quadratic methods run on LAPACK)")
            return quadratic_modes(self.mass_matrix(), self.hessian().toarray(), G=self.gyroscopic_matrix(),
                                   C=self.damping_matrix(), units=self.units, solver=solver,
                                   max_memory=max_memory, max_seconds=max_seconds)
        mass = self.mass_matrix()
        return normal_modes(self.hessian(), mass, n_modes=n_modes, vectors=vectors, band=band,
                            solver=solver, units=self.units, accuracy=accuracy, device=device,
                            max_memory=max_memory, max_seconds=max_seconds, progress=progress)
