"""The view data of a crystal's bands with their modes: click a point (q, branch), see it move on a supercell.

`band_view` gives the ``"crystal"`` view data of `vibra._results.display` (the report's crystal
pages and ``bands.show(crystal)`` in a notebook): the bands in the chosen unit, and at every
stored q-point of the path the displacement pattern u_j = e_j / sqrt(m_j) of each branch, from
vibra's own solve at that q (`vibra.crystals.dynamical.phonons`, in the branch order of the band
structure; a polar crystal's Gamma with the LO-TO split of its segment's direction, as the
bands). The page animates atom j of cell R as

    r(t) = R + x_j + scale * Re[u_j exp(2 pi i q . (R + x_j)) exp(-i phi)],  phi = 2 pi t / n_frames,

one period in `FRAMES` frames. The Bloch phase uses the atom's position, R + x_j, because the
eigenvectors are in the ``"positions"`` phase, phonopy's: its D(q) sums exp(iq.[r(j'l') - r(j0)])
(https://phonopy.github.io/phonopy/formulation.html, "Dynamical matrix") and its modulation
multiplies by exp(2 pi i q . r) of the atom in the supercell (``phonopy.phonon.modulation``). The
``"cell"`` phase (exp(iq.R) alone) would take exp(2 pi i q . R) instead; the two patterns are the
same (`vibra.crystals.supercell_mode` works in the cell phase; the tests compare both with
phonopy's `Phonopy.run_modulations`).

An imaginary mode (omega < 0, vibra's sign for omega^2 < 0) does not oscillate: it grows
as exp(|omega| t). It is drawn as its static pattern growing from rest, scale * s * Re[u ... e^{i
theta}] for s from 0 to 1 (played back and forth), with theta the global phase that makes the
real pattern largest, and labelled imaginary.

Supercell (`repeats`): along each periodic axis enough cells for one wavelength of q,
ceil(1 / |q_i|) (q reduced into [-1/2, 1/2]), at least `MIN_REPEATS` and at most `MAX_REPEATS`,
with the largest axes shrunk until the supercell holds at most `MAX_ATOMS` atoms. `frame_positions`
computes the frames from the view data with the same sums as the page's script.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._results.display import MAX_MOTION, View
from vibra.crystals.dynamical import phonons

if TYPE_CHECKING:
    from vibra.crystals.force_constants import CrystalLike as Crystal  # the protocol: no import cycle


class BandsLike(Protocol):
    """What the view reads of a `vibra.crystals.BandStructure` (for type checkers only:
    `BandStructure.show` imports this module, and the two stay out of an import cycle, even
    for type checking, as `CrystalLike` keeps the package's)."""

    @property
    def qpoints(self) -> NDArray[np.float64]: ...

    @property
    def distances(self) -> NDArray[np.float64]: ...

    @property
    def omega(self) -> NDArray[np.float64]: ...

    @property
    def segments(self) -> NDArray[np.int64]: ...

    @property
    def labels(self) -> tuple[tuple[int, str], ...]: ...

    @property
    def breaks(self) -> tuple[int, ...]: ...

    def frequencies_thz(self) -> NDArray[np.float64]: ...

    def wavenumbers_cm1(self) -> NDArray[np.float64]: ...


__all__ = ["band_view", "bands_view", "frame_positions", "repeats", "FRAMES", "MAX_REPEATS", "MIN_REPEATS",
           "MAX_ATOMS", "MAX_VECTOR_NUMBERS", "UNITS"]

#: Frames of one period (an oscillation) or of the growth from rest (an imaginary mode).
FRAMES = 24
#: Cells along a periodic axis: at least (the mode's context), at most (a long wavelength is cut).
MIN_REPEATS, MAX_REPEATS = 2, 8
#: Most atoms in a supercell drawn (24 frames of 400 atoms animate smoothly in a software-rendered browser).
MAX_ATOMS = 400
#: Most numbers of displacement patterns the view data holds (2 per complex entry, n_q x (3n)^2 x 2):
#: beyond it only every s-th q-point of the path keeps its patterns (a click picks the nearest).
MAX_VECTOR_NUMBERS = 120_000
#: Frequency units of the band axis.
UNITS = ("THz", "cm^-1")


def repeats(crystal: Crystal, q: ArrayLike) -> NDArray[np.int64]:
    """(3,) cells along each lattice vector that show one wavelength of `q` (module docstring)."""
    reduced = np.abs(np.asarray(q, dtype=float) - np.rint(q))
    out = np.ones(3, dtype=np.int64)
    for axis in range(3):
        if crystal.periodic[axis]:
            need = math.ceil(1.0 / reduced[axis] - 1e-9) if reduced[axis] > 1e-9 else 1
            out[axis] = min(MAX_REPEATS, max(MIN_REPEATS, need))
    while int(out.prod()) * crystal.n_atoms > MAX_ATOMS and out.max() > 1:
        out[int(np.argmax(out))] -= 1
    return out


def _shortest_distance(crystal: Crystal) -> float:
    """The shortest distance between two atoms (periodic images included), in the length unit."""
    shifts = np.array([(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1)], dtype=float)
    images = (shifts @ crystal.cell)[:, None, :] + crystal.positions[None, :, :]
    gaps = np.linalg.norm(images[None, :, :, :] - crystal.positions[:, None, None, :], axis=-1)
    positive = gaps[gaps > 1e-9]
    return float(positive.min()) if positive.size else 1.0


def _label(text: str) -> str:
    return "Γ" if text.upper() in ("GAMMA", "G", "\\GAMMA") else text


def band_view(crystal: Crystal, bands: BandsLike, *, unit: str = "THz",
              max_numbers: int = MAX_VECTOR_NUMBERS) -> dict[str, Any]:
    """The ``"crystal"`` view data of `bands` (computed from `crystal`): bands, patterns, supercells.

    Parameters
    ----------
    crystal : Crystal
        The crystal the bands belong to (cell, atoms, force constants).
    bands : BandStructure
        Its band structure (`Crystal.band_structure`).
    unit : {"THz", "cm^-1"}
        The unit of the band axis.
    max_numbers : int
        Most numbers of displacement patterns kept (`MAX_VECTOR_NUMBERS`).

    Raises
    ------
    ValueError
        An unknown `unit`; bands whose branches are not the crystal's.
    """
    if unit not in UNITS:
        raise ValueError(f"unit is {unit!r}; expected one of {', '.join(UNITS)}")
    n3 = crystal.n_branches
    if bands.omega.shape[1] != n3:
        raise ValueError(f"bands have {bands.omega.shape[1]} branches; crystal {crystal.name!r} has {n3}: pass the "
                         "crystal the bands were computed from")
    values = bands.frequencies_thz() if unit == "THz" else bands.wavenumbers_cm1()
    n_q = len(bands.qpoints)
    stride = max(1, -(-(n_q * n3 * n3 * 2) // max(1, int(max_numbers))))
    kept = np.unique(np.concatenate([np.arange(0, n_q, stride), [k for k, _ in bands.labels]])).astype(int)
    solved = phonons(crystal, bands.qpoints[kept], vectors=True)
    assert solved.vectors is not None
    vectors = np.array(solved.vectors)
    if getattr(crystal, "nac", None) is not None:  # a polar crystal's Gamma: the LO-TO split of its segment, as the bands
        for row, k in enumerate(kept):
            q = bands.qpoints[k]
            segment = next((s for s in bands.segments if s[0] <= k <= s[1]), None)
            if segment is not None and np.allclose(q, np.rint(q), atol=1e-12):
                direction = bands.qpoints[segment[1]] - bands.qpoints[segment[0]]
                if np.any(direction):
                    vectors[row] = np.asarray(phonons(crystal, q[None], vectors=True, q_direction=direction).vectors)[0]
    weights = 1.0 / np.sqrt(np.repeat(crystal.masses, 3))
    points = []
    for row, k in enumerate(kept):
        rank = np.empty(n3, dtype=np.intp)  # band branch b is the solve's rank[b]-th eigenpair (both from D(q))
        rank[np.argsort(bands.omega[k], kind="stable")] = np.arange(n3)
        patterns = vectors[row][:, rank] * weights[:, None]  # (3n, branches): e / sqrt(m)
        atoms = np.linalg.norm(patterns.reshape(crystal.n_atoms, 3, n3), axis=1).max(axis=0)
        patterns = patterns / np.where(atoms > 0, atoms, 1.0)[None, :]  # largest atom moves 1
        pairs = np.stack([patterns.real, patterns.imag], axis=-1).transpose(1, 0, 2).reshape(n3, -1)
        points.append({"index": int(k), "q": np.round(bands.qpoints[k], 6).tolist(),
                       "repeats": repeats(crystal, bands.qpoints[k]).tolist(),
                       "vectors": np.round(pairs, 5).tolist()})
    labels: list[list[Any]] = []
    for k, text in bands.labels:  # one label per place: "U|K" where the path breaks, a joint's point once
        if labels and abs(bands.distances[k] - bands.distances[labels[-1][0]]) <= 1e-12 * max(1.0, bands.distances[-1]):
            if _label(text) != labels[-1][1].rpartition("|")[2]:
                labels[-1][1] += "|" + _label(text)
            continue
        labels.append([int(k), _label(text)])
    start_label = labels[1][0] if len(labels) > 1 else 0  # the first special point after the start
    start = int(np.argmin(np.abs(kept - start_label)))
    note = ""
    if stride > 1:
        note = f"the modes of every {stride}th q-point kept (the size cap, {max_numbers:,} numbers); a click picks the nearest"
    if np.any(bands.omega < 0):
        note = (note + "; " if note else "") + "negative frequencies are imaginary (unstable) modes"
    return {"kind": "crystal", "style": "crystal", "unit": unit.replace("^-1", "⁻¹"),
            "cell": np.round(crystal.cell, 6).tolist(), "fractional": np.round(crystal.fractional, 6).tolist(),
            "elements": [str(s) for s in crystal.symbols], "scale": round(MAX_MOTION * _shortest_distance(crystal), 5),
            "frames": FRAMES,
            "bands": {"x": np.round(bands.distances, 6).tolist(), "values": np.round(values, 5).tolist(),
                      "labels": labels, "breaks": [int(k) for k in bands.breaks]},
            "points": points, "start": [start, n3 - 1], "note": note}


def bands_view(crystal: Crystal, bands: BandsLike, *, unit: str = "THz") -> View:
    """`band_view` as a `View` (what ``bands.show(crystal)`` returns in a notebook)."""
    return View(band_view(crystal, bands, unit=unit), title=f"bands of {crystal.name!r} with their modes")


def frame_positions(data: dict[str, Any], point: int, branch: int) -> tuple[NDArray[np.float64], bool]:
    """(n_frames, n_cells n_atoms, 3) positions of the page's animation of `branch` at ``data["points"][point]``,
    and whether the mode is imaginary: the sums of the page's script (module docstring), in the length unit."""
    entry = data["points"][point]
    cell = np.asarray(data["cell"])
    fractional = np.asarray(data["fractional"])
    pairs = np.asarray(entry["vectors"][branch]).reshape(-1, 3, 2)
    u = pairs[..., 0] + 1j * pairs[..., 1]
    n = entry["repeats"]
    cells = np.array([(a, b, c) for a in range(n[0]) for b in range(n[1]) for c in range(n[2])], dtype=float)
    where = (cells[:, None, :] + fractional[None, :, :]).reshape(-1, 3)
    amplitudes = np.tile(u, (len(cells), 1)) * np.exp(2j * np.pi * where @ np.asarray(entry["q"]))[:, None]
    rest = where @ cell
    imaginary = data["bands"]["values"][entry["index"]][branch] < 0
    count = data["frames"]
    if imaginary:
        turned = amplitudes * np.exp(-0.5j * np.angle(np.sum(amplitudes ** 2)))
        growth = np.arange(count) / max(count - 1, 1)
        return rest[None] + data["scale"] * growth[:, None, None] * turned.real[None], True
    phi = 2.0 * np.pi * np.arange(count) / count
    return rest[None] + data["scale"] * np.real(amplitudes[None] * np.exp(-1j * phi)[:, None, None]), False
