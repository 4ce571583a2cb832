"""The data of a scene's interactive 3-D view: sites, bonds and each drawn mode's displacements.

`mode_view` turns a built system and its modes into a small JSON-ready dict that the report's
scene page hands to 3Dmol.js (`vibra._results.display` builds the data from what this chooses and writes the page side,
the same for notebooks): one XYZ
"atom" per drawn site with its element (molecules: the real ones; chains: one element per
distinct mass; networks: carbon for each C-alpha), the bonds to draw (a molecule's bonds, the
springs of a chain, a network's backbone), and per drawn mode the displacement of every site,
scaled so that its largest motion is `MAX_MOTION` of the shortest drawn bond (the page's
amplitude slider multiplies it). Long chains show the evenly spaced sites of
`vibra.pipeline.render.chain_sites`, as the PNG does; another system of more than `MAX_SITES`
sites has no view (the page says so) to keep the page small.
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING, Any, Protocol, Sequence

import numpy as np

from vibra._core.filesystem import atomic_write_text
from vibra._results.display import CHAIN_SPACING, MAX_MOTION, MAX_SITES, mode_label, mode_view_data
from vibra.pipeline.plan.tables import mode_names
from vibra.pipeline.render import chain_sites

if TYPE_CHECKING:
    from pathlib import Path

    from vibra.crystals import Crystal
    from vibra.crystals.bands import BandStructure
    from vibra.modes import Modes
    from vibra.pipeline.plan.analysis import MoleculeSymmetry
    from vibra.pipeline.plan.model import Plan
    from vibra.pipeline.render import MoleculeStructure
    from vibra.pipeline.scene import Scene
    from vibra.system import System

__all__ = ["mode_view", "write_band_view", "MAX_SITES", "MAX_MOTION", "CHAIN_SPACING"]

# MAX_SITES (no interactive view above it: its JSON would pass ~1 MB per mode), MAX_MOTION and
# CHAIN_SPACING are `vibra._results.display`'s: the report and notebooks draw alike.
#: Elements given to a chain's distinct masses, lightest first (colours only).
CHAIN_ELEMENTS = ("C", "O", "N", "S", "P", "Fe", "Cl", "Br")


class BandViewContext(Protocol):
    """What `write_band_view` reads and records of a plan's execution state (`vibra.pipeline.plan.steps`)."""

    system: Crystal
    out_dir: Path
    outputs: list[str]
    captions: list[str]


def _mode_label(scene: Scene, modes: Modes, k: int, symmetry: MoleculeSymmetry | None = None) -> str:
    """'ν2: 1595.0 cm⁻¹, A1 (C2v)' (molecules), 'mode 1: ... Hz' (SI), 'mode 1: ω = ...' otherwise."""
    species = symmetry.species[k] if scene.kind == "molecule" and symmetry is not None and symmetry.species[k] else ""
    label = mode_label(modes, k, wavenumbers=scene.kind == "molecule", suffix=f", {species} ({symmetry.group})"
                       if species else "")
    name = mode_names(scene, modes, symmetry).get(int(k))  # the table's and the renders' name: "ν2", "mode 1"
    return label.replace(f"mode {k}:", f"{name}:", 1) if name else label


def mode_view(scene: Scene, system: System, modes: Modes, indices: Sequence[int], *,
              structure: MoleculeStructure | None = None, symmetry: MoleculeSymmetry | None = None) -> dict[str, Any] | None:
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
    positions = np.zeros((system.n_sites, 3))
    positions[:, : system.dim] = np.asarray(system.positions, dtype=float).reshape(system.n_sites, system.dim)
    note = ""
    if scene.kind == "chain":
        sites = chain_sites(system.masses)
        masses = np.asarray(system.masses, dtype=float)[sites]
        kinds = sorted(set(masses.tolist()))
        elements = [CHAIN_ELEMENTS[min(kinds.index(m), len(CHAIN_ELEMENTS) - 1)] for m in masses]
        bonds = [(i, i + 1) for i in range(len(sites) - 1)]
        if len(sites) < system.n_sites:
            note = f"{len(sites)} of {system.n_sites} sites shown, evenly spaced"
        style = "chain"
    elif scene.kind == "molecule":
        sites = np.arange(system.n_sites)
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
        elements = ["C"] * system.n_sites
        gaps = np.linalg.norm(np.diff(positions, axis=0), axis=1)
        bonds = [(i, i + 1) for i in range(system.n_sites - 1) if gaps[i] < 4.5]  # C-alpha spacing 3.8 Å
        style = "network"
    labels = [_mode_label(scene, modes, int(k), symmetry) for k in indices]
    return mode_view_data(system, modes, indices, kind=style, elements=elements, bonds=bonds, sites=sites,
                          labels=labels, note=note)


def write_band_view(plan: Plan, context: BandViewContext, bands: BandStructure, *, unit: str) -> None:
    """Write a crystal scene's ``<scene>_view.json``: `vibra.crystals.animation.band_view` of its bands
    (the page draws the bands; a clicked point animates that branch's mode on a supercell)."""
    from vibra.crystals.animation import band_view

    view = band_view(context.system, bands, unit=unit)
    name = f"{plan.scene.name}_view.json"
    atomic_write_text(context.out_dir / name, json.dumps(view, separators=(",", ":"), allow_nan=False))
    context.outputs.append(name)
    context.captions.append(f"{plan.scene.title}: the bands in 3-D: click a point of the bands to animate that "
                            "branch's mode on a supercell")
