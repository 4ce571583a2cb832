"""Band structures along high-symmetry paths: SeeK-path's, or a given one with labels.

The automatic path is SeeK-path's (HPKOT recipe) for the crystal's own cell:
``seekpath.get_path_orig_cell`` finds the standardised primitive cell, takes its path, and
converts the special points back to fractional coordinates of *this* crystal's reciprocal
lattice (through the rotation and transformation spglib reports), so every q here is in the
user's basis. For a supercell (a cell that is not primitive) the path is the primitive cell's
path written in the supercell's reciprocal basis (its bands are folded). For 2-D and 1-D
crystals only the segments whose ends lie in the plane (or line) of the periodic axes are kept.

Branches are connected across crossings by eigenvector overlap: at each step the branches
of the previous q-point are matched to those of the next by the assignment that maximises
sum |<e_prev|e_next>|^2 (scipy's linear_sum_assignment). At a degeneracy the eigenvectors
are first rotated to diagonalise dD/dk along the segment (degenerate perturbation theory), so
the branches leaving a crossing keep their identity. Group velocities along the path come
from the same analytic dD/dk (`vibra.crystals.dynamical.derivative_matrices`).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

from vibra._core import validate as _validate
from vibra._core.frozen import frequency_span
from vibra._results import Result, stored
from vibra.crystals.dynamical import derivative_matrices, phonons
from vibra.crystals.velocities import eigenvalue_slopes
from vibra.units import UnitSystem

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from vibra._results.display import View
    from vibra.crystals.force_constants import CrystalLike as Crystal  # the protocol: no import cycle

__all__ = ["BandStructure", "band_structure", "special_points", "ALIASES"]

#: Other spellings of SeeK-path's labels.
ALIASES: dict[str, str] = {"G": "GAMMA", "Γ": "GAMMA", "\\Gamma": "GAMMA"}

#: Most q-points a band structure takes (a bound before any allocation).
MAX_POINTS = 1_000_000
#: Complex entries of eigenvectors per chunk of a path (~256 KiB; D(q), dD/dk and their solves
#: take a few times that), and at least `PATH_CHUNK_POINTS` q-points (each chunk is one
#: `phonons` call): the band structure's memory is bounded by the chunk, not by the path.
PATH_CHUNK = 1 << 14
PATH_CHUNK_POINTS = 64


@dataclass(frozen=True, eq=False, repr=False)
class BandStructure(Result):
    """Phonon bands along a path in reciprocal space (a `vibra._results.Result` over its q-points).

    A slice keeps a contiguous run of q-points (``bands[40:80]``; a step, an index array or a
    mask with gaps is refused), with the segments cut to it and the labels and breaks inside it,
    their indices counted from its first q-point; `distances` keep their values.

    Attributes
    ----------
    qpoints : (n_q, 3) ndarray
        Wave vectors, fractional coordinates of the crystal's reciprocal lattice. Each segment
        holds both its ends (a label point appears twice where two segments meet).
    distances : (n_q,) ndarray
        Cumulative Cartesian path length, in rad / length (no length is added across a break).
    omega : (n_q, n_branches) ndarray
        Angular frequencies, branches connected by eigenvector overlap (column b is one branch
        along each continuous run), in rad per time unit; imaginary as -|omega|.
    omega_error : (n_q, n_branches) ndarray
        Error bounds of `omega`, same order.
    velocities : (n_q, n_branches) ndarray
        Group velocity d omega / dk along the segment's direction, in length per time unit (0 for
        an acoustic branch at Gamma, where it depends on the direction of approach).
    segments : (n_segments, 2) ndarray of int
        First and last index (inclusive) of each segment in `qpoints`.
    labels : tuple of (int, str)
        Index into `qpoints` and label of each special point on the path.
    breaks : tuple of int
        Indices where a new continuous run starts (a discontinuity of the path), 0 excluded.
    units : UnitSystem
        The crystal's units.
    path : str
        How the frequencies were solved (`Phonons.path`: ``" + spring-svd"`` where some q-points were re-solved).
    """

    STORED = {"qpoints": stored(("n_q", 3)), "distances": stored(("n_q",)),  # how save / load check them
              "omega": stored(("n_q", "n_branches")), "omega_error": stored(("n_q", "n_branches")),
              "velocities": stored(("n_q", "n_branches")), "segments": stored(("n_segments", 2), kind="int")}
    AXIS, NOUNS = "n_q", ("q-point", "q-points")

    qpoints: NDArray[np.float64]
    distances: NDArray[np.float64]
    omega: NDArray[np.float64]
    omega_error: NDArray[np.float64]
    velocities: NDArray[np.float64]
    segments: NDArray[np.int64]
    labels: tuple[tuple[int, str], ...]
    breaks: tuple[int, ...]
    units: UnitSystem
    path: str = "hermitian-eigh"

    def _repr_parts(self) -> tuple[str, ...]:
        along = ""
        for k, (index, label) in enumerate(self.labels):
            if k:
                along += "|" if index in self.breaks and self.labels[k - 1][0] == index - 1 else "-"
            along += "Γ" if label == "GAMMA" else label
        return (f"{self._size()} x {self.omega.shape[1]} branches", "along " + along if along else "",
                frequency_span(self.omega, self.units))

    def _sliced(self, chosen: NDArray[np.intp]) -> dict[str, Any]:
        """The segments, labels and breaks of a contiguous run of q-points, counted from its first."""
        if np.any(np.diff(chosen) != 1):
            raise IndexError("a BandStructure is sliced by a contiguous run of q-points (step 1): its segments, "
                             "labels and breaks index them")
        start, stop = (int(chosen[0]), int(chosen[-1]) + 1) if chosen.size else (0, 0)
        low, high = np.maximum(self.segments[:, 0], start), np.minimum(self.segments[:, 1], stop - 1)
        keep = low <= high
        return {"segments": np.stack([low[keep], high[keep]], axis=1) - start,
                "labels": tuple((k - start, label) for k, label in self.labels if start <= k < stop),
                "breaks": tuple(k - start for k in self.breaks if start < k < stop)}

    @classmethod
    def _from_stored(cls, values: dict[str, Any], where: Callable[[str], str]) -> BandStructure:
        """A stored band structure whose segments, labels and breaks index its q-points."""
        n_q = len(values["qpoints"])
        segments = values["segments"]
        if segments.size and (segments.min() < 0 or segments.max() >= n_q or np.any(segments[:, 0] > segments[:, 1])):
            raise ValueError(f"{where('segments')} holds {segments.tolist()[:4]}...; expected (first, last) index "
                             f"pairs, first <= last, into the {n_q} q-points")
        for key, indices in (("labels", [k for k, _ in values["labels"]]), ("breaks", values["breaks"])):
            if any(not 0 <= k < n_q for k in indices):
                raise ValueError(f"{where(key)} holds an index outside the {n_q} q-points ({list(indices)[:6]})")
        return cls(**values)

    def frequencies_thz(self) -> NDArray[np.float64]:
        """(n_q, n_branches) signed ordinary frequencies, in THz."""
        return self.units.omega_to_thz(self.omega)

    def wavenumbers_cm1(self) -> NDArray[np.float64]:
        """(n_q, n_branches) signed wavenumbers, in cm^-1."""
        return self.units.omega_to_cm1(self.omega)

    def show(self, crystal: Crystal, *, unit: str = "THz") -> View:
        """The interactive view of these bands (`vibra.crystals.animation.bands_view`): click a point
        (q, branch) to animate that branch's mode on a supercell; in Jupyter, the cell's value shows it
        (offline: 3Dmol.js, about 530 kB, is inlined once per output).

        Parameters
        ----------
        crystal : Crystal
            The crystal these bands were computed from (its cell, atoms and force constants).
        unit : {"THz", "cm^-1"}
            The unit of the band axis.
        """
        from vibra.crystals.animation import bands_view  # (same layer; loaded only to draw)

        return bands_view(crystal, self, unit=unit)


# ---------------------------------------------------------------------- special points
def special_points(crystal: Crystal) -> tuple[dict[str, NDArray[np.float64]], list[list[str]]]:
    """SeeK-path's special points (fractional, this crystal's reciprocal basis) and its path as runs of labels.

    For a crystal with vacuum axes, only points in the periodic plane (or line) are kept, and
    only the segments between two of them.
    """
    import seekpath  # at the edge: only for an automatic path

    from vibra.crystals.mesh import species_numbers, symmetry_cell  # (points are fractional: the cell's scale does not matter)

    structure = (symmetry_cell(crystal).tolist(), crystal.fractional.tolist(), species_numbers(crystal))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # SupercellWarning, EdgeCaseWarning: documented above
        found = seekpath.get_path_orig_cell(structure, with_time_reversal=True)
    points = {label: np.asarray(coords, dtype=float) for label, coords in found["point_coords"].items()}
    vacuum = [axis for axis in range(3) if not crystal.periodic[axis]]
    if vacuum:
        points = {label: q for label, q in points.items() if np.allclose(q[vacuum], 0.0, atol=1e-9)}
    runs: list[list[str]] = []
    for start, end in found["path"]:
        if start not in points or end not in points:
            continue
        if runs and runs[-1][-1] == start:
            runs[-1].append(end)
        else:
            runs.append([start, end])
    if not runs:
        raise ValueError(f"SeeK-path gives no path in the periodic directions of {crystal.name!r}; give path= "
                         "and points= explicitly")
    return points, runs


def _check_path(path: Any, points: Mapping[str, Any] | None, crystal: Crystal
                ) -> tuple[list[list[str]], dict[str, NDArray[np.float64]]]:
    table: dict[str, NDArray[np.float64]] = {}
    if points is not None:
        if not isinstance(points, Mapping):
            raise TypeError(f"points must be a mapping label -> fractional q, got {type(points).__name__}")
        for label, q in points.items():
            value = _validate.real_array(q, f"points[{label!r}]", ndim=1)
            if value.shape != (3,):
                raise ValueError(f"points[{label!r}] must hold 3 fractional coordinates, got shape {value.shape}")
            table[str(label)] = value
    if path is None:
        auto, runs = special_points(crystal)
        return runs, {**auto, **table}
    if isinstance(path, str) or not isinstance(path, Sequence) or not path:
        raise TypeError("path must be a list of runs, each a list of point labels, e.g. [['GAMMA', 'X', 'W']]")
    runs = []
    for r, run in enumerate(path):
        if isinstance(run, str) or not isinstance(run, Sequence) or len(run) < 2:
            raise ValueError(f"path[{r}] must be a list of at least 2 point labels, got {run!r}")
        runs.append([str(label) for label in run])
    missing = [(r, k, label) for r, run in enumerate(runs) for k, label in enumerate(run)
               if label not in table and ALIASES.get(label, label) not in table]
    if missing:
        try:
            auto, _ = special_points(crystal)
        except ValueError:
            auto = {}
        table = {**auto, **table}
        for r, k, label in missing:
            if label not in table and ALIASES.get(label, label) not in table:
                known = ", ".join(sorted(table)) or "none"
                raise ValueError(f"path[{r}][{k}] is {label!r}, not a known point of {crystal.name!r}; "
                                 f"known points: {known} (or give its coordinates in points=)")
    return runs, {label: table[label] if label in table else table[ALIASES[label]]
                  for run in runs for label in run}


# ---------------------------------------------------------------------- bands
def band_structure(crystal: Crystal, path: Sequence[Sequence[str]] | None = None, *, npoints: int = 200,
                   points: Mapping[str, ArrayLike] | None = None) -> BandStructure:
    """Phonon bands along `path` (SeeK-path's when None), branches connected, with group velocities.

    Parameters
    ----------
    crystal : Crystal
        With force constants.
    path : list of runs of labels, optional
        e.g. ``[["GAMMA", "X", "W", "K", "GAMMA", "L"]]``; a new run starts after a break.
        Labels are SeeK-path's for this crystal (``"G"`` and ``"Γ"`` also mean ``"GAMMA"``) or
        keys of `points`.
    npoints : int
        q-points in all, shared among segments by length (at least 2 per segment).
    points : mapping label -> (3,) fractional q, optional
        Extra or overriding special points.

    Raises
    ------
    ValueError
        A label that is neither SeeK-path's nor in `points`; a run of fewer than 2 labels;
        npoints smaller than 2 per segment; a crystal without force constants.
    """
    crystal.require_force_constants()
    runs, table = _check_path(path, points, crystal)
    n_segments = sum(len(run) - 1 for run in runs)
    total = _validate.count(npoints, "npoints", low=2 * n_segments, high=MAX_POINTS)
    reciprocal = crystal.reciprocal
    ends = [(run[k], run[k + 1], r) for r, run in enumerate(runs) for k in range(len(run) - 1)]
    lengths = np.array([np.linalg.norm((table[b] - table[a]) @ reciprocal) for a, b, _ in ends])
    share = np.maximum(2, np.floor(lengths / max(lengths.sum(), 1e-300) * total + 0.5).astype(int))
    while share.sum() > total:  # rounding up to 2 per segment can overshoot
        share[int(np.argmax(share))] -= 1
    qs, dist, segments, labels, breaks, directions = [], [], [], [], [], []
    offset, position = 0, 0.0
    previous_run = -1
    for (a, b, r), n, length in zip(ends, share, lengths):
        t = np.linspace(0.0, 1.0, n)
        qs.append(table[a] + t[:, None] * (table[b] - table[a]))
        if r != previous_run and previous_run >= 0:
            breaks.append(offset)
        if r != previous_run or not labels or labels[-1][1] != a:
            labels.append((offset, a))
        dist.append(position + t * length)
        position += length
        labels.append((offset + n - 1, b))
        segments.append((offset, offset + n - 1))
        direction = (table[b] - table[a]) @ reciprocal
        directions.append(direction / length if length > 0 else np.array([1.0, 0.0, 0.0]))
        offset += n
        previous_run = r
    qpoints = np.vstack(qs)
    omega, error, velocity, order, paths = _solve_path(crystal, qpoints, segments, directions, set(breaks))
    rows = np.arange(len(qpoints))[:, None]
    return BandStructure(qpoints=qpoints, distances=np.concatenate(dist), omega=omega[rows, order],
                         omega_error=error[rows, order], velocities=velocity[rows, order],
                         segments=np.array(segments, dtype=np.int64),
                         labels=tuple((int(k), label) for k, label in labels), breaks=tuple(int(k) for k in breaks),
                         units=crystal.units, path=max(paths, key=len))


def _solve_path(crystal: Crystal, qpoints: NDArray[np.float64], segments: list[tuple[int, int]],
                directions: list[NDArray[np.float64]], breaks: set[int]
                ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.intp], list[str]]:
    """omega, omega_error, velocities (solver order), the branch order, in chunks of `PATH_CHUNK` entries,
    and the paths of the chunks' solves (`Phonons.path`, each once).

    Each chunk of the path is solved with eigenvectors, rotated by dD/dk along each segment it
    meets, then connected to the previous q-point; only the previous q-point's eigenvectors outlive
    a chunk, so memory is bounded by the chunk, not by the path (the eigenvectors of the
    whole path are never held at once).
    """
    n3 = crystal.n_branches
    step = max(PATH_CHUNK_POINTS, PATH_CHUNK // (n3 * n3))
    omega = np.empty((len(qpoints), n3))
    error = np.empty_like(omega)
    velocity = np.empty_like(omega)
    order = np.empty((len(qpoints), n3), dtype=np.intp)
    previous: NDArray[np.complex128] | None = None  # eigenvectors of the last q-point, in branch order
    paths: dict[str, None] = {}
    for start in range(0, len(qpoints), step):
        chunk = slice(start, min(len(qpoints), start + step))
        result = phonons(crystal, qpoints[chunk], vectors=True)
        omega[chunk], error[chunk] = result.omega, result.omega_error
        paths[result.path] = None
        basis = np.array(result.vectors)
        del result
        if crystal.nac is not None:  # a polar crystal's Gamma: the LO-TO split of the direction of the path
            _gamma_along_path(crystal, qpoints, chunk, segments, omega, error, basis)
        for (first, last), direction in zip(segments, directions):  # the segments this chunk meets
            low, high = max(first, chunk.start), min(last + 1, chunk.stop)
            if low >= high:
                continue
            part, local = slice(low, high), slice(low - start, high - start)
            values = np.sign(omega[part]) * omega[part] ** 2
            value_error = 2.0 * np.abs(omega[part]) * error[part] + error[part] ** 2
            derivative = derivative_matrices(crystal, qpoints[part], direction)
            slopes, basis[local] = eigenvalue_slopes(derivative, values, basis[local], value_error)
            del derivative
            zero = np.abs(omega[part]) <= error[part]
            velocity[part] = np.where(zero, 0.0, slopes / np.where(zero, 1.0, 2.0 * omega[part]))
        order[chunk], previous = _connect(basis, {k - start for k in breaks if k >= start}, previous)
    return omega, error, velocity, order, list(paths)


def _gamma_along_path(crystal: Crystal, qpoints: NDArray[np.float64], chunk: slice, segments: list[tuple[int, int]],
                      omega: NDArray[np.float64], error: NDArray[np.float64], basis: NDArray[np.complex128]) -> None:
    """Re-solve the Gamma points of `chunk` (any point equal to a reciprocal lattice vector, at the ends
    of a segment or inside it) with the direction of their segment (phonopy's nac_q_direction)."""
    for first, last in segments:
        direction = qpoints[last] - qpoints[first]
        low, high = max(first, chunk.start), min(last + 1, chunk.stop)
        if low >= high or not np.any(direction):
            continue
        part = qpoints[low:high]
        for k in low + np.nonzero(np.abs(part - np.rint(part)).max(axis=1) <= 1e-12)[0]:
            result = phonons(crystal, qpoints[k:k + 1], vectors=True, q_direction=direction)
            omega[k], error[k] = result.omega[0], result.omega_error[0]
            basis[k - chunk.start] = np.asarray(result.vectors)[0]


def _connect(basis: NDArray[np.complex128], breaks: set[int], previous: NDArray[np.complex128] | None
             ) -> tuple[NDArray[np.intp], NDArray[np.complex128]]:
    """(n_q, n) column order (order[k, b]: the eigenpair of q-point k on branch b), and the last
    q-point's eigenvectors in that order.

    Ascending at the start of each run (`previous` None, or k in `breaks`); afterwards each
    branch follows the eigenvector of largest overlap with its own at the previous q-point
    (`previous` for k = 0: the last q-point of the chunk before; an assignment, so no two
    branches take the same one).
    """
    n_q, _, n = basis.shape
    order = np.empty((n_q, n), dtype=np.intp)
    for k in range(n_q):
        if previous is None or k in breaks:
            order[k] = np.arange(n)
        else:
            overlap = np.abs(previous.conj().T @ basis[k]) ** 2
            _, columns = linear_sum_assignment(-overlap)
            order[k] = columns
        previous = basis[k][:, order[k]]
    assert previous is not None
    return order, previous.copy()
