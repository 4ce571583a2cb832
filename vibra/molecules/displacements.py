"""The displaced geometries of a finite-difference Hessian: their order, one force call, and the cache.

`finite_difference_hessian` evaluates the forces at a reference geometry and at displaced
ones; this module lists them (`displacement_plan`, always in the same order, which is the
order the Hessian is assembled in), evaluates one of them (`displaced_forces`: the function a
Dask worker runs), and keeps the results on disk (`ForceCache`).

Calculators (`CalculatorSource`)
--------------------------------
A calculator is given as an **instance** or as a **factory** (a class or a callable with no
arguments returning a new ASE calculator, e.g. ``functools.partial(TBLite, method="GFN2-xTB")``).
A factory is called for every force call, serially and on the workers, so every call starts
from scratch. An instance is used as it is in a serial run (as vibra always did); on a cluster
it is pickled once and every call on a worker unpickles a fresh copy, so that no result
depends on which calls ran before it on the same worker. For calculators whose result depends
on the previous call (tblite starts each SCF from the previous wavefunction) only a factory
gives the same numbers serially and on a cluster, bit for bit. A run on a cluster needs the
factory or the instance (which also carries whatever it computed before) to be picklable. Pickling uses cloudpickle when it is installed (it comes
with Dask): module-level functions, classes and ``functools.partial`` go by reference (the
workers import them), while lambdas and classes or functions defined in a script or notebook
go by value. An instance that
cannot be pickled (tblite after a calculation holds C objects) works serially; on a cluster
pass a factory instead.

The cache
---------
One ``<key>.npy`` file per geometry in the cache folder, written atomically
(`vibra._core.filesystem.atomic_write`) as soon as the forces arrive. The key is the SHA-256 of the
reference geometry (atomic numbers, positions, cell and periodic flags, as bytes), the
displacement (degree of freedom, sign and step multiple m: the stencil enters as the
multiples it evaluates, so a 4-point run reuses the +-h forces of a 2-point run on the same
geometry), the step h, and the calculator's settings: ``calculator_key`` when given, else
the pickled bytes of the factory (its qualified name and, for a ``functools.partial``, its
arguments) or of a copy of the instance after its ``reset()`` (ASE's `Calculator.reset`
forgets the last geometry and results): its class and settings (e.g. the force field of a
`ValenceForceField`), whether or not it computed anything before. The cache does not know the calculator's code or version: after
changing either, use a new folder. A run that also differentiates properties
(``properties=("dipole", "polarizability")``, `PROPERTY_ROWS`) stores their values as more
rows below the forces in the same file, and their names enter the key. A file is verified when read (it must load as a finite
``(n_atoms, 3)`` float64 array without pickles); a file that does not is recomputed and
replaced, with a `CacheWarning`.

A symmetry-reduced plan (`vibra.molecules.displacement_symmetry`) evaluates a subset of the
full plan's geometries under the same keys: a key names one geometry, whose forces do not
depend on which plan asked for them, so a reduced and a full run share those files, and only
evaluated forces are ever stored (rows rebuilt by symmetry never are).
"""

from __future__ import annotations

import hashlib
import io
import os
import copy
import pickle
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Protocol, Sequence, TypeVar, Union

import numpy as np
from numpy.typing import NDArray

from vibra._core.filesystem import atomic_write_bytes
from vibra.cluster import ClientOnDemand, ClientOption, ProgressOption, progress_callback, run_tasks

if TYPE_CHECKING:
    from ase import Atoms
    from ase.calculators.calculator import BaseCalculator

    class _Labelled(Protocol):
        """What `gather_forces` reads of a geometry itself: its label, in words (a molecule's
        `Displacement`, a crystal's moved atom); the rest is read by the caller's `positions`."""

        @property
        def label(self) -> str: ...

    #: One geometry of a finite-difference run, of the caller's kind.
    _Geometry = TypeVar("_Geometry", bound=_Labelled)

__all__ = ["Displacement", "displacement_plan", "displaced_positions", "displaced_forces", "force_problem",
           "CalculatorSource", "CalculatorOption", "ForceCache", "CacheWarning", "PROPERTY_ROWS", "property_rows",
           "GatheredForces", "gather_forces", "calculator_of", "calculator_source"]

#: What ``calculator=`` accepts (module docstring, "Calculators"): an ASE calculator instance
#: (`is_calculator`: anything with ``get_forces`` or ``get_property``), or a factory of one (a
#: class, or a callable with no arguments returning a new calculator).
CalculatorOption = Union["BaseCalculator", Callable[[], "BaseCalculator"]]

_AXES = "xyz"

#: Properties a finite difference can differentiate beside the forces, and the rows of 3 each adds
#: below the forces in one geometry's array: the dipole (e Angstrom, 1 row) and the polarisability
#: (Angstrom^3, a polarisability volume, 3 rows).
PROPERTY_ROWS = {"dipole": 1, "polarizability": 3}


def property_rows(properties: Sequence[str]) -> int:
    """Rows of 3 that `properties` (names in `PROPERTY_ROWS`) add below the forces."""
    return sum(PROPERTY_ROWS[name] for name in properties)


class CacheWarning(UserWarning):
    """A cache file was unreadable or did not hold the expected forces; it is recomputed."""


@dataclass(frozen=True)
class Displacement:
    """One geometry of a finite difference.

    Attributes
    ----------
    index : int
        Position in the evaluation order (0: the reference geometry).
    dof : int
        Displaced degree of freedom, 3 * atom + axis (-1: the reference geometry).
    multiple : int
        The displacement is `multiple` steps h (0 at the reference).
    sign : int
        +1 or -1 (0 at the reference).
    """

    index: int
    dof: int
    multiple: int
    sign: int

    @property
    def label(self) -> str:
        """The geometry in words: ``atom 1 displaced by +1h along y`` or ``the reference geometry``."""
        if self.dof < 0:
            return "the reference geometry"
        return (f"atom {self.dof // 3} displaced by {'+' if self.sign > 0 else '-'}{self.multiple}h "
                f"along {_AXES[self.dof % 3]}")


def displacement_plan(n_atoms: int, multiples: Sequence[int],
                      dofs: Sequence[int] | None = None) -> tuple[Displacement, ...]:
    """The reference, then for each dof (all, or those of `dofs`: a symmetry-reduced plan,
    `vibra.molecules.displacement_symmetry`) and each step multiple m: +m h, then -m h."""
    plan = [Displacement(0, -1, 0, 0)]
    for dof in (range(3 * n_atoms) if dofs is None else dofs):
        for m in multiples:
            for sign in (1, -1):
                plan.append(Displacement(len(plan), dof, int(m), sign))
    return tuple(plan)


def displaced_positions(positions: NDArray[np.float64], displacement: Displacement,
                        step: float) -> NDArray[np.float64]:
    """(n_atoms, 3) positions of one geometry, in Angstrom (the same arithmetic on every machine)."""
    if displacement.dof < 0:
        return np.array(positions, dtype=float)
    shift = np.zeros(positions.shape)
    shift.flat[displacement.dof] = displacement.multiple * step
    return positions + shift if displacement.sign > 0 else positions + -shift


def force_problem(values: NDArray[np.float64], n_atoms: int, label: str, rows: int = 0) -> str | None:
    """Why `values` are not usable forces of `n_atoms` atoms (and `rows` rows of properties below
    them, `property_rows`) at `label` (None when they are)."""
    if values.shape != (n_atoms + rows, 3):
        what = "forces" if not rows else "forces and properties"
        return f"calculator returned {what} of shape {values.shape} at {label}; expected ({n_atoms + rows}, 3)"
    bad = ~np.isfinite(values)
    if bad.any():
        a, c = (int(v) for v in np.argwhere(bad)[0])
        return f"calculator returned non-finite forces at {label}: forces[{a},{c}] = {values[a, c]!r}"
    return None


class CalculatorSource:
    """Where each force call gets its calculator: a factory, the instance, or a copy of it on a worker.

    In this process the instance itself is used (as a serial run always did); what is sent to
    a worker holds the instance's pickled bytes instead, and every call there unpickles a
    fresh copy. A factory is called for every call, here and on the workers.

    Parameters
    ----------
    calculator : ASE calculator or callable
        An ASE calculator instance, or a factory (a class or a callable with no arguments
        returning one).
    key : str, optional
        The calculator's settings for the cache key (overrides the pickled bytes).
    """

    def __init__(self, calculator: CalculatorOption, key: str | None = None) -> None:
        self.key = key
        self.factory: Any = calculator if is_factory(calculator) else None
        self.instance: Any = None if self.factory is not None else calculator
        self.blob: bytes | None = None       # the instance, pickled (made when first needed; hashed only)
        self.template: Any = None            # on a worker: the instance it copies for each call
        self.pickle_error = ""

    @property
    def kind(self) -> str:
        """``"factory"`` or ``"instance"``."""
        return "factory" if self.factory is not None else "instance"

    def _pickled(self) -> bytes:
        if self.blob is None:
            try:
                self.blob = _dumps(self.instance)
            except Exception as error:  # any pickling failure: the instance stays in this process
                self.pickle_error = f"{type(error).__name__}: {error}"
                raise TypeError(f"calculator cannot be pickled ({self.pickle_error})") from None
        return self.blob

    def make(self) -> BaseCalculator:
        """The calculator for one force call: the factory's new one, the instance, or a fresh copy of it."""
        if self.factory is not None:
            made = self.factory()
            if not is_calculator(made):
                raise TypeError(f"the calculator factory returned {type(made).__name__}, not an ASE calculator")
            return made
        if self.instance is not None:
            return self.instance
        assert self.template is not None  # a copy sent to a worker carries the instance as a template
        return copy.deepcopy(self.template)

    def require_picklable(self) -> None:
        """TypeError, saying what to do, for an instance that cannot be sent to workers."""
        if self.factory is not None:
            return
        try:
            self._pickled()
        except TypeError as error:
            raise TypeError(f"{error}, so it cannot be sent to workers; pass a factory instead, e.g. "
                            "calculator=functools.partial(TBLite, method='GFN2-xTB')") from None

    def digest(self) -> str:
        """SHA-256 (hex) of the calculator's settings, for the cache key."""
        if self.key is not None:
            return hashlib.sha256(b"key\0" + self.key.encode("utf-8")).hexdigest()
        try:
            if self.factory is not None:
                return hashlib.sha256(b"factory\0" + _dumps(self.factory)).hexdigest()
            self._pickled()                      # TypeError, as a worker would meet it, if it cannot travel
            settings = copy.deepcopy(self.instance)  # a copy, without its last geometry and results
            if callable(getattr(settings, "reset", None)):
                settings.reset()
            return hashlib.sha256(b"instance\0" + _dumps(settings)).hexdigest()
        except Exception as error:
            what = "the calculator factory" if self.factory is not None else "calculator"
            reason = str(error) if isinstance(error, TypeError) and self.factory is None else \
                f"{what} cannot be pickled ({type(error).__name__}: {error})"
            raise TypeError(f"{reason}; the cache needs calculator_key= naming its settings"
                            + (" (or pass a factory)" if self.factory is None else "")) from None

    def __getstate__(self) -> dict[str, object]:
        """What a worker gets: the factory, or the instance as a template it copies for each call."""
        self.require_picklable()
        state = dict(self.__dict__)
        state["template"] = self.instance if self.instance is not None else self.template
        state["instance"] = None
        return state


def _dumps(value: Any) -> bytes:
    """Pickled bytes of `value`: with cloudpickle when installed (it comes with Dask, and ships
    classes and functions defined in a script or notebook by value), else with pickle."""
    try:
        import cloudpickle  # type: ignore[import-untyped]
    except ImportError:
        return pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL)
    return bytes(cloudpickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL))


def is_calculator(value: object) -> bool:
    """Whether `value` is an ASE calculator instance (has get_forces or get_property)."""
    return not isinstance(value, type) and (hasattr(value, "get_forces") or hasattr(value, "get_property"))


def is_factory(value: object) -> bool:
    """Whether `value` is a calculator factory: a class, or a callable that is not a calculator."""
    return isinstance(value, type) or (callable(value) and not is_calculator(value))


def calculator_of(atoms: Atoms, calculator: CalculatorOption | None) -> CalculatorOption:
    """`calculator`, or ``atoms.calc`` when it is None: an ASE calculator or a factory of one (TypeError else)."""
    calc = calculator if calculator is not None else atoms.calc
    if calc is None:
        raise TypeError("calculator is None and atoms has no calculator attached; pass calculator=")
    if not is_calculator(calc) and not is_factory(calc):
        raise TypeError(f"calculator must be an ASE calculator or a factory returning one, got {type(calc).__name__}")
    return calc


def calculator_source(calc: CalculatorOption, calculator_key: str | None, client: ClientOption) -> CalculatorSource:
    """The `CalculatorSource` of a finite-difference run: `calculator_key` checked, and a calculator
    that a `client` would have to pickle checked for that."""
    if calculator_key is not None and not isinstance(calculator_key, str):
        raise TypeError(f"calculator_key must be a str, got {type(calculator_key).__name__}")
    source = CalculatorSource(calc, key=calculator_key)
    if client is not None:
        source.require_picklable()
    return source


def displaced_forces(atoms: Atoms, source: CalculatorSource, positions: NDArray[np.float64],
                     properties: Sequence[str] = ()) -> NDArray[np.float64]:
    """Forces (n_atoms, 3), eV / Angstrom, at `positions`, from a calculator in its initial state.

    The task each Dask worker runs (and the serial loop calls): `atoms` gives the numbers,
    cell and periodic flags, `positions` the geometry. With `properties` (names in
    `PROPERTY_ROWS`) their values from the same calculation follow the forces as more rows:
    the dipole ``atoms.get_dipole_moment()`` (e Angstrom) as one row, the polarisability
    ``calc.get_property("polarizability")`` (Angstrom^3) as three, in the order given.
    """
    work = atoms.copy()
    work.calc = source.make()
    work.set_positions(positions)
    forces = np.asarray(work.get_forces(), dtype=float)
    if not properties:
        return forces
    blocks = [forces]
    for name in properties:
        value = (work.get_dipole_moment() if name == "dipole" else work.calc.get_property(name, work))
        array = np.asarray(value, dtype=float)
        if array.size != 3 * PROPERTY_ROWS[name]:
            raise ValueError(f"the calculator's {name} has shape {array.shape}; expected "
                             f"{(3,) if name == 'dipole' else (3, 3)}")
        blocks.append(array.reshape(PROPERTY_ROWS[name], 3))
    return np.vstack(blocks)


class ForceCache:
    """The per-geometry force files of one finite-difference run (see the module docstring).

    Parameters
    ----------
    folder : path-like
        The cache folder (created when the first file is written).
    atoms : ase.Atoms
        The reference geometry.
    step : float
        h, Angstrom.
    calculator_digest : str
        `CalculatorSource.digest`.
    properties : sequence of str
        Properties stored below the forces (`displaced_forces`); they enter the key, so a file
        of forces alone is never read as one with properties.
    """

    def __init__(self, folder: str | os.PathLike[str], atoms: Atoms, step: float, calculator_digest: str,
                 properties: Sequence[str] = ()) -> None:
        self.folder = Path(folder)
        self.n_atoms = len(atoms)
        self.rows = property_rows(properties)
        geometry = hashlib.sha256(b"vibra finite-difference cache 1\0")
        geometry.update(np.ascontiguousarray(atoms.get_atomic_numbers(), dtype=np.int64).tobytes())
        geometry.update(np.ascontiguousarray(atoms.get_positions(), dtype=np.float64).tobytes())
        geometry.update(np.ascontiguousarray(atoms.cell.array, dtype=np.float64).tobytes())
        geometry.update(np.ascontiguousarray(atoms.pbc, dtype=np.bool_).tobytes())
        geometry.update(calculator_digest.encode("ascii"))
        if properties:  # (forces alone keep the keys they always had)
            geometry.update(("\0properties " + ",".join(properties)).encode("ascii"))
        self.base = geometry.digest()
        self.step = float(step)

    def path(self, displacement: Displacement) -> Path:
        """The file of one geometry."""
        key = hashlib.sha256(self.base)
        if displacement.dof >= 0:  # the reference geometry does not depend on the step
            key.update(np.float64(self.step).tobytes())
            key.update(f"\0{displacement.dof},{displacement.multiple},{displacement.sign}".encode("ascii"))
        return self.folder / f"{key.hexdigest()}.npy"

    def load(self, displacement: Displacement) -> NDArray[np.float64] | None:
        """The cached forces of one geometry, verified; None when absent or unusable."""
        path = self.path(displacement)
        if not path.is_file():
            return None
        try:
            with open(path, "rb") as handle:  # the header first: a file declaring 10^9 values is not read
                version = np.lib.format.read_magic(handle)
                shape, _, dtype = (np.lib.format.read_array_header_1_0(handle) if version == (1, 0)
                                   else np.lib.format.read_array_header_2_0(handle))
            if shape != (self.n_atoms + self.rows, 3) or np.dtype(dtype) != np.float64:
                warnings.warn(f"{path}: cache file declares {np.dtype(dtype)} {shape}, not "
                              f"({self.n_atoms + self.rows}, 3) float64 forces; recomputing {displacement.label}",
                              CacheWarning, stacklevel=3)
                return None
            values = np.load(path, allow_pickle=False)
        except (OSError, ValueError, EOFError) as error:
            warnings.warn(f"{path}: unreadable cache file ({error}); recomputing {displacement.label}",
                          CacheWarning, stacklevel=3)
            return None
        if values.dtype != np.float64 or force_problem(values, self.n_atoms, displacement.label,
                                                       self.rows) is not None:
            warnings.warn(f"{path}: cache file holds {values.dtype} {values.shape}, not finite "
                          f"({self.n_atoms + self.rows}, 3) "
                          f"float64 forces; recomputing {displacement.label}", CacheWarning, stacklevel=3)
            return None
        return np.asarray(values, dtype=np.float64)

    def store(self, displacement: Displacement, forces: NDArray[np.float64]) -> Path:
        """Write the forces of one geometry atomically."""
        buffer = io.BytesIO()
        np.save(buffer, np.ascontiguousarray(forces, dtype=np.float64), allow_pickle=False)
        return atomic_write_bytes(self.path(displacement), buffer.getvalue())


@dataclass(frozen=True)
class GatheredForces:
    """The forces of every geometry of a finite-difference run (`gather_forces`)."""

    forces: tuple[NDArray[np.float64], ...]   # one array per geometry, in the order asked
    computed: int                              # force calls made in this run
    cached: int                                # geometries read from the cache


def gather_forces(geometries: Sequence[_Geometry], template: Atoms, source: CalculatorSource,
                  positions: Callable[[_Geometry], NDArray[np.float64]], store: ForceCache | None,
                  cluster: ClientOnDemand, progress: ProgressOption, *, properties: tuple[str, ...] = (),
                  check_reference: Callable[[NDArray[np.float64]], None] | None = None,
                  name: str = "vibra-fd") -> GatheredForces:
    """Forces (and the `properties` below them) at every geometry: from the cache, in this process, or
    one Dask task each on `cluster`; the molecules' and the crystals' finite differences.

    Each geometry has a ``label`` and is the key of `store`; `positions(geometry)` is where its atoms
    are. The first geometry is the reference: `check_reference` sees its forces as soon as they
    are read or computed. A calculator that raises or returns unusable forces (`force_problem`) is
    a RuntimeError naming each geometry, and saying what the cache kept.
    """
    n = len(template)
    rows = property_rows(properties)
    found: dict[int, NDArray[np.float64]] = {}
    if store is not None:
        for k, g in enumerate(geometries):
            values = store.load(g)
            if values is not None:
                found[k] = values
    if 0 in found and check_reference is not None:
        check_reference(found[0][:n])
    missing = [k for k in range(len(geometries)) if k not in found]
    n_cached = len(found)

    def kept() -> str:
        if store is None:
            return " (pass cache= to keep the finished force calls of a run)"
        return (f" ({len(found)} finished force call(s) kept in the cache {str(store.folder)!r}; "
                "a rerun computes only the rest)")

    def accept(k: int, values: NDArray[np.float64]) -> str | None:
        problem = force_problem(values, n, geometries[k].label, rows)
        if problem is not None:
            return problem
        if store is not None:
            store.store(geometries[k], values)
        found[k] = values
        if k == 0 and check_reference is not None:
            check_reference(values[:n])
        return None

    if missing and cluster.client is None:
        callback = progress_callback(progress, len(missing))
        for done, k in enumerate(missing, start=1):
            label = geometries[k].label
            try:
                values = displaced_forces(template, source, positions(geometries[k]), properties)
            except Exception as error:
                raise RuntimeError(f"calculator failed at {label}: {type(error).__name__}: {error}"
                                   + kept()) from error
            problem = accept(k, values)
            if problem is not None:
                raise RuntimeError(problem + kept())
            if callback is not None:
                callback(done, len(missing), label)
    elif missing:
        problems: list[str] = []

        def on_result(i: int, values: NDArray[np.float64]) -> None:
            problem = accept(missing[i], values)
            if problem is not None:
                problems.append(problem)

        _, failures = run_tasks(
            cluster.get(), displaced_forces,
            [(template, source, positions(geometries[k]), properties) for k in missing],
            labels=[geometries[k].label for k in missing], on_result=on_result, progress=progress, name=name)
        problems.extend(f"calculator failed at {f.describe()}" for f in failures)
        if problems:
            raise RuntimeError(f"{len(problems)} of {len(geometries)} force calls failed: " + "; ".join(problems)
                               + kept())
    return GatheredForces(forces=tuple(found[k] for k in range(len(geometries))), computed=len(missing),
                          cached=n_cached)
