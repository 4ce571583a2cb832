"""`System`: what is vibrating, and how its Hessian K and mass matrix M are assembled.

A system is a set of sites (equilibrium coordinates in 1, 2 or 3 dimensions, one mass each)
with a quadratic potential. A set of generalised coordinates with a dense mass matrix is a
class of its own, `vibra.generalized.GeneralizedSystem`, built by `System.generalized`. Both
satisfy `Vibrating`, the protocol of anything with K, M and modes (``isinstance(x, Vibrating)``
accepts either; `is_generalized` tells them apart; ``isinstance(x, System)`` means sites). The potential is stored factorised whenever possible
(Kneller, Mécanique analytique, eq. 133):

    V = 1/2 u^T K u,    K = B^T diag(w) B + K_extra,

where each row of the sparse matrix B is the gradient of one internal coordinate (a spring's
elongation, an anchor spring, a bond angle, ...) with respect to the displacements u, w > 0
is its stiffness and K_extra holds Hessian blocks given directly by the user. When K_extra is
absent the accurate solver path uses the factor: the normal frequencies are the singular values
of W^1/2 B M^-1/2 (docs/architecture.md, "Accuracy").

Sites or single degrees of freedom can be frozen; `hessian()`, `mass_matrix()` and `modes()`
then refer to the free degrees of freedom only, in the order of `free_dofs`.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import TYPE_CHECKING, Callable, Protocol, Sequence, runtime_checkable

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from vibra import assembly
from vibra._core import validate as _validate
from vibra._core.frozen import short_repr
from vibra.generalized import FreeDofs, GeneralizedSystem
from vibra.modes import Modes, normal_modes
from vibra.solvers.accuracy import LEVELS as ACCURACY_LEVELS, Accuracy, uses_springs
from vibra.units import UnitSystem, unit_system

if TYPE_CHECKING:
    from vibra.solvers.structured.quadratic import QuadraticModes

__all__ = ["System", "GeneralizedSystem", "Vibrating"]


@runtime_checkable
class Vibrating(Protocol):
    """Anything vibra can solve and analyse: a `System` (sites) or a `GeneralizedSystem`
    (coordinates). A function that takes either checks ``isinstance(x, Vibrating)`` and tells
    them apart with `is_generalized`; one that needs sites checks ``isinstance(x, System)``."""

    units: UnitSystem

    @property
    def is_generalized(self) -> bool: ...

    @property
    def n_dof(self) -> int: ...

    def hessian(self) -> sp.csr_matrix: ...

    def mass_matrix(self) -> NDArray[np.float64]: ...

    def modes(self, n_modes: int | None = None, *, accuracy: Accuracy = "high", vectors: bool = True,
              band: tuple[float, float] | None = None, solver: str = "auto", device: str = "cpu",
              max_memory: float | None = None, max_seconds: float | None = None,
              progress: bool | Callable[[float, str], None] | None = None) -> Modes | QuadraticModes: ...

_AXES = "xyz"


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class System(FreeDofs):
    """A vibrating system: sites, masses, and a factorised quadratic potential.

    Build one with `System.from_springs`, `System.from_terms` or `System.from_hessian` (or a
    builder in `vibra.chains` / `vibra.molecules`), not with the raw constructor;
    `System.generalized` builds a `GeneralizedSystem` instead.

    Attributes
    ----------
    positions : (n_sites, dim) ndarray
        Equilibrium coordinates, in the length unit of `units`.
    masses : (n_sites,) ndarray
        Site masses, in the mass unit of `units`.
    units : UnitSystem
        The unit system of every quantity of the system and of its results.
    coupling : (n_terms, n_sites * dim) scipy.sparse.csr_matrix
        B: row t is the gradient of internal coordinate t with respect to the displacements
        (dimensionless for springs, 1/length for angles).
    weights : (n_terms,) ndarray
        w: the stiffness of each term, in energy per (internal-coordinate unit)^2.
    extra_hessian : (n_sites * dim, n_sites * dim) scipy.sparse.csr_matrix or None
        Hessian blocks given directly (not factorised), in energy / length^2.
    frozen : (n_sites * dim,) ndarray of bool
        True for a degree of freedom held at rest.
    labels : tuple of str
        One name per degree of freedom (free and frozen), e.g. ``"3x"``.
    name : str
        A short name used in reports.
    symbols : tuple of str or None
        Chemical symbol of each site for a molecule (set by `vibra.molecules` builders, or
        `with_symbols`); None for other systems.

    Examples
    --------
    >>> chain = System.from_springs([0.0, 1.0, 2.0], 1.0, [[0, 1], [1, 2]], 1.0)
    >>> np.round(chain.modes().omega_squared, 12)  # 0, kappa / m, 3 kappa / m
    array([0., 1., 3.])
    """

    positions: NDArray[np.float64]
    masses: NDArray[np.float64]
    units: UnitSystem
    coupling: sp.csr_matrix
    weights: NDArray[np.float64]
    extra_hessian: sp.csr_matrix | None
    frozen: NDArray[np.bool_]
    labels: tuple[str, ...]
    name: str = "system"
    symbols: tuple[str, ...] | None = None

    def __repr__(self) -> str:
        """One line, never the arrays: name, sites and dimension, dofs, frozen dofs, units."""
        frozen = f"{int(self.frozen.sum())} dofs frozen" if self.frozen.any() else "unconstrained"
        return short_repr(self, repr(self.name), f"{self.masses.size} sites in {self.positions.shape[1]}-D",
                          f"{self.n_dof} dofs", frozen, f"{self.units.name} units")

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_springs(
        cls,
        positions: ArrayLike,
        masses: ArrayLike,
        springs: ArrayLike | None = None,
        stiffness: ArrayLike | float | None = None,
        *,
        anchors: ArrayLike | None = None,
        anchor_stiffness: ArrayLike | float | None = None,
        anchor_directions: ArrayLike | None = None,
        blocks: Sequence[tuple[ArrayLike, ArrayLike]] | None = None,
        frozen_sites: ArrayLike | None = None,
        frozen_dofs: ArrayLike | None = None,
        units: str | UnitSystem = "SI",
        name: str = "system",
        cell: ArrayLike | None = None,
    ) -> System:
        """Sites joined by harmonic springs whose rest lengths are the equilibrium distances.

        In d dimensions a spring between sites i and j, with unit bond vector e, adds the
        Hessian block k e e^T (row of B: -e on site i, +e on site j).

        Parameters
        ----------
        positions : (n_sites, dim) or (n_sites,) array_like
            Equilibrium coordinates, in the length unit of `units`; 1-D input means dim = 1.
        masses : (n_sites,) array_like or float
            Site masses, in the mass unit of `units`.
        springs : (n_springs, 2) array_like of int, optional
            Site index pairs (i, j), i != j.
        stiffness : (n_springs,) array_like or float
            Spring constants, in energy / length^2 (N/m in SI).
        anchors : (n_anchors,) array_like of int, optional
            Sites tied by a spring to a fixed point.
        anchor_stiffness : (n_anchors,) array_like or float
            Their spring constants.
        anchor_directions : (n_anchors, dim) array_like, optional
            Direction of each anchor spring (normalised here); by default the x axis.
        blocks : sequence of (sites, H), optional
            User-given Hessian blocks: `sites` (k,) site indices and `H` a symmetric
            (k * dim, k * dim) matrix in energy / length^2 over their dofs (site-major),
            added to K. A system with blocks has no spring factor (no accurate path).
        frozen_sites : array_like of int, optional
            Sites held at rest (all their degrees of freedom).
        frozen_dofs : array_like of int, optional
            Single degrees of freedom held at rest, as flat indices site * dim + axis.
        units : str or UnitSystem
            ``"SI"`` (default), ``"ASE"`` or ``"dimensionless"``.
        name : str
            Name used in reports.
        cell : (dim, dim) array_like, optional
            Lattice vectors (rows) of a periodic supercell, in the length unit: each spring
            joins i to the nearest image of j (minimum image). Crystals: `vibra.crystals`.

        Raises
        ------
        ValueError
            Wrong shapes, non-positive or non-finite masses or stiffnesses, site indices out
            of range, a spring joining a site to itself or two coincident sites; a `cell` too
            small for a spring; without `cell`, in 2-D/3-D, a spring that looks wrapped around a
            periodic box (`vibra.assembly.refuse_wrapped`).

        Examples
        --------
        >>> corner = System.from_springs([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], 1.0, [[0, 1], [0, 2]], 2.0)
        >>> corner.n_dof, corner.hessian()[0, 2], corner.hessian()[1, 5]  # each spring acts along its axis
        (6, np.float64(-2.0), np.float64(-2.0))
        """
        name = _validate.text(name, "name")
        positions_array = _positions(positions)
        n_sites, dim = positions_array.shape
        mass_array = _site_masses(masses, n_sites)
        rows: list[sp.coo_matrix] = []
        weight_parts: list[NDArray[np.float64]] = []
        if springs is not None:
            pairs = _validate.indices(springs, "springs", n_sites, shape=(-1, 2))
            k = _per_item(stiffness, len(pairs), "stiffness")
            _validate.positive(k, "stiffness", "spring constant")
            same = pairs[:, 0] == pairs[:, 1]
            if same.any():
                s = int(np.argmax(same))
                raise ValueError(f"springs[{s}] joins site {pairs[s, 0]} to itself")
            bond = positions_array[pairs[:, 1]] - positions_array[pairs[:, 0]]
            bond = assembly.periodic_bonds(bond, positions_array, pairs, cell)  # minimum image, or wrap refused
            length = np.linalg.norm(bond, axis=1)
            scale = max(float(np.abs(positions_array).max()), 1.0) if positions_array.size else 1.0
            short = length <= 1e-12 * scale
            if short.any():
                s = int(np.argmax(short))
                raise _validate.ArgumentError(  # the positions are at fault: two sites in one place
                    "positions", f"springs[{s}] joins sites {pairs[s, 0]} and {pairs[s, 1]} at the same "
                    "position; a spring needs distinct equilibrium positions to define its axis")
            unit = bond / length[:, None]
            rows.append(assembly.pair_rows(pairs, unit, n_sites, dim))
            weight_parts.append(k)
        elif stiffness is not None:
            raise ValueError("stiffness was given without springs")
        elif cell is not None:
            raise ValueError("cell was given without springs")
        if anchors is not None:
            sites = _validate.indices(anchors, "anchors", n_sites, shape=(-1,))
            k = _per_item(anchor_stiffness, len(sites), "anchor_stiffness")
            _validate.positive(k, "anchor_stiffness", "spring constant")
            if anchor_directions is None:
                direction = np.zeros((len(sites), dim))
                direction[:, 0] = 1.0
            else:
                direction = _validate.real_array(anchor_directions, "anchor_directions", ndim=2)
                if direction.shape != (len(sites), dim):
                    raise ValueError(
                        f"anchor_directions must have shape ({len(sites)}, {dim}), got {direction.shape}"
                    )
                norm = np.linalg.norm(direction, axis=1)
                if (norm == 0).any():
                    raise ValueError(f"anchor_directions[{int(np.argmin(norm))}] is the zero vector")
                direction = direction / norm[:, None]
            rows.append(assembly.single_rows(sites, direction, n_sites, dim))
            weight_parts.append(k)
        elif anchor_stiffness is not None:
            raise ValueError("anchor_stiffness was given without anchors")
        coupling, weights = assembly.stack_terms(rows, weight_parts, n_sites * dim)
        frozen = _frozen_mask(n_sites, dim, frozen_sites, frozen_dofs)
        extra = assembly.hessian_blocks(blocks, n_sites, dim) if blocks is not None else None
        return cls(
            positions=positions_array, masses=mass_array, units=unit_system(units),
            coupling=coupling, weights=weights, extra_hessian=extra, frozen=frozen,
            labels=_site_labels(n_sites, dim), name=name,
        )

    @classmethod
    def from_terms(
        cls,
        positions: ArrayLike,
        masses: ArrayLike,
        coupling: ArrayLike | sp.spmatrix,
        weights: ArrayLike,
        *,
        extra_hessian: ArrayLike | sp.spmatrix | None = None,
        frozen_sites: ArrayLike | None = None,
        frozen_dofs: ArrayLike | None = None,
        units: str | UnitSystem = "SI",
        name: str = "system",
    ) -> System:
        """Sites with a potential given as K = B^T diag(w) B (+ K_extra).

        Parameters
        ----------
        positions : (n_sites, dim) array_like
            Equilibrium coordinates, in the length unit of `units`.
        masses : (n_sites,) array_like
            Site masses.
        coupling : (n_terms, n_sites * dim) array_like or sparse
            B, the gradients of the internal coordinates (Wilson's B matrix).
        weights : (n_terms,) array_like
            w, the force constant of each internal coordinate (> 0).
        extra_hessian : (n_sites * dim, n_sites * dim) array_like or sparse, optional
            A symmetric Hessian added to B^T W B, in energy / length^2.

        Examples
        --------
        >>> system = System.from_terms([0.0, 1.0], [1.0, 2.0], [[-1.0, 1.0]], [3.0])
        >>> system.hessian().toarray()
        array([[ 3., -3.],
               [-3.,  3.]])
        """
        name = _validate.text(name, "name")
        positions_array = _positions(positions)
        n_sites, dim = positions_array.shape
        mass_array = _site_masses(masses, n_sites)
        n_full = n_sites * dim
        b = sp.csr_matrix(coupling, dtype=float)
        if b.shape[1] != n_full:
            raise ValueError(f"coupling must have {n_full} columns (n_sites * dim), got shape {b.shape}")
        _validate.finite(b.data, "coupling.data")
        w = _validate.real_array(weights, "weights", ndim=1)
        if w.shape[0] != b.shape[0]:
            raise ValueError(f"weights must have {b.shape[0]} entries (one per row of coupling), got {w.shape[0]}")
        _validate.positive(w, "weights", "force constant")
        extra = None
        if extra_hessian is not None:
            extra = _validate.symmetric(_validate.square_matrix(extra_hessian, "extra_hessian"), "extra_hessian")
            if extra.shape[0] != n_full:
                raise ValueError(f"extra_hessian must be ({n_full}, {n_full}), got {extra.shape}")
            extra = sp.csr_matrix(extra)
        return cls(
            positions=positions_array, masses=mass_array, units=unit_system(units),
            coupling=b, weights=w, extra_hessian=extra,
            frozen=_frozen_mask(n_sites, dim, frozen_sites, frozen_dofs),
            labels=_site_labels(n_sites, dim), name=name,
        )

    @classmethod
    def from_hessian(
        cls,
        positions: ArrayLike,
        masses: ArrayLike,
        hessian: ArrayLike | sp.spmatrix,
        *,
        symmetrize: bool = False,
        frozen_sites: ArrayLike | None = None,
        frozen_dofs: ArrayLike | None = None,
        units: str | UnitSystem = "SI",
        name: str = "system",
    ) -> System:
        """Sites with a Hessian K given directly, (n_sites * dim, n_sites * dim), energy / length^2.

        Examples
        --------
        >>> system = System.from_hessian([0.0, 1.0], 1.0, [[1.0, -1.0], [-1.0, 1.0]])
        >>> system.spring_factor() is None, np.round(system.modes().omega_squared, 12).tolist()
        (True, [0.0, 2.0])
        """
        name = _validate.text(name, "name")
        positions_array = _positions(positions)
        n_sites, dim = positions_array.shape
        symmetrize = _validate.boolean(symmetrize, "symmetrize")
        matrix = _validate.square_matrix(hessian, "hessian")
        matrix = _validate.symmetric(matrix, "hessian", symmetrize=symmetrize)
        if matrix.shape[0] != n_sites * dim:
            raise ValueError(f"hessian must be ({n_sites * dim}, {n_sites * dim}), got {matrix.shape}")
        return cls(
            positions=positions_array, masses=_site_masses(masses, n_sites), units=unit_system(units),
            coupling=sp.csr_matrix((0, n_sites * dim)), weights=np.zeros(0),
            extra_hessian=sp.csr_matrix(matrix),
            frozen=_frozen_mask(n_sites, dim, frozen_sites, frozen_dofs),
            labels=_site_labels(n_sites, dim), name=name,
        )

    @staticmethod
    def generalized(
        M: ArrayLike,
        K: ArrayLike,
        *,
        G: ArrayLike | None = None,
        C: ArrayLike | None = None,
        coordinates: Sequence[str] | None = None,
        units: str | UnitSystem = "SI",
        name: str = "system",
    ) -> GeneralizedSystem:
        """A system in generalised coordinates q: M q'' + (G + C) q' + K q = 0.

        Returns a `vibra.generalized.GeneralizedSystem` built by its `from_matrices` (see
        there for the parameters, in the same order, and the checks): M (n, n) symmetric
        positive definite (or its diagonal; ill-conditioned is fine), K (n, n) symmetric,
        optional G (skew-symmetric, gyroscopic) and C (symmetric, damping), optional
        coordinate names. With G or C, ``modes()`` returns a `vibra.solvers.structured.quadratic.QuadraticModes`.
        It has no sites: ``freeze(sites=...)`` raises, ``freeze(dofs=...)`` holds coordinates
        at rest.

        Examples
        --------
        >>> system = System.generalized(np.diag([2.0, 1.0]), np.diag([8.0, 1.0]), coordinates=["a", "b"])
        >>> system.is_generalized, system.labels, np.round(system.modes().omega, 12).tolist()
        (True, ('a', 'b'), [1.0, 2.0])
        """
        return GeneralizedSystem.from_matrices(M, K, G=G, C=C, coordinates=coordinates, units=units, name=name)

    # ------------------------------------------------------------------ derived systems
    def with_masses(self, masses: ArrayLike) -> System:
        """The same potential with new site masses (isotopes), in the mass unit of `units`.

        Examples
        --------
        >>> chain = System.from_springs([0.0, 1.0, 2.0], 1.0, [[0, 1], [1, 2]], 1.0)
        >>> chain.with_masses([1.0, 2.0, 1.0]).mass_matrix().tolist()
        [1.0, 2.0, 1.0]
        """
        return dataclasses.replace(self, masses=_site_masses(masses, self.n_sites))

    def with_symbols(self, symbols: Sequence[str] | None) -> System:
        """The same system with a chemical symbol per site (None clears them).

        Raises
        ------
        TypeError
            `symbols` is a single string or holds a non-string.
        ValueError
            Not one symbol per site, or an empty symbol.

        Examples
        --------
        >>> System.from_springs([0.0, 1.1, 2.2], [16.0, 12.0, 16.0], [[0, 1], [1, 2]], 1.0
        ...                     ).with_symbols(["O", "C", "O"]).symbols
        ('O', 'C', 'O')
        """
        if symbols is None:
            return dataclasses.replace(self, symbols=None)
        if isinstance(symbols, str) or not isinstance(symbols, Sequence):
            raise TypeError(f"symbols must be a sequence of str, one per site, got {symbols!r}")
        if len(symbols) != self.n_sites:
            raise ValueError(f"symbols has {len(symbols)} entries; expected one per site ({self.n_sites})")
        for i, symbol in enumerate(symbols):
            if not isinstance(symbol, str):
                raise TypeError(f"symbols[{i}] is {symbol!r}; expected a str such as 'O'")
            if not symbol.strip():
                raise ValueError(f"symbols[{i}] is empty; expected a chemical symbol such as 'O'")
        return dataclasses.replace(self, symbols=tuple(symbols))

    def freeze(self, sites: ArrayLike | None = None, dofs: ArrayLike | None = None) -> System:
        """A copy with more sites or flat degrees of freedom held at rest.

        Examples
        --------
        >>> chain = System.from_springs([0.0, 1.0, 2.0], 1.0, [[0, 1], [1, 2]], 1.0)
        >>> chain.freeze(sites=[0]).free_dofs.tolist()
        [1, 2]
        """
        mask = self.frozen | _frozen_mask(self.n_sites, self.dim, sites, dofs)
        if mask.all():
            raise ValueError("every degree of freedom is frozen; nothing is left to vibrate")
        return dataclasses.replace(self, frozen=mask)

    # ------------------------------------------------------------------ sizes
    @property
    def n_sites(self) -> int:
        """Number of sites."""
        return int(self.masses.shape[0])

    @property
    def dim(self) -> int:
        """Spatial dimension of the sites (1, 2 or 3)."""
        return int(self.positions.shape[1])

    @property
    def is_generalized(self) -> bool:
        """False: a `System` has sites (a `GeneralizedSystem` answers True)."""
        return False

    # ------------------------------------------------------------------ assembly
    def spring_factor(self) -> tuple[sp.csr_matrix, NDArray[np.float64]] | None:
        """(B, w) with K = B^T diag(w) B over the free dofs, or None if K is not factorised.

        B is (n_terms, n_dof) CSR with the columns of frozen dofs removed and rows that
        touch no free dof dropped; w is (n_terms,).

        Examples
        --------
        >>> B, w = System.from_springs([0.0, 1.0, 2.0], 1.0, [[0, 1], [1, 2]], 1.0).spring_factor()
        >>> B.toarray().tolist(), w.tolist()
        ([[-1.0, 1.0, 0.0], [0.0, -1.0, 1.0]], [1.0, 1.0])
        """
        if self.extra_hessian is not None:
            return None
        b = self.coupling[:, self.free_dofs] if self.frozen.any() else self.coupling
        b = sp.csr_matrix(b)
        keep = np.diff(b.indptr) > 0
        if not keep.all():
            b = b[np.flatnonzero(keep)]
            return sp.csr_matrix(b), self.weights[keep]
        return b, np.asarray(self.weights)

    def hessian(self) -> sp.csr_matrix:
        """(n_dof, n_dof) CSR force-constant matrix K over the free dofs, in energy / length^2: a copy of
        the one `modes` solves, assembled once per system (ubiquitin's ANM: 1 of 6.5 ms a "fast" call)."""
        return self._hessian.copy()

    @functools.cached_property
    def _hessian(self) -> sp.csr_matrix:
        """K, assembled on first use, read-only (so are the system's arrays: it cannot go stale)."""
        return assembly.hessian(self.coupling, self.weights, self.extra_hessian, self.free_dofs if self.frozen.any() else None)

    def mass_matrix(self) -> NDArray[np.float64]:
        """(n_dof,) masses of the free dofs (the diagonal of M), in the mass unit of `units`.

        Examples
        --------
        >>> System.from_springs([[0.0, 0.0], [1.0, 0.0]], [1.0, 3.0], [[0, 1]], 1.0).mass_matrix().tolist()
        [1.0, 1.0, 3.0, 3.0]
        """
        return np.repeat(np.asarray(self.masses), self.dim)[self.free_dofs]

    def solver_positions(self) -> NDArray[np.float64] | None:
        """The sites' positions as `vibra.normal_modes` takes them (``positions=``: the iterative path's
        rigid blocks and exact rotations) for a 3-D system whose dofs are all free, else None."""
        return self.positions if self.dim == 3 and self.free_dofs.size == self.positions.size else None

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
    ) -> Modes:
        """Normal modes of the free dofs (Kneller, Mécanique analytique, eqs. 137-151).

        Parameters
        ----------
        n_modes : int, optional
            Number of lowest modes wanted (all by default).
        accuracy : {"high", "fast", "certified"}
            "high" (default): every requested frequency to ~1e-10 relative, using the spring
            factor, with an a-posteriori bound; "fast": the quickest path (absolute accuracy,
            ~eps ||K~||); "certified": every bound a certificate (within 1000x the true error or
            1e-13 relative), at its cost. See `vibra.normal_modes`.
        vectors : bool
            False computes frequencies only.
        band : (float, float), optional
            Only the modes with omega in [low, high], in rad per time unit.
        solver : str
            Override the automatic choice (see `vibra.normal_modes`).
        device : {"cpu", "gpu"}
            "gpu": all modes densely on an NVIDIA GPU through CuPy (``vibra[gpu]``), the
            standard (absolute-accuracy) path whatever `accuracy` says; see `vibra.normal_modes`.
        max_memory, max_seconds, progress
            The resource limits and progress reporting of `vibra.normal_modes`.

        Examples
        --------
        >>> chain = System.from_springs([0.0, 1.0, 2.0], 1.0, [[0, 1], [1, 2]], 1.0)
        >>> chain.modes(n_modes=2, vectors=False).omega.round(12).tolist()
        [0.0, 1.0]
        """
        _validate.choice(accuracy, "accuracy", ACCURACY_LEVELS)
        on_gpu = isinstance(device, str) and device in ("gpu", "cuda")
        factor = self.spring_factor() if uses_springs(accuracy) and not on_gpu else None
        return normal_modes(
            self._hessian, self.mass_matrix(), n_modes=n_modes, vectors=vectors, band=band,
            solver=solver, spring_factor=factor, positions=self.solver_positions(),
            units=self.units, device=device,
            max_memory=max_memory, max_seconds=max_seconds, progress=progress,
            accuracy=accuracy,
        )


# ---------------------------------------------------------------------- helpers
def _positions(positions: ArrayLike) -> NDArray[np.float64]:
    array = _validate.real_array(positions, "positions", ndim=(1, 2))
    array = array[:, None] if array.ndim == 1 else array
    if array.shape[0] < 1:
        raise ValueError("positions must hold at least one site, got none")
    if array.shape[1] not in (1, 2, 3):
        raise ValueError(f"positions must be (n_sites, dim) with dim 1, 2 or 3, got shape {array.shape}")
    return array


def _site_masses(masses: ArrayLike, n_sites: int) -> NDArray[np.float64]:
    array = _validate.per_entry(masses, n_sites, "masses", "site")
    _validate.positive(array, "masses", "mass")
    return array


def _per_item(value: ArrayLike | float | None, n: int, name: str) -> NDArray[np.float64]:
    if value is None:
        raise ValueError(f"{name} is required")
    return _validate.per_entry(value, n, name)


def _frozen_mask(n_sites: int, dim: int, sites: ArrayLike | None, dofs: ArrayLike | None) -> NDArray[np.bool_]:
    mask = np.zeros(n_sites * dim, dtype=bool)
    if sites is not None:
        index = _validate.indices(sites, "frozen_sites", n_sites, shape=(-1,))
        mask[(index[:, None] * dim + np.arange(dim)).ravel()] = True
    if dofs is not None:
        index = _validate.indices(dofs, "frozen_dofs", n_sites * dim, shape=(-1,), what="dof")
        mask[index] = True
    if mask.all():
        raise ValueError("every degree of freedom is frozen; nothing is left to vibrate")
    return mask


def _site_labels(n_sites: int, dim: int) -> tuple[str, ...]:
    return tuple(str(i) if dim == 1 else f"{i}{_AXES[a]}" for i in range(n_sites) for a in range(dim))
