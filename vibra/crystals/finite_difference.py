"""Force constants of a crystal from any ASE calculator, by finite differences on a supercell.

The displacements are reduced by the space group: phonopy's generator
(``Phonopy.generate_displacements``, spglib underneath) picks one displacement per
symmetry-inequivalent atom and direction, and phonopy's solver (``produce_force_constants``)
rebuilds the full supercell force constants from their forces by the site symmetries. Both
are phonopy's, not ours: it is the reference implementation of exactly this reduction (a
named dependency of vibra), and a second one here would be a second place for the same
decision. What vibra adds is everything around them:

- each displaced supercell is one force call, run by the machinery of the molecules' finite
  differences (`vibra.molecules.displacements`, `vibra.cluster`): serially, or one Dask task
  each with ``client=``; with ``cache=``, each geometry's forces are written as they arrive,
  keyed by the displaced geometry itself, so a killed run started again computes only what
  is missing;
- the forces at the reference supercell are subtracted (they vanish by symmetry for a
  perfect crystal; what is left is the calculator's own residual);
- the acoustic sum rule and the index symmetry are imposed (`impose_sum_rules`, our own
  projection), and how far the raw force constants were from them is reported;
- the error is estimated as for molecules (`vibra.molecules.finite_difference`): with
  ``estimate_error`` every displacement is evaluated again at 2h and the truncation error of
  each supercell entry is the Richardson estimate |Phi(h) - Phi(2h)| / 3; the round-off part is
  force_noise / h, with the force noise probed as for molecules (`vibra.molecules.noise`: a
  listed closed-form calculator such as EMT is not called again, any other is probed at the
  reference supercell); the change made by the sum-rule projection is added. Per frequency,
  `FiniteDifferenceForceConstants.omega_errors` turns that into a first-order bound.

Units: ASE's (eV, Angstrom, amu); the crystal is in ``ASE`` units.
"""

from __future__ import annotations

import contextlib
import hashlib
import math
import os
import sys
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import Frozen, short_repr
from vibra.cluster import ClientOnDemand, ClientOption, ProgressOption, check_client
from vibra.crystals.crystal import Crystal
from vibra.crystals.fd_cost import (FORCE_SECONDS, SYMMETRY_FIXED_SECONDS, SYMMETRY_SECONDS,  # noqa: F401 (their home)
                                    check_memory, force_constants_cost, symmetry_pays)
from vibra.crystals.force_constants import ForceConstants, SumRuleReport, average_over_space_group, impose_sum_rules
from vibra.crystals.phonopy_io import MAX_SUPERCELL_ATOMS  # one limit: phonopy's full force constants, 72 n^2 bytes
from vibra.crystals.mesh import species_numbers
from vibra.crystals.reach import SupercellReach, check_range_from_sizes, supercell_reach, warn_range
from vibra.molecules.displacements import (CalculatorOption, ForceCache, calculator_of, calculator_source,
                                           gather_forces)
from vibra.molecules.noise import is_deterministic_calculator, rounding_noise, run_noise

if TYPE_CHECKING:
    from ase import Atoms

__all__ = ["FiniteDifferenceForceConstants", "finite_difference_force_constants", "from_ase"]


@dataclass(frozen=True, eq=False)
class FiniteDifferenceForceConstants(Frozen):
    """A crystal whose force constants are finite differences of a calculator's forces, with their error.

    Attributes
    ----------
    crystal : Crystal
        The unit cell of the atoms given, with the force constants (sum rules imposed), ASE units.
    supercell : (3,) ndarray of int
        Cells along each lattice vector of the supercell the forces were computed on.
    step : float
        Displacement h, Angstrom.
    error_blocks : (n_atoms, n_atoms, 3, 3) ndarray
        Bound on |Delta Phi(i, j R)| summed over all R, per atom pair and Cartesian entry,
        eV / Angstrom^2: truncation + round-off + the sum-rule change. |Delta D(q)| is below it
        divided by sqrt(m_i m_j), at every q.
    truncation : float
        Largest Richardson truncation estimate of one supercell entry, eV / Angstrom^2 (0
        without ``estimate_error``).
    roundoff : float
        force_noise / h, eV / Angstrom^2.
    force_noise : float
        Noise of one force component behind `roundoff`, eV / Angstrom.
    noise_source : str
        As for molecules: ``"analytic"``, ``"probed"``, ``"measured"``, ``"given"`` or ``"rounding"``.
    sum_rules : SumRuleReport
        How far the raw force constants were from the acoustic sum rule and the index symmetry.
    n_displacements : int
        Symmetry-inequivalent displacements (phonopy's generator), per step.
    n_force_calls : int
        Force calls made in this run (reference included; the noise probe not).
    n_cached : int
        Geometries read from the cache instead.
    reach : SupercellReach or None
        How far the force constants reach the supercell's edge (None when not measured).
    primitive_matrix : (3, 3) ndarray or None
        The matrix P of the crystal's cell, P^T applied to the given cell's lattice vectors
        (phonopy's convention): the identity unless ``primitive=True``.
    """

    crystal: Crystal
    supercell: NDArray[np.int64]
    step: float
    error_blocks: NDArray[np.float64]
    truncation: float
    roundoff: float
    force_noise: float
    noise_source: str
    sum_rules: SumRuleReport
    n_displacements: int
    n_force_calls: int
    n_cached: int = 0
    reach: SupercellReach | None = None
    primitive_matrix: NDArray[np.float64] | None = None

    def __repr__(self) -> str:
        size = "x".join(str(int(n)) for n in self.supercell)
        reduced = (self.primitive_matrix is not None and not np.allclose(self.primitive_matrix, np.eye(3)))
        edge = "" if self.reach is None or self.reach.holds_range else f"range exceeds the supercell ({self.reach.edge_ratio:.2g} at its edge)"
        return short_repr(self, repr(self.crystal.name), f"{size} supercell", f"step {self.step:g}",
                          f"{self.n_displacements} displacements", f"{self.n_force_calls} force calls",
                          f"{self.n_cached} cached" if self.n_cached else "",
                          "primitive cell of the cell given" if reduced else "", edge)

    def omega_errors(self, qpoints: ArrayLike) -> NDArray[np.float64]:
        """(n_q, n_branches) bound on how far each frequency moves under the force-constant error.

        First order: |Delta omega_k^2| <= |e_k|^H W |e_k| with W_(ia),(jb) = error_blocks[i, j, a, b]
        / sqrt(m_i m_j) (every phase has modulus 1, so W bounds |Delta D(q)| entry by entry);
        Delta omega = min(Delta omega^2 / (2 |omega|), sqrt(Delta omega^2)), plus the eigensolver's
        own `omega_error`; rad per ASE time unit. First order only, as for molecules: where branches
        lie closer together than the error couples them it may underestimate.
        """
        result = self.crystal.phonons(qpoints, vectors=True)
        assert result.vectors is not None
        n = self.crystal.n_atoms
        scale = 1.0 / np.sqrt(np.repeat(self.crystal.masses, 3))
        weight = self.error_blocks.transpose(0, 2, 1, 3).reshape(3 * n, 3 * n) * scale[:, None] * scale[None, :]
        d = np.abs(result.vectors)
        lam = np.einsum("qib,ij,qjb->qb", d, weight, d)
        omega = np.abs(result.omega)
        bound = np.minimum(lam / np.maximum(2.0 * omega, 1e-300), np.sqrt(lam))
        return np.asarray(bound + result.omega_error)


@dataclass(frozen=True)
class _Geometry:
    """One displaced supercell: the reference (atom -1) or atom `atom` moved by `vector`."""

    atom: int
    vector: tuple[float, float, float]

    @property
    def label(self) -> str:
        if self.atom < 0:
            return "the reference supercell"
        shown = ", ".join(f"{v:+.4g}" for v in self.vector)
        return f"supercell atom {self.atom} displaced by ({shown}) Angstrom"


def _moved(base: NDArray[np.float64]) -> Any:
    """The positions of each `_Geometry`: the reference supercell's `base`, one atom moved."""
    def positions(g: _Geometry) -> NDArray[np.float64]:
        moved = base.copy()
        if g.atom >= 0:
            moved[g.atom] += np.asarray(g.vector)
        return moved
    return positions


class _GeometryCache(ForceCache):
    """`ForceCache` keyed by the displaced geometry itself (atom and Cartesian vector)."""

    def path(self, displacement: Any) -> Any:
        key = hashlib.sha256(self.base)
        key.update(b"crystal supercell\0")
        if displacement.atom >= 0:
            key.update(np.int64(displacement.atom).tobytes())
            key.update(np.asarray(displacement.vector, dtype=np.float64).tobytes())
        return self.folder / f"{key.hexdigest()}.npy"


def _check_supercell(supercell: Any, periodic: tuple[bool, bool, bool], n_atoms: int) -> NDArray[np.int64]:
    raw = np.asarray(supercell)
    if raw.shape != (3,) or not np.issubdtype(raw.dtype, np.integer) or (raw < 1).any():
        raise ValueError(f"supercell must be 3 positive integers (cells along each lattice vector), got {supercell!r}")
    for axis in range(3):
        if not periodic[axis] and raw[axis] != 1:
            raise ValueError(f"supercell[{axis}] is {int(raw[axis])} along a vacuum axis (pbc False); it must be 1")
    atoms = math.prod(int(n) for n in raw) * n_atoms  # Python integers: no wrap-around
    if atoms > MAX_SUPERCELL_ATOMS:
        raise ValueError(f"supercell {[int(n) for n in raw]} holds {atoms} atoms, over the limit {MAX_SUPERCELL_ATOMS} "
                         f"(its full force constants would take {72 * atoms ** 2 / 1e9:.3g} GB); use a smaller supercell")
    return raw.astype(np.int64)


def finite_difference_force_constants(
    atoms: Atoms,
    calculator: CalculatorOption | None = None,
    *,
    supercell: Sequence[int],
    delta: float = 0.01,
    estimate_error: bool = True,
    force_noise: float | str | None = "auto",
    symprec: float = 1e-5,
    symmetry: bool | str = "auto",
    client: ClientOption = None,
    cache: str | os.PathLike[str] | None = None,
    calculator_key: str | None = None,
    progress: ProgressOption = None,
    n_workers: int | None = None,
    timeout: float = 10.0,
    primitive: bool = False,
    name: str | None = None,
    max_memory: float | None = None,
) -> FiniteDifferenceForceConstants:
    """Force constants of the crystal `atoms` from a calculator's forces on a supercell, with their error.

    Parameters
    ----------
    atoms : ase.Atoms
        The unit cell (with ``cell`` and ``pbc``), at equilibrium; Angstrom, amu. Not modified.
    calculator : ase Calculator or factory, optional
        ``atoms.calc`` by default; as for `vibra.molecules.finite_difference_hessian` (an instance
        is copied fresh for each call on a worker; a factory is called for each call).
    supercell : 3 ints
        Cells along each lattice vector (1 along a vacuum axis). The force constants reach as
        far as this supercell: choose it larger than the calculator's interaction range.
    delta : float
        Displacement h, Angstrom (ASE's and phonopy's 0.01 by default).
    estimate_error : bool
        Evaluate every displacement again at 2h for the Richardson truncation estimate (twice
        the force calls).
    force_noise : "auto", float or None
        As for molecules: probed (``"auto"``), given (eV / Angstrom) or rounding only (None).
    symprec : float
        spglib's tolerance for the space group, Angstrom.
    symmetry : "auto", True or False
        Reduce the displacements by the space group (phonopy's generator and solver). Its set-up
        costs ~0.1 s + n_ops x n_cells x n_supercell_atoms x 1.1 us (phonopy's atomic permutations,
        `SYMMETRY_SECONDS`);
        for a closed-form calculator (EMT, Lennard-Jones, ...: `DETERMINISTIC_CALCULATORS`) on a
        large supercell that exceeds the force calls it saves (`FORCE_SECONDS`: ASE's Al test,
        7x7x7, spent 6.2 s in the symmetry search for one displacement where six without it cost
        0.4 s). ``"auto"`` (default) estimates both from sizes and keeps the cheaper, and without
        the search averages the force constants over the space group (spglib's, to `symprec`),
        which gives what phonopy's symmetric solver would; any other calculator keeps the
        search (its force calls are the cost). ``False``: no search and no average (the raw
        finite differences, sum rules imposed).
    client, cache, calculator_key, progress, n_workers, timeout
        As for `vibra.molecules.finite_difference_hessian`: where the force calls run (None,
        ``"local"``, a scheduler address or a ``distributed.Client``), a folder of per-geometry
        force files (resumable), the calculator's settings for the cache key, progress lines.
    primitive : bool
        Reduce the cell to a primitive one first (phonopy's, found by symmetry; the matrix is
        kept in `FiniteDifferenceForceConstants.primitive_matrix`). Off by default: the crystal
        is the cell given, so fractional q mean the user's reciprocal basis (a conventional
        cube stays a cube). Not for a crystal with vacuum axes.
    name : str, optional
        The crystal's name (default: the chemical formula).
    max_memory : float, optional
        Bytes the run may hold at its peak (`vibra.crystals.fd_cost`: eight full supercell
        force-constant arrays, 72 n^2 bytes each, the symmetry search's permutations and the
        forces); None takes the solvers' `MEMORY_LIMIT` or the memory available,
        ``float("inf")`` none. Checked from sizes before phonopy builds the supercell; with
        ``progress=True`` the estimate (force calls, memory, and for a closed-form calculator
        the seconds) is printed first.

    Returns
    -------
    FiniteDifferenceForceConstants
        With `reach`: a supercell whose force constants reach its edge (blocks beyond half its
        shortest lattice vector above EDGE_RTOL of the largest) draws a `SupercellRangeWarning`
        naming the supercell that holds the range measured.

    Raises
    ------
    TypeError
        `atoms` is not an ase.Atoms; no calculator; a calculator that cannot be pickled with a
        `client` (pass a factory) or a `cache` (pass `calculator_key`).
    ValueError
        The checks of `Crystal.from_ase`; a supercell that is not 3 positive integers (or not 1
        along a vacuum axis), or so small that an atom's own images are no farther than its
        nearest neighbours (refused before any force call, naming the size needed); delta or
        symprec not positive; a bad `force_noise` or `client`; ``primitive=True`` with vacuum axes.
        `vibra.solvers.ResourceLimitError` (a ValueError): more memory than `max_memory`, naming
        the cells that would fit.
    RuntimeError
        The calculator failed, or returned forces that are not finite or of the wrong shape
        (each such geometry named; finished force calls stay in `cache`).
    """
    unit = Crystal.from_ase(atoms, name=name)
    calc = calculator_of(atoms, calculator)
    size = _check_supercell(supercell, unit.periodic, unit.n_atoms)
    check_range_from_sizes(unit, size)
    if primitive and not all(unit.periodic):
        raise ValueError(f"primitive=True with vacuum axes (pbc {tuple(unit.periodic)}): phonopy's primitive cell may "
                         "reorder the axes; pass the primitive cell itself (primitive=False)")
    h = _validate.positive_scalar(delta, "delta", "displacement (Angstrom)")
    precision = _validate.positive_scalar(symprec, "symprec", "symmetry tolerance (Angstrom)")
    if isinstance(force_noise, str):
        if force_noise != "auto":
            raise ValueError(f"force_noise is {force_noise!r}; expected a number (eV/Angstrom), 'auto' or None")
    elif force_noise is not None:
        force_noise = _validate.nonnegative_scalar(force_noise, "force_noise")
    check_client(client)
    source = calculator_source(calc, calculator_key, client)

    if symmetry not in ("auto", True, False):
        raise ValueError(f"symmetry is {symmetry!r}; expected 'auto', True or False")
    use_symmetry = symmetry is True
    operations = _space_group(unit, precision) if symmetry is not False else None
    n_ops = 1 if operations is None else len(operations["rotations"])
    cells = math.prod(int(n) for n in size)
    deterministic = is_deterministic_calculator(calc)
    if symmetry == "auto":
        use_symmetry = symmetry_pays(unit.n_atoms, cells, n_ops, deterministic)
        if not use_symmetry:  # the average must map every atom: checked now, before any force call
            try:
                _space_group_average(unit.with_force_constants(_NO_TERMS), operations, precision)
            except ValueError:
                use_symmetry = True

    steps = 2 if estimate_error else 1
    sizes = dict(n_ops=n_ops, symmetry=use_symmetry, steps=steps)
    bound = force_constants_cost(unit.n_atoms, cells, deterministic=deterministic, **sizes)
    check_memory(bound, supercell=[int(n) for n in size], n_unit=unit.n_atoms, max_memory=max_memory, **sizes)

    from phonopy import Phonopy  # at the edge: phonopy only when asked
    from phonopy.structure.atoms import PhonopyAtoms

    cell = PhonopyAtoms(cell=unit.cell, scaled_positions=unit.fractional, masses=unit.masses,
                        symbols=list(unit.symbols))
    # An explicit primitive matrix: phonopy >= 4 reads None as "auto" and would return another cell.
    with warnings.catch_warnings():  # phonopy 4 warns that "auto" is its new default: asked for here
        warnings.simplefilter("ignore")
        phonon = Phonopy(cell, supercell_matrix=np.diag(size), primitive_matrix="auto" if primitive else np.eye(3),
                         symprec=precision, is_symmetry=use_symmetry, log_level=0)
    phonon.generate_displacements(distance=h, is_plusminus="auto")
    first = phonon.dataset["first_atoms"]
    moves = [(int(d["number"]), np.asarray(d["displacement"], dtype=float)) for d in first]
    template = _supercell_atoms(phonon.supercell, unit.periodic)
    cost = force_constants_cost(unit.n_atoms, cells, deterministic=deterministic, n_moves=len(moves), **sizes)
    if progress is True:
        print(f"{unit.name}: {cost.describe()}", file=sys.stderr, flush=True)
    multiples = [1, 2] if estimate_error else [1]
    geometries = [_Geometry(-1, (0.0, 0.0, 0.0))]
    geometries += [_Geometry(atom, tuple(float(v) for v in m * vector))  # type: ignore[misc]
                   for m in multiples for atom, vector in moves]
    store = None if cache is None else _GeometryCache(cache, template, h, source.digest())
    with contextlib.ExitStack() as stack:
        cluster = ClientOnDemand(client, stack, n_workers, timeout)
        gathered = gather_forces(geometries, template, source, _moved(template.get_positions()), store, cluster,
                                 progress, name="vibra-crystal-fd")
        forces = gathered.forces
        floor = rounding_noise(max(float(np.abs(f).max()) for f in forces))
        noise = run_noise(force_noise, template, source, calc, forces[0], floor, cluster)
    sigma = noise.level(floor)
    reference = forces[0]
    n_moves = len(moves)
    raw = []
    for k, m in enumerate(multiples):
        block = forces[1 + k * n_moves: 1 + (k + 1) * n_moves]
        raw.append(_fit(phonon, moves, [f - reference for f in block], m))
    projected, report = impose_sum_rules(raw[0])
    truncation = np.abs(raw[0] - raw[1]) / 3.0 if estimate_error else np.zeros_like(raw[0])
    roundoff = float(sigma / h)
    entry_error = truncation + np.abs(projected - raw[0]) + roundoff
    reach = supercell_reach(phonon, projected, unit, size)
    if not reach.holds_range:
        warn_range(unit.name, size, reach)
    phonon.force_constants = projected
    crystal = Crystal.from_phonopy(phonon, name=unit.name, periodic=unit.periodic)
    if symmetry == "auto" and not use_symmetry:  # the space group's average, as phonopy's symmetric solver gives
        own = operations if not primitive else _space_group(crystal, precision)  # a primitive cell has its own
        crystal = crystal.with_force_constants(_space_group_average(crystal, own, precision))
    matrix = np.asarray(phonon.primitive_matrix, dtype=float)
    return FiniteDifferenceForceConstants(
        crystal=crystal, supercell=size, step=h, error_blocks=_fold(phonon, entry_error),
        truncation=float(truncation.max()), roundoff=roundoff, force_noise=float(sigma), noise_source=noise.source,
        sum_rules=report, n_displacements=n_moves, n_force_calls=gathered.computed, n_cached=gathered.cached,
        reach=reach, primitive_matrix=matrix)


def from_ase(atoms: Atoms, calculator: CalculatorOption | None = None, *, supercell: Sequence[int] | None = None,
             delta: float = 0.01, client: ClientOption = None, cache: str | os.PathLike[str] | None = None,
             calculator_key: str | None = None,
             progress: ProgressOption = None, wrap: bool = False, left_handed: bool = False,
             primitive: bool = False, name: str | None = None, max_memory: float | None = None) -> Crystal:
    """A `Crystal` from an `ase.Atoms`: the structure alone, or with force constants from a calculator.

    Without `calculator` and `supercell`: `Crystal.from_ase` (cell, positions, masses, symbols;
    `wrap`, `left_handed` as there). With them: the force constants of
    `finite_difference_force_constants` (displacements reduced by the space group, one force call
    per displaced supercell, sum rules imposed), without the 2h step and the noise probe; use
    that function for the error estimate. The crystal is the cell given (conventional stays
    conventional, ``pbc`` False stays a vacuum axis) unless ``primitive=True`` asks for
    phonopy's primitive cell.

    Raises
    ------
    ValueError
        A `calculator` without `supercell` (the message says so); the checks of both functions.

    Examples
    --------
    >>> from ase.build import bulk
    >>> from ase.calculators.emt import EMT
    >>> copper = from_ase(bulk("Cu", "fcc", a=3.61), EMT(), supercell=(3, 3, 3))
    >>> copper.n_branches, copper.units.name, bool(copper.frequencies([[0.0, 0.0, 0.0]]).max() < 1e-6)
    (3, 'ASE', True)
    """
    if calculator is None and supercell is None:
        return Crystal.from_ase(atoms, wrap=wrap, left_handed=left_handed, name=name)
    if supercell is None:
        raise ValueError("supercell is None; force constants from a calculator need supercell=(n1, n2, n3), "
                         "larger than the calculator's interaction range")
    return finite_difference_force_constants(
        atoms, calculator, supercell=supercell, delta=delta, estimate_error=False, force_noise=None,
        client=client, cache=cache, calculator_key=calculator_key, progress=progress, primitive=primitive,
        name=name, max_memory=max_memory).crystal


_NO_TERMS = ForceConstants(first=np.zeros(0, dtype=np.intp), second=np.zeros(0, dtype=np.intp),
                           translations=np.zeros((0, 3), dtype=np.int64), blocks=np.zeros((0, 3, 3)))

def _space_group(crystal: Crystal, symprec: float) -> Any:
    """spglib's operations of the cell (species told apart by symbol and mass), or None."""
    import spglib

    return spglib.get_symmetry((crystal.cell, crystal.fractional, species_numbers(crystal)), symprec=symprec)


def _space_group_average(crystal: Crystal, operations: Any, symprec: float) -> Any:
    """The crystal's force constants averaged over `operations` (spglib's), atoms matched within
    `symprec` (Angstrom, as spglib's) in fractional terms."""
    force_constants = crystal.require_force_constants()
    if operations is None:
        return force_constants
    atol = symprec / float(np.linalg.norm(crystal.cell, axis=1).min())
    return average_over_space_group(force_constants, crystal.cell, crystal.fractional, operations["rotations"],
                                    operations["translations"], atol=atol)


def _supercell_atoms(supercell: Any, periodic: tuple[bool, bool, bool]) -> Atoms:
    from ase import Atoms

    return Atoms(symbols=list(supercell.symbols), positions=np.asarray(supercell.positions, dtype=float),
                 cell=np.asarray(supercell.cell, dtype=float), masses=np.asarray(supercell.masses, dtype=float),
                 pbc=list(periodic))


def _fit(phonon: Any, moves: list[tuple[int, NDArray[np.float64]]], forces: list[NDArray[np.float64]],
         multiple: int) -> NDArray[np.float64]:
    """phonopy's full supercell force constants from the forces of one step multiple."""
    dataset = {"natom": len(phonon.supercell),
               "first_atoms": [{"number": atom, "displacement": multiple * vector, "forces": f}
                               for (atom, vector), f in zip(moves, forces)]}
    phonon.dataset = dataset
    phonon.produce_force_constants(calculate_full_force_constants=True)
    return np.array(phonon.force_constants, dtype=float)


def _fold(phonon: Any, entry_error: NDArray[np.float64]) -> NDArray[np.float64]:
    """(n_atoms, n_atoms, 3, 3): supercell entry errors summed over the images of each primitive pair."""
    primitive = phonon.primitive
    p2s = np.asarray(primitive.p2s_map)
    s2pp = np.array([primitive.p2p_map[s] for s in primitive.s2p_map])
    n = len(p2s)
    folded = np.zeros((n, n, 3, 3))
    for i, p in enumerate(p2s):
        np.add.at(folded[i], s2pp, entry_error[p])
    return folded
