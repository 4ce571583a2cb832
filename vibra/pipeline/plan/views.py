"""The data of a scene's interactive 3-D view: sites, bonds and each drawn mode's displacements.

`mode_view` turns a built system and its modes into a small JSON-ready dict that the report's
scene page hands to 3Dmol.js (`vibra.pipeline.report.views` writes the page side): one XYZ
"atom" per drawn site with its element (molecules: the real ones; chains: one element per
distinct mass; networks: carbon for each C-alpha), the bonds to draw (a molecule's bonds, the
springs of a chain, a network's backbone), and per drawn mode the displacement of every site,
scaled so that its largest motion is `MAX_MOTION` of the shortest drawn bond (the page's
amplitude slider multiplies it). Long chains show the evenly spaced sites of
`vibra.pipeline.render.chain_sites`, as the PNG does; another system of more than `MAX_SITES`
sites has no view (the page says so) to keep the page small.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from vibra.pipeline.render import chain_sites

__all__ = ["mode_view", "MAX_SITES", "MAX_MOTION", "CHAIN_SPACING"]

#: Sites above which no interactive view is written (its JSON would pass ~1 MB per mode).
MAX_SITES = 5000
#: The largest displacement of a drawn mode, as a fraction of the shortest drawn bond.
MAX_MOTION = 0.35
#: Spacing of a chain's drawn sites in the view, in Å-like view units (the chain's own length
#: unit does not matter to the picture; 3Dmol.js draws in Å).
CHAIN_SPACING = 3.0
#: Elements given to a chain's distinct masses, lightest first (colours only).
CHAIN_ELEMENTS = ("C", "O", "N", "S", "P", "Fe", "Cl", "Br")


def _round(values: np.ndarray, digits: int = 4) -> list[Any]:
    return np.round(values, digits).tolist()


def _mode_label(scene: Any, modes: Any, k: int, symmetry: Any = None) -> str:
    """'mode 6: 1595.0 cm⁻¹, A1 (C2v)' (molecules), '... Hz' (SI), 'ω = ...' otherwise."""
    if scene.kind == "molecule" and modes.units.time_s is not None:
        species = symmetry.species[k] if symmetry is not None and symmetry.species[k] else ""
        group = f", {species} ({symmetry.group})" if species else ""
        return f"mode {k}: {float(modes.wavenumbers_cm1()[k]):.1f} cm⁻¹{group}"
    if modes.units.time_s is not None:
        return f"mode {k}: {float(modes.frequencies_hz()[k]):.4g} Hz"
    return f"mode {k}: ω = {float(modes.omega[k]):.4g}"


def _displacements(system: Any, shape: np.ndarray) -> np.ndarray:
    """(n_sites, 3) displacement of every site (zeros at frozen dofs and unused axes)."""
    full = np.asarray(system.expand(shape), dtype=float).reshape(system.n_sites, system.dim)
    out = np.zeros((system.n_sites, 3))
    out[:, : system.dim] = full
    return out


def mode_view(scene: Any, system: Any, modes: Any, indices: Sequence[int], *,
              structure: Any = None, symmetry: Any = None) -> dict[str, Any] | None:
    """The interactive view of the drawn modes `indices` of a chain, molecule or network scene.

    Parameters
    ----------
    scene : Scene
    system : System
        The built system (positions, masses, `expand`).
    modes : Modes
        Its modes, with shapes.
    indices : sequence of int
        The drawn modes.
    structure : MoleculeStructure, optional
        A molecule's elements and bonds (the plan's ``structure`` step).
    symmetry : MoleculeSymmetry, optional
        A molecule's point group and species (the plan's ``symmetry`` step), for the labels.

    Returns
    -------
    dict or None
        ``{"kind", "style", "elements", "positions", "bonds", "modes": [{"label", "vectors"}],
        "note"}`` (positions in Å for molecules and networks, view units for chains), or None
        when the scene has no geometry to show (another kind, or more than `MAX_SITES` sites).
    """
    too_many = scene.kind != "chain" and system.n_sites > MAX_SITES  # a chain shows at most 41 sites
    if scene.kind not in ("chain", "molecule", "network") or too_many or not indices:
        return None
    shapes = np.asarray(modes.shapes)
    positions = np.zeros((system.n_sites, 3))
    positions[:, : system.dim] = np.asarray(system.positions, dtype=float).reshape(system.n_sites, system.dim)
    note = ""
    if scene.kind == "chain":
        sites = chain_sites(system.masses)
        masses = np.asarray(system.masses, dtype=float)[sites]
        kinds = sorted(set(masses.tolist()))
        elements = [CHAIN_ELEMENTS[min(kinds.index(m), len(CHAIN_ELEMENTS) - 1)] for m in masses]
        x = positions[sites, 0]
        span = float(x.max() - x.min()) if len(x) > 1 else 0.0
        drawn = np.zeros((len(sites), 3))
        drawn[:, 0] = (x - x.min()) / span * CHAIN_SPACING * (len(sites) - 1) if span > 0 else 0.0
        bonds = [(i, i + 1) for i in range(len(sites) - 1)]
        if len(sites) < system.n_sites:
            note = f"{len(sites)} of {system.n_sites} sites shown, evenly spaced"
        style = "chain"
    elif scene.kind == "molecule":
        sites = np.arange(system.n_sites)
        drawn = positions
        if structure is not None:
            elements = list(structure.symbols)
            bonds = [(int(i), int(j)) for i, j in structure.bonds]
        else:  # no structure step: the element of nearest standard mass, bonds from distances
            from vibra.molecules import bonds_from_distances, symbols_from_masses

            elements = list(symbols_from_masses(system.masses))
            bonds = [(int(i), int(j)) for i, j in bonds_from_distances(np.asarray(system.positions), elements)]
        style = "molecule"
    else:  # a network: C-alpha atoms, joined along the chain where they are consecutive residues
        sites = np.arange(system.n_sites)
        drawn = positions
        elements = ["C"] * system.n_sites
        gaps = np.linalg.norm(np.diff(positions, axis=0), axis=1)
        bonds = [(i, i + 1) for i in range(system.n_sites - 1) if gaps[i] < 4.5]  # C-alpha spacing 3.8 Å
        style = "network"
    lengths = [float(np.linalg.norm(drawn[i] - drawn[j])) for i, j in bonds]
    scale_length = min((v for v in lengths if v > 0), default=CHAIN_SPACING if style == "chain" else 1.5)
    views = []
    for k in indices:
        vectors = _displacements(system, shapes[:, k])[sites]
        largest = float(np.linalg.norm(vectors, axis=1).max())
        if largest > 0:
            vectors = vectors * (MAX_MOTION * scale_length / largest)
        views.append({"label": _mode_label(scene, modes, int(k), symmetry), "vectors": _round(vectors)})
    return {"kind": scene.kind, "style": style, "elements": elements, "positions": _round(drawn),
            "bonds": [list(b) for b in bonds], "modes": views, "note": note}
